#!/usr/bin/env python3
"""Where a room's time goes: per-stage seconds per room on the bundled scenarios, in one run.

For every scenario of :data:`~invrad_wb.core.synthetic.scenarios.SCENARIOS` at reflectance
0 (direct light) and 0.6 (interreflection), and the shipped ``examples/office.ply``:

* I/O: the scene written as binary PLY and read back (what ``locate FILE`` reads);
* sampling, maps, votes, refinement (post-processing: peaks, greedy selection, joint
  refinement), radiosity (the model and gather operator of the refinement's indirect
  light), as ``locate`` times them, per room;
* the scene's accuracy (found / true, spurious, worst error), so a faster stage that
  changed the answer shows.

Stages are timed twice: in wall seconds (what a user waits) and in CPU seconds of this
process, all threads (PoCL's included). The machines are shared and noisy; CPU seconds
hardly depend on what else runs, wall seconds do. Compare ratios within one run.
Kernels are built (and the first OpenCL context made) before anything is timed.

Usage: python bench/bench_stages.py [--quick] [--backend auto|opencl|numpy]
"""
import argparse
import os
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import numpy as np  # noqa: E402

STAGES = ("io", "sampling", "maps", "votes", "postprocess", "radiosity")


class _CpuClock:
    """Stand-in for the ``time`` module inside :mod:`invrad_wb.core.inverse.locate` whose
    ``time()`` is this process's CPU time (all threads)."""

    def __getattr__(self, name):
        return getattr(time, name)

    @staticmethod
    def time():
        return time.process_time()


def _locate_timed(scene, flux, backend, clock):
    from invrad_wb.core.inverse import locate as L, locate_problem, locate_result
    timed = (L, locate_problem, locate_result)       # the modules that take stage times
    saved = [m.time for m in timed]
    for m in timed:
        m.time = _CpuClock() if clock == "cpu" else time
    try:
        t = (time.process_time if clock == "cpu" else time.perf_counter)()
        r = L.locate(scene, flux, backend=backend)
        r.timings["total"] = (time.process_time if clock == "cpu" else time.perf_counter)() - t
    finally:
        for m, s in zip(timed, saved):
            m.time = s
    return r


def _io(scene, tmp, clock):
    """Seconds to write and read the scene as PLY; returns (seconds, scene read back)."""
    from invrad_wb.core.io.sceneio import read_scene, write_scene
    now = time.process_time if clock == "cpu" else time.perf_counter
    path = os.path.join(tmp, "scene.ply")
    t = now()
    write_scene(path, scene)
    back = read_scene(path)
    return now() - t, back


def cases(quick):
    from invrad_wb.core.synthetic.scenarios import SCENARIOS, known_scene
    names = SCENARIOS[:3] if quick else SCENARIOS
    for rho in (0.0, 0.6):
        for name in names:
            scene, true = known_scene(name, reflectance=rho)
            yield f"{name}", rho, scene, true, true[0].flux_lm
    here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    office = os.path.join(here, "examples", "office.ply")
    if os.path.exists(office):
        from invrad_wb.core.io.sceneio import read_scene
        from invrad_wb.core.model.luminaires import load_luminaires
        scene = read_scene(office)
        true = load_luminaires(os.path.join(here, "examples", "office_true.json"))
        rho = float(np.max(scene.face_reflectance)) if len(scene.faces) else 0.0
        yield "office.ply", rho, scene, true, true[0].flux_lm


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="three scenarios")
    ap.add_argument("--backend", default="auto")
    a = ap.parse_args()
    from invrad_wb.core.accel.device import check_backend, get_env
    from invrad_wb.core.synthetic.scenarios import known_scene, match
    backend = check_backend(a.backend)
    print(f"backend: {backend}" + (f" ({get_env().description})" if backend == "opencl"
                                   else ""))
    warm, wt = known_scene("pillar", reflectance=0.6)          # builds every kernel
    _locate_timed(warm, wt[0].flux_lm, backend, "wall")
    head = (f"{'scene':12s} {'rho':>4s} {'rooms':>5s} {'found':>6s} {'spur':>4s} {'max cm':>7s}"
            + "".join(f" {s[:8]:>8s}" for s in STAGES) + f" {'total':>7s}")
    sums = {}
    tmp = tempfile.mkdtemp(prefix="invrad-stages-")
    try:
        for clock in ("wall", "cpu"):
            print(f"\n== {clock} seconds per room, by stage ('postprocess': peaks and the"
                  " joint refinement)")
            print(head)
            for name, rho, scene, true, flux in cases(a.quick):
                io_s, back = _io(scene, tmp, clock)
                r = _locate_timed(back, flux, backend, clock)
                m = match(r.luminaires, true)
                n = max(1, len(r.rooms))
                t = dict(r.timings, io=io_s)
                key = (clock, rho > 0)
                acc = sums.setdefault(key, {s: 0.0 for s in STAGES + ("total", "rooms")})
                for s in STAGES:
                    acc[s] += t[s]
                acc["total"] += t["total"] + io_s
                acc["rooms"] += n
                print(f"{name:12s} {rho:4.1f} {n:5d} {m['found']:>3d}/{m['true']:<2d}"
                      f" {m['spurious']:4d} {float('nan') if m['max_error_cm'] is None else m['max_error_cm']:7.2f}"
                      + "".join(f" {t[s] / n:8.3f}" for s in STAGES)
                      + f" {(t['total'] + io_s) / n:7.3f}", flush=True)
    finally:
        import shutil
        shutil.rmtree(tmp, ignore_errors=True)
    print("\n== Mean seconds per room over the scenes")
    print(f"{'clock':5s} {'light':16s}" + "".join(f" {s[:8]:>8s}" for s in STAGES)
          + f" {'total':>7s}")
    for (clock, ir), acc in sorted(sums.items()):
        n = acc["rooms"]
        print(f"{clock:5s} {'interreflection' if ir else 'direct':16s}"
              + "".join(f" {acc[s] / n:8.3f}" for s in STAGES) + f" {acc['total'] / n:7.3f}")


if __name__ == "__main__":
    main()
