#!/usr/bin/env python3
"""Verification-report benchmark: the report of a verify (figures, EXR rasters, tables,
metrics.json, HTML and the PDF through WeasyPrint) for a 6 x 4 x 3 m box meshed at 10 cm
with floor targets, for a few and for many luminaires; CPU seconds per stage (the machine
is shared: CPU seconds are steadier than wall seconds).

Measured (2 shared cores under load ~9, CPU s): 10 luminaires 6.8 (figures 3.5, PDF 2.0,
rasters 0.7), 10,000 luminaires 10.3 (figures 3.7, PDF 4.1: its 200-row luminaire table
costs 2 s, metrics.json 0.6, tables 0.2). Tried and not kept: the luminaire table with
'table-layout: fixed' (PDF 4.0 -> 3.1 s, but other column widths and one page more) and
'break-inside: auto' on it (no change); the no-target grey as one Gouraud tripcolor
instead of a PolyCollection (no change: matplotlib's TriMesh makes a Path per triangle
too).

The first row also pays the imports (matplotlib, WeasyPrint, OpenImageIO).

Usage: python bench/bench_report.py [--many 10000]
"""
import argparse
import os
import shutil
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import numpy as np  # noqa: E402

from invrad_wb.core.model.luminaires import Luminaire  # noqa: E402
from invrad_wb.core.output import report as R  # noqa: E402
from invrad_wb.core.synthetic import generate as g  # noqa: E402

#: the report's stages timed (module functions of invrad_wb.core.output.report)
STAGES = ("_room_figures", "_room_rasters", "_write_tables", "_write_json", "_write_pdf")


def timed_stages():
    """Wrap the report's stages to add up their CPU seconds into the returned dict."""
    spent = {}

    def wrap(name, f):
        def timed(*a, **k):
            c = time.process_time()
            try:
                return f(*a, **k)
            finally:
                spent[name] = spent.get(name, 0.0) + time.process_time() - c
        return timed
    for name in STAGES:
        setattr(R, name, wrap(name, getattr(R, name)))
    return spent


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--many", type=int, default=10000)
    args = ap.parse_args()
    spent = timed_stages()
    scene = g.box_room((6, 4, 3), cell=0.1, reflectance=0.5)
    rng = np.random.default_rng(0)
    achieved = 200.0 + rng.normal(0, 10, len(scene.vertices))
    targets = np.where(scene.vertices[:, 2] < 0.01, 210.0, np.nan)
    print(f"{'luminaires':>10s} {'wall s':>7s} {'CPU s':>6s}  "
          + " ".join(f"{s.strip('_'):>13s}" for s in STAGES))
    for n in (10, args.many):
        xy = rng.uniform([0.2, 0.2], [5.8, 3.8], size=(n, 2))
        lums = [Luminaire([x, y, 2.95], [0, 0, -1], 12000.0 / n) for x, y in xy]
        out = tempfile.mkdtemp(prefix="bench-report-")
        spent.clear()
        try:
            t, c = time.perf_counter(), time.process_time()
            R.build_report(scene, targets, achieved, lums, os.path.join(out, "rep"),
                           project="box")
            wall, cpu = time.perf_counter() - t, time.process_time() - c
        finally:
            shutil.rmtree(out)
        print(f"{n:10d} {wall:7.2f} {cpu:6.2f}  "
              + " ".join(f"{spent.get(s, 0.0):13.2f}" for s in STAGES), flush=True)


if __name__ == "__main__":
    main()
