#!/usr/bin/env python3
"""Memory budget benchmark: the vote maps' estimated bytes against the measured peak.

``locate`` on examples/office.ply at finer and finer vote-map resolutions, each run in its
own process; prints the canvas estimate that the memory budget checks
(:func:`invrad_wb.core.inverse.votemaps.canvas_memory`), the measured peak resident memory,
and the peak above the coarsest run's (the part that grows with the pixels). The estimate
should stay above that growth: otherwise raise ``CANVAS_BYTES_PER_PIXEL``.

Usage: python bench/bench_memory.py [--resolutions 0.1 0.05 0.02 0.01] [--backend numpy]
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

from invrad_wb.core.io.sceneio import read_scene  # noqa: E402
from invrad_wb.core.inverse.locate import LocateSettings  # noqa: E402
from invrad_wb.core.inverse.votemaps import canvas_memory, dummy_layer_heights  # noqa: E402

SCENE = os.path.join(ROOT, "examples", "office.ply")

# one locate in a child of a child: RUSAGE_CHILDREN then holds exactly that run's peak
_RUN = """
import resource, subprocess, sys
rc = subprocess.call(sys.argv[1:], stdout=subprocess.DEVNULL)
print(rc, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)
"""


def peak_kb(args):
    out = subprocess.run([sys.executable, "-c", _RUN, sys.executable, "-m", "invrad_wb",
                          *args], capture_output=True, text=True, cwd=ROOT, check=True)
    rc, kb = out.stdout.split()
    return int(rc), int(kb)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--resolutions", type=float, nargs="+", default=[0.1, 0.05, 0.02, 0.01])
    ap.add_argument("--backend", default="auto")
    a = ap.parse_args()
    scene = read_scene(SCENE)
    s = LocateSettings()
    planes = [p.index for p in scene.planes if p.room == 0 and not p.is_virtual]
    layers = len(dummy_layer_heights(scene, 0, s.dummy_spacing_m, s.dummy_count,
                                     s.dummy_lowest_m))
    rows, base = [], None
    with tempfile.TemporaryDirectory() as tmp:
        for r in sorted(a.resolutions, reverse=True):
            est, pixels = canvas_memory(scene, 0, planes, r, layers)
            rc, kb = peak_kb(["locate", SCENE, "--flux", "3000", "--resolution", str(r),
                              "--backend", a.backend, "-o", os.path.join(tmp, "r.json")])
            peak = kb * 1024
            base = peak if base is None else base
            rows.append({"resolution_m": r, "pixels": int(pixels), "estimate_mb": est / 2**20,
                         "peak_mb": peak / 2**20, "growth_mb": (peak - base) / 2**20,
                         "exit": rc})
    print(f"{'m/pixel':>8} {'pixels':>10} {'estimate MB':>12} {'peak MB':>9}"
          f" {'growth MB':>10} {'B/pixel':>8}")
    for row in rows:
        per = (row["growth_mb"] * 2**20 / row["pixels"]) if row["growth_mb"] > 0 else 0.0
        print(f"{row['resolution_m']:8.3f} {row['pixels']:10d} {row['estimate_mb']:12.1f}"
              f" {row['peak_mb']:9.1f} {row['growth_mb']:10.1f} {per:8.0f}")
    print(json.dumps(rows))


if __name__ == "__main__":
    main()
