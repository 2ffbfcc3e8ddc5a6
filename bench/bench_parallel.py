#!/usr/bin/env python3
"""Whole floors: rooms per second with 1 and 2 local workers and a local Dask cluster, peak
memory for 10 and 50 rooms, per-stage seconds per room, and a suite of scenes located with
one CLI process per scene against one batch process. Everything in one run (the machines
are noisy: compare ratios within a run).

Each configuration runs in a fresh process (its own peak memory; the workers' peak is the
largest child's). Usage: python bench/bench_parallel.py [--rooms 50] [--quick]
"""
import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

#: room footprints cycled along the floor (m)
SIZES = ((4.0, 4.0), (5.0, 4.0), (3.0, 4.0), (6.0, 5.0), (4.0, 3.0))


def floor(n, cell=0.2, rho=0.5):
    """n box rooms in a row, one or two 3000 lm downlights each, targets rendered."""
    from invrad_wb.core.forward.render import render
    from invrad_wb.core.model.luminaires import Luminaire
    from invrad_wb.core.synthetic import generate as g
    rooms = [SIZES[i % len(SIZES)] for i in range(n)]
    scene, origins = g.floor_of_rooms(rooms, cell=cell, reflectance=rho)
    lums = []
    for i, ((w, d), o) in enumerate(zip(rooms, origins)):
        spots = [(0.5 * w, 0.5 * d)] if w * d < 18 else [(0.3 * w, 0.5 * d), (0.72 * w, 0.45 * d)]
        for dx, dy in spots:
            lums.append(Luminaire([o[0] + dx, o[1] + dy, 3.0], [0, 0, -1], 3000.0, room=i))
    return scene.with_vertex_lux(render(scene, lums, interreflection=rho > 0)), lums


def run_floor(path, workers, dask):
    """In a fresh process: locate on a floor read from ``path``; prints one JSON line."""
    from invrad_wb.core.inverse.locate import locate
    from invrad_wb.core.io.sceneio import read_scene
    from invrad_wb.core.model.luminaires import load_luminaires
    from invrad_wb.core.synthetic.scenarios import match
    t = time.perf_counter()
    scene = read_scene(path)
    read_s = time.perf_counter() - t
    true = load_luminaires(path[:-4] + "_true.json")
    peaks = _PeakRss()
    import resource
    r0 = resource.getrusage(resource.RUSAGE_SELF)
    t = time.perf_counter()
    r = locate(scene, 3000.0, workers=workers, dask=dask)
    wall = time.perf_counter() - t
    r1 = resource.getrusage(resource.RUSAGE_SELF)
    kids_cpu = resource.getrusage(resource.RUSAGE_CHILDREN)      # the joined workers
    own, kids = peaks.stop()
    m = match(r.luminaires, true, radius=0.3)
    print(json.dumps({"rooms": len(scene.rooms), "seconds": wall, "read_s": read_s,
                      "found": m["found"], "true": m["true"], "spurious": m["spurious"],
                      "max_err_cm": m["max_error_cm"], "timings": r.timings, "rss_mb": own,
                      "worker_rss_mb": kids,
                      "cpu_main": (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
                      - peaks.cpu,
                      "cpu_workers": kids_cpu.ru_utime + kids_cpu.ru_stime}))


class _PeakRss:
    """Peak resident memory (MB) of this process (VmHWM: its own since exec, unlike
    getrusage, which keeps the forking parent's) and of its largest descendant (workers,
    Dask's nanny workers), sampled every 50 ms with psutil (a dependency of Dask)."""

    def __init__(self):
        import threading
        import psutil
        self.me = psutil.Process()
        self.kids = 0.0
        self.done = threading.Event()
        self.cpu = 0.0
        self.thread = threading.Thread(target=self._watch, daemon=True)
        self.thread.start()

    def _watch(self):
        while not self.done.wait(0.05):
            for c in self.me.children(recursive=True):
                try:
                    self.kids = max(self.kids, c.memory_info().rss / 2**20)
                except Exception:
                    pass
        #: this sampler's own CPU seconds (psutil reads /proc: not locate's work)
        self.cpu = time.thread_time()

    def stop(self):
        self.done.set()
        self.thread.join()
        with open("/proc/self/status") as fh:
            hwm = next(int(l.split()[1]) for l in fh if l.startswith("VmHWM:")) / 1024
        return hwm, self.kids


_FLOORS = {}


def floor_file(n, tmp):
    """The floor of n rooms written once as PLY (+ its true luminaires)."""
    if n not in _FLOORS:
        from invrad_wb.core.io.sceneio import write_scene
        from invrad_wb.core.io.jsonout import write_luminaires_json
        scene, lums = floor(n)
        path = os.path.join(tmp, f"floor{n}.ply")
        write_scene(path, scene)
        write_luminaires_json(path[:-4] + "_true.json", lums)
        _FLOORS[n] = path
    return _FLOORS[n]


def _child(n, workers, dask, tmp):
    cp = subprocess.run([sys.executable, __file__, "--child", floor_file(n, tmp), str(workers),
                         dask or "-"], capture_output=True, text=True, cwd=ROOT)
    if cp.returncode:
        raise SystemExit(f"child failed:\n{cp.stderr[-3000:]}")
    return json.loads(cp.stdout.strip().splitlines()[-1])


def floors(n, quick, tmp):
    print(f"\n== A floor of {n} rooms (one or two 3000 lm downlights each, rho 0.5,"
          " interreflection), locate with the flux given")
    print("  (CPU s: this process / its workers, all threads; on a shared machine the wall"
          " seconds depend on what else runs, the CPU seconds hardly: 2 workers can reach"
          " 2x only if their CPU sum stays near one process's)")
    print(f"{'how':22s} {'seconds':>8s} {'rooms/s':>8s} {'found':>7s} {'spur':>4s}"
          f" {'max cm':>7s} {'peak MB':>8s} {'child MB':>9s} {'CPU s':>13s}")
    configs = [("1 process", 1, None), ("2 local workers", 2, None)]
    if not quick:
        configs.append(("local Dask, 2 workers", 2, "local"))
    rows = {}
    for name, w, dask in configs:
        r = _child(n, w, dask, tmp)
        rows[name] = r
        print(f"{name:22s} {r['seconds']:8.2f} {n / r['seconds']:8.2f}"
              f" {r['found']:>3d}/{r['true']:<3d} {r['spurious']:4d} {r['max_err_cm'] or 0:7.2f}"
              f" {r['rss_mb']:8.0f} {r['worker_rss_mb']:9.0f}"
              f" {r['cpu_main']:6.1f}/{r['cpu_workers']:<6.1f}")
    base = rows["1 process"]["seconds"]
    cpu1 = rows["1 process"]["cpu_main"] + rows["1 process"]["cpu_workers"]
    for name, r in rows.items():
        cpu = r["cpu_main"] + r["cpu_workers"]
        print(f"  speed-up {name}: {base / r['seconds']:.2f}x; CPU {cpu:.1f} s ="
              f" {cpu / cpu1:.2f} x one process's")
    t = rows["1 process"]["timings"]
    print("  per room, 1 process: " + ", ".join(
        f"{k} {1000 * t[k] / n:.0f} ms" for k in ("sampling", "maps", "votes", "postprocess",
                                                  "radiosity")))
    return rows


def memory(quick, tmp):
    print("\n== Peak memory by floor size (2 local workers; the main process reads the PLY"
          " and keeps every room's result, each worker one room at a time)")
    sizes = (5, 10) if quick else (10, 50)
    for n in sizes:
        r = _child(n, 2, None, tmp)
        print(f"  {n:3d} rooms: main process {r['rss_mb']:.0f} MB, largest worker"
              f" {r['worker_rss_mb']:.0f} MB, {r['seconds']:.1f} s (PLY read {r['read_s']:.2f} s)")


def cli_suite(quick):
    from invrad_wb.core.io.sceneio import write_scene
    from invrad_wb.core.synthetic.scenarios import SCENARIOS, known_scene
    names = SCENARIOS[:4] if quick else SCENARIOS
    tmp = tempfile.mkdtemp(prefix="invrad-bench-")
    try:
        for name in names:
            scene, true = known_scene(name, reflectance=0.5)
            write_scene(os.path.join(tmp, f"{name}.ply"), scene)
        cli = [sys.executable, "-m", "invrad_wb", "locate"]
        t = time.perf_counter()
        for name in names:
            subprocess.run(cli + [os.path.join(tmp, f"{name}.ply"), "--flux", "3000", "-o",
                                  os.path.join(tmp, f"{name}.json")], check=True,
                           capture_output=True, cwd=ROOT)
        per_scene = time.perf_counter() - t
        t = time.perf_counter()
        subprocess.run(cli + [tmp, "--flux", "3000", "-o", os.path.join(tmp, "batch")],
                       check=True, capture_output=True, cwd=ROOT)
        batch = time.perf_counter() - t
        same = all(json.load(open(os.path.join(tmp, f"{n}.json")))["luminaires"] ==
                   json.load(open(os.path.join(tmp, "batch", f"{n}.json")))["luminaires"]
                   for n in names)
        print(f"\n== {len(names)} scenes (rho 0.5): one CLI process per scene {per_scene:.1f} s,"
              f" one batch process {batch:.1f} s ({per_scene / batch:.2f}x); per-scene CLI"
              f" overhead {(per_scene - batch) / len(names):.2f} s; same results: {same}")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--rooms", type=int, default=50)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--child", nargs=3)
    a = ap.parse_args()
    if a.child:
        path, w, dask = a.child
        return run_floor(path, int(w), None if dask == "-" else dask)
    from invrad_wb.core.accel.workers import usable_cores
    print(f"invrad parallel benchmark: {usable_cores()} usable cores; 'peak MB': the main"
          " process, 'child MB': the largest worker process (sampled)")
    tmp = tempfile.mkdtemp(prefix="invrad-bench-floor-")
    try:
        floors(10 if a.quick else a.rooms, a.quick, tmp)
        memory(a.quick, tmp)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    cli_suite(a.quick)


if __name__ == "__main__":
    main()
