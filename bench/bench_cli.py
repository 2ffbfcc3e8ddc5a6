#!/usr/bin/env python3
"""The whole command line, per room: ``python -m invrad_wb locate SCENE --flux F -o R.json``
as a user runs it (a new process: interpreter start, imports, reading, OpenCL context,
kernel builds, votes, refinement, radiosity, writing), stage by stage, in wall and CPU
seconds; beside it the same method in plain numpy (``locate(..., backend="numpy")``, every
kernel's numpy twin, run in this process) and, with ``--before REV``, the CLI of another
revision. Runs alternate (before, after, numpy; then again), so that the shared machine's
load falls on all of them alike; each figure is the median over ``--rounds``.

Scenes: the shipped ``examples/office.ply`` (interreflection, 4 x 3000 lm), the generated
``l_room`` with reflectance 0.6 and ``two_ceiling`` in direct light (``--quick``: the
office only). Each CLI run's RESULT.json is compared with the other revision's, timings
left out: a faster stage that changed the answer shows as "results differ".

Stages come from ``bench/cli_probe.py`` (see there); under ``postprocess`` (the
refinement) three parts of it, inclusive and overlapping: the optimiser's runs, the
luminaires' interreflection solves, the final refit on every target vertex; ``start + exit`` is the interpreter's
start, ``site`` and its finalisation after the exit hooks (the child's seconds minus those
the probe saw). CPU seconds hardly depend on
what else runs; wall seconds do. Compare ratios within one run.

Figures (2026-11-26, 2-core machine under heavy load, load average 9-12: wall seconds
mean little there; CPU seconds, medians of 2 alternating rounds, ``--before 8bd114a``):
office 3.28 -> 2.84 CPU s (ratio to the numpy run 0.152 -> 0.131); l_room rho 0.6
4.80 -> 4.89 (no gain: its refinement is the optimiser's numpy work); two_ceiling
direct 1.41 -> 1.26. The interreflection solves fell to half (office 0.32 -> 0.16,
l_room 0.35 -> 0.25); what is left of a run is the optimiser (office 0.97 of 2.84 s,
l_room 2.2 of 4.9), votes, imports and the radiosity model.

Round 9 (2026-11-26, load average 5-7, 3 alternating rounds, ``--before 930e8fa``; CPU s
before -> after): the optimiser's arithmetic without temporaries or copies, a cell grid for
the mount-clearance face tests, close luminaire pairs by plain floats. The optimiser (LM)
office 1.09 -> 0.71, l_room rho 0.6 1.41 -> 0.98, two_ceiling direct 0.10 -> 0.10;
locate office 2.10 -> 1.62, l_room 2.95 -> 2.34, two_ceiling 0.68 -> 0.60; whole CLI
office 2.63 -> 2.45 (ratio to the numpy run 0.133 -> 0.123), l_room 3.48 -> 2.95 (0.114 ->
0.097), two_ceiling 1.09 -> 1.09 (0.056 -> 0.055); every RESULT.json identical to
930e8fa's. (Under this load the medians of one stage and of the total come from different
rounds: office's stages add up to 2.16 s after.) Left: imports (0.34 s: numpy, scipy for
ndimage and lu_factor, pyopencl), votes (0.3-0.5 s, the kernel), the visibility rays of the
optimiser in rooms with occluders (l_room: 0.5 M rays), the radiosity model and solves.

Round 10 (2026-11-26, load average 4-5, 3 alternating rounds, ``--before 1391db4``; CPU s
before -> after): the stored radiosity gather keeps the kernel's rows as read back (no
second (k, P) array: the office's final refit gathers 11,326 vertices x 1180 patches),
peaks' three image filters in numpy (scipy.ndimage's numbers bit for bit; no
scipy.ndimage import), the optimiser's Jacobian at an accepted trial reusing the trial's
forward model (office: 370 of 405 Jacobian calls). Office: imports 0.489 -> 0.333,
radiosity 0.221 -> 0.156, optimiser (LM) 0.928 -> 0.777, locate 2.181 -> 1.889, whole CLI
3.000 -> 2.410 (ratio to the numpy run 0.127 -> 0.102); l_room rho 0.6 4.400 -> 4.295
(0.096 -> 0.094; its optimiser is the 257 visibility calls, 1.3 M shadow rays, and the
model); two_ceiling direct 1.569 -> 1.491 (0.060 -> 0.057; imports 0.508 -> 0.419: no
scipy at all there). Every RESULT.json identical to 1391db4's, and office ``--aim
fixed``'s. ("indirect solves" now holds scipy.linalg's import, which happens at the
first radiosity solve; the "imports" stage counts it either way.) Left: numpy (0.15 s)
and pyopencl (0.1 s) imports, the votes kernel (0.3-0.55 s), the optimiser's numpy
arithmetic and, in rooms with occluders, its shadow rays; the radiosity LU (0.05-0.1 s).

Round 10b (2026-11-26, load average 3.5-4.5, ``--before 96e5d04``; CPU s before -> after):
classify_rooms imports the design modules (accent, evaluate, layouts, room, en12464,
metrics, images) only for a room with a work-plane level, and the winding check computes
the winding numbers in front of a room's faces only where those behind lie inside (half
of the check). Both are small: about 0.01 s of imports (measured alone, 30 alternating
processes: start + imports + read + classify, median 0.375 -> 0.374, min 0.273 -> 0.264)
and 0.01 s of reading the office (check_winding 0.046-0.051 -> 0.035-0.043), under this
machine's noise. Whole CLI, 3 rounds with the numpy run: office 2.850 -> 2.799 (ratio
0.117 -> 0.114; the numpy run took 24.5 CPU s), l_room rho 0.6 3.813 -> 3.986 (0.094 ->
0.098), two_ceiling direct 1.432 -> 1.212 (0.058 -> 0.049); 5 rounds without it: office
2.264 -> 2.406, l_room 3.657 -> 3.917, two_ceiling 1.239 -> 1.284. One side's medians
move by up to 0.6 s between runs at this load, so these runs show no change. Every RESULT.json
identical to 96e5d04's, and office ``--aim fixed``'s. Tried and dropped: BLAS on one thread
for the radiosity LU (scipy's OpenBLAS is loaded after the room's thread limit, so it
runs on 2 threads; one thread changes the factors' last bits), unique_rows on one int64 key
(np.unique with return_index sorts stably: no faster than the lexsort), the pseudo-Huber
cost's constant factor made once (same numbers, no measurable gain). Where a run goes
(sampling the office in one process, and its 31 optimiser runs replayed): the
optimiser's residuals and model 40 %, the mount-clearance projection 16 % and the
Marquardt step 15 % of the LM; the votes are one cast of the kernel (0.29 CPU s, weights
4.5 ms); imports are now third-party (numpy 0.12 s, pyopencl 0.1 s with pytools,
importlib.metadata, attrs, sqlite3 and platformdirs for its kernel invokers, scipy.linalg
0.07 s at the first radiosity solve; invrad's own 0.04 s). Watch out when measuring: this
environment sets PYTHONDONTWRITEBYTECODE=1, so a fresh "before" checkout compiles every
module on every run (bench_cli removes it; a hand-made comparison must too).

Round 11 (2026-11-26, load average 3-5, ``--before fe3448d``; CPU s before -> after): BLAS
on one thread from the command line's start (OpenBLAS's second thread busy-waited 0.11
CPU s after numpy's import, scipy's 0.03 s after the LU: perf, one office run), the
radiosity's LU and solves on one BLAS thread always (so the factors do not depend on the
cores), FaceTest.contains through the cell grid (305 -> 83 us per call off the inner
pixels on the office's 4,800 floor triangles). Office, 9 alternating rounds without the
numpy run: 2.560 -> 2.413 (imports 0.434 -> 0.385, votes 0.338 -> 0.302, LM 0.823 ->
0.804, radiosity 0.184 -> 0.155); 5 rounds with the numpy run: 2.323 -> 2.202 (ratio
0.102 -> 0.096, numpy 22.8 CPU s). With the numpy run, 3 rounds, twice: office 2.391 ->
2.337 (ratio 0.111 -> 0.108) and 2.199 -> 2.596 (0.102 -> 0.120: one LM median 0.60 ->
0.90 at this load, the 9-round run shows none), l_room rho 0.6 3.907 -> 3.301 (0.111 ->
0.094) and 3.633 -> 3.383 (0.090 -> 0.084), two_ceiling direct 1.105 -> 1.235 (0.049 ->
0.054) and 1.266 -> 1.272 (0.052 -> 0.052). Every RESULT.json identical to fe3448d's, and
office ``--aim fixed``'s. At this load the same code's office ratio ranges 0.097-0.120
between 3-round runs: the 5- and 9-round runs (after below before by 0.12-0.15 CPU s, 5-6
%) are the ones to go by. Tried and dropped: the votes
kernel returning early for a point that lights none of a block's 16 pixels (other vote
bits: the compiler contracts the accumulation differently; and no faster, 0.28 -> 0.33 s
a cast), work-groups of 8, 32, 128 (0.27-0.30 s a cast each, the same votes).

Round 12 (2026-11-26, load average 4-5, ``--before 2f69707``; CPU s before -> after):
scipy's LU without ``scipy.linalg`` (its LAPACK module loaded alone,
``core/accel/lapack.py``: the same routines, the same numbers; the import brought
scipy.sparse and cost 0.034-0.038 CPU s, the module alone 0.004-0.005), and the exact-vote
kernel skipping, 16 points at a time, the points that certainly give none of a block's 16
pixels a vote (``no_vote_in_row``: every vote bit for bit as without it; one office cast
0.143 -> 0.110, l_room 0.326 -> 0.256, two_ceiling 0.173 -> 0.151). Office, ``--quick``,
5 rounds, twice: imports 0.225 -> 0.174 and 0.211 -> 0.166, votes 0.156 -> 0.126 and
0.157 -> 0.125, indirect solves 0.165 -> 0.111 and 0.179 -> 0.119, whole CLI 1.376 ->
1.184 and 1.274 -> 1.198 (ratio to the numpy run 0.106 -> 0.091 and 0.107 -> 0.100,
numpy 12.98 and 11.95 CPU s); all three rooms, 3 rounds: office 1.225 -> 1.134 (0.107 ->
0.099), l_room rho 0.6 1.954 -> 1.780 (0.093 -> 0.084; votes 0.337 -> 0.274), two_ceiling
direct 0.624 -> 0.574 (0.048 -> 0.044). Every RESULT.json identical to 2f69707's. The
optimiser's medians (0.31-0.36, code unchanged) and the numpy run's (11.5-13.0 s) move
as much between runs as the gain: the office ratio is now 0.09-0.10 at this load, not
robustly below 0.10. Tried and dropped (votes the same bit for bit, no faster): the row
test in log space without its x < 1/2 limit (0.113), the points that may vote listed
first and then cast in one loop (0.113-0.117), whole groups of 16 points skipped only
where none may vote (0.17: slower than no test; the kernel's cost per cast pair rises
whenever its point loop is restructured, which is why skipping seven pairs in ten saves a
quarter), work-groups of 8, 64, 128 (0.110-0.111). Left: the optimiser (0.31-0.34 of
1.13-1.20 s, ``refine.py``), numpy's (0.055 CPU s) and pyopencl's (0.048: pytools,
importlib.metadata, attrs) imports, the LU (0.037), the form-factor kernels.

Round 12, later the same day: the row test was reverted (4aa2606) while finding why
PoCL 3.0 from PyPI aborts on an AMD Zen 4 (not the cause: 2f69707 aborts there too;
``core/accel/probe.py``); it is not back until it is checked under that driver. Its share
above: one office cast 0.143 -> 0.110 CPU s (about 0.03 of the whole CLI's 1.1-1.2 s), so
the office ratio without it is about 0.003 higher than the figures here; not measured.

Round 12 (h12-opt) (2026-11-26, load average 2-4, ``--before 436b785``; CPU s before ->
after): the optimiser's arithmetic, the same numbers bit for bit: mid-air luminaires'
Jacobian without the product with dpos() = I and the concatenation (+ 0.0 does what the
product did to -0.0), the lambertian gradient written in the Jacobian's (k, K, 3) layout
(no transposing copy), the row division by Ep repeated per row (no loops of 3), the
pseudo-Huber cost and its IRLS weights in one scratch array (``optim.pseudo_huber``,
``pseudo_huber_weights``, ``divide_rows``). Per Jacobian (office, one process): three
mid-air luminaires 155 -> 36 us, one 43 -> 21 us; all 405 of a run 36 -> 17 ms (the
gradient 27 -> 31 ms: its strided writes). The office's 31 optimiser runs replayed in one
process, 5 passes, 3 alternations: 0.273-0.278 -> 0.256-0.263. Office ``--quick``: 9
rounds without the numpy run, LM 0.281 -> 0.258, whole CLI 0.997 -> 0.964; 5 rounds with
it, LM 0.279 -> 0.260, whole 0.983 -> 0.974 (ratio 0.092 -> 0.092, numpy 10.6 CPU s); all
rooms, 3 rounds: office LM 0.283 -> 0.259, whole 0.993 -> 0.986 (ratio 0.089 -> 0.088),
l_room rho 0.6 1.830 -> 1.766 (0.085 -> 0.082), two_ceiling direct 0.684 -> 0.616 (0.051 ->
0.046). Every RESULT.json identical to 436b785's, and office ``--aim fixed``'s. Tried and
dropped: the Marquardt step's ``J * w`` with w repeated per row (no gain measured). Left
in the office's LM (0.26 s): the forward model (87 us a call, 583 calls), the Marquardt
step (78 us, 552: einsum on the transposed J, the solve), the allowed-region projection
(36 us, 1031 calls: surface luminaires near a border, ``map_contains_all``), the
gradient (76 us, 405), the cost (20 us, 957).

Usage: python bench/bench_cli.py [--before REV] [--rounds N] [--quick] [--no-numpy]
"""
import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, HERE)

import numpy as np  # noqa: E402

STAGES = ("start + exit", "imports", "read scene", "opencl context", "kernel builds",
          "requirements check", "locate", "write", "cli other")
CORE = ("sampling", "maps", "votes", "postprocess", "  optimiser (LM)", "  indirect solves",
        "  final refit", "radiosity")


def scenes(tmp, quick):
    """(name, path, flux) of the benchmark's scenes, generated ones written to ``tmp``."""
    out = [("office", os.path.join(HERE, "examples", "office.ply"), 3000.0)]
    if quick:
        return out
    from invrad_wb.core.io.sceneio import write_scene
    from invrad_wb.core.synthetic.scenarios import known_scene
    for name, rho in (("l_room", 0.6), ("two_ceiling", 0.0)):
        scene, true = known_scene(name, reflectance=rho)
        path = os.path.join(tmp, f"{name}.ply")
        write_scene(path, scene)
        out.append((f"{name} rho {rho:g}", path, true[0].flux_lm))
    return out


def checkout(rev, tmp):
    """A copy of revision ``rev`` of this repository (``git archive``) in ``tmp``."""
    dest = os.path.join(tmp, "before")
    os.makedirs(dest)
    tar = subprocess.run(["git", "-C", HERE, "archive", rev], check=True,
                         capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", dest], input=tar, check=True)
    return dest


def cli_run(root, scene, flux, tmp):
    """One CLI process on ``root``'s code; returns (stages {name: [wall, cpu]}, core
    {stage: [wall, cpu]}, RESULT.json's data)."""
    out = os.path.join(tmp, "result.json")
    probe = os.path.join(tmp, "probe.json")
    for f in (out, probe):
        if os.path.exists(f):
            os.remove(f)
    env = dict(os.environ, INVRAD_PROBE_ROOT=root, INVRAD_PROBE_OUT=probe)
    env.pop("PYTHONDONTWRITEBYTECODE", None)     # a user's Python caches bytecode
    cmd = [sys.executable, os.path.join(HERE, "bench", "cli_probe.py"), "locate", scene,
           "--flux", f"{flux:g}", "-o", out]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    p = subprocess.run(cmd, cwd=root, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    if p.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({p.returncode}):\n{p.stderr[-2000:]}")
    with open(probe, encoding="utf-8") as fh:
        pr = json.load(fh)
    with open(out, encoding="utf-8") as fh:
        data = json.load(fh)
    stages = dict(pr["stages"])
    stages["start + exit"] = [wall - pr["inside"][0], cpu - pr["inside"][1]]
    stages["total"] = [wall, cpu]
    core = dict(pr["core"])
    for k, v in pr.get("detail", {}).items():
        core["  " + k] = v
    return stages, core, data


def numpy_run(path, flux):
    """The same method in plain numpy in this process: (wall, cpu) of read + locate."""
    from invrad_wb.core.inverse.locate import locate
    from invrad_wb.core.io.sceneio import read_scene
    t, c = time.perf_counter(), time.process_time()
    locate(read_scene(path), flux, backend="numpy")
    return [time.perf_counter() - t, time.process_time() - c]


def answer(data):
    """RESULT.json without what may differ between identical runs (seconds)."""
    d = dict(data)
    d.pop("timings", None)
    for r in d.get("rooms", []):
        r.pop("stopped_after_s", None)
    return json.dumps(d, sort_keys=True)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--before", metavar="REV", help="also time the CLI of this revision")
    ap.add_argument("--rounds", type=int, default=None, help="3 (--quick: 2)")
    ap.add_argument("--quick", action="store_true", help="the office only, 2 rounds")
    ap.add_argument("--no-numpy", action="store_true", help="no numpy reference")
    a = ap.parse_args()
    rounds = a.rounds or (2 if a.quick else 3)
    tmp = tempfile.mkdtemp(prefix="invrad-bench-cli-")
    try:
        sides = [("after", HERE)]
        if a.before:
            sides.insert(0, ("before", checkout(a.before, tmp)))
        print(f"python {sys.version.split()[0]}, {os.cpu_count()} cores; sides: "
              + ", ".join(f"{n} = {r}" for n, r in sides) + f"; {rounds} round(s), medians")
        for name, path, flux in scenes(tmp, a.quick):
            for side, root in sides:     # warm-up: bytecode and PoCL's kernel cache
                cli_run(root, path, flux, tmp)
            runs = {side: [] for side, _ in sides}
            ref = []
            answers = {}
            for _ in range(rounds):
                for side, root in sides:
                    st, core, data = cli_run(root, path, flux, tmp)
                    runs[side].append((st, core))
                    answers.setdefault(side, answer(data))
                if not a.no_numpy:
                    ref.append(numpy_run(path, flux))
            _table(name, flux, runs, ref, answers)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def _med(values):
    return float(np.median(values)) if values else float("nan")


def _table(name, flux, runs, ref, answers):
    sides = list(runs)
    print(f"\n== {name} (--flux {flux:g}): seconds per room, wall / CPU")
    print(f"{'stage':20s}" + "".join(f" {s + ' wall':>12s} {s + ' cpu':>11s}" for s in sides))
    for stage in STAGES + ("total",):
        row = []
        for s in sides:
            for k in (0, 1):
                row.append(_med([st.get(stage, [0.0, 0.0])[k] for st, _ in runs[s]]))
        print(f"{stage:20s}" + "".join(f" {v:12.3f}" for v in row))
    print(f"{'core (in locate)':20s}")
    for stage in CORE:
        row = []
        for s in sides:
            for k in (0, 1):
                row.append(_med([c.get(stage, [0.0, 0.0])[k] for _, c in runs[s]]))
        print(f"{'  ' + stage:20s}" + "".join(f" {v:12.3f}" for v in row))
    tot = {s: [_med([st["total"][k] for st, _ in runs[s]]) for k in (0, 1)] for s in sides}
    if "before" in tot:
        print(f"speed-up after vs before: wall {tot['before'][0] / tot['after'][0]:.2f}x,"
              f" CPU {tot['before'][1] / tot['after'][1]:.2f}x; results "
              + ("identical" if answers["before"] == answers["after"] else "DIFFER"))
    if ref:
        rw, rc = _med([r[0] for r in ref]), _med([r[1] for r in ref])
        print(f"numpy reference (same method, numpy twins, in this process): wall {rw:.2f} s,"
              f" CPU {rc:.2f} s")
        for s in sides:
            print(f"  CLI {s} / numpy reference: wall {tot[s][0] / rw:.3f},"
                  f" CPU {tot[s][1] / rc:.3f}")


if __name__ == "__main__":
    main()
