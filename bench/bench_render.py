#!/usr/bin/env python3
"""Forward-solve benchmark: a 6 x 4 x 3 m room meshed at 8 cm, direct light and with
interreflection, OpenCL vs numpy, in one run (machines are noisy: compare ratios); then
``--many`` luminaires (default 10,000) 5 cm under the ceiling of the same room at 10 cm,
Lambertian and with a 40-degree intensity distribution, and in the room with a pillar
(render with interreflections, the default backend).

Measured (2 shared cores under load ~8, PoCL CPU; 10,000 luminaires, 40 degrees, same
scenes, render only): box 30.1 s wall / 18.2 s CPU -> 23.8 s / 11.8 s, pillar 125.2 s /
61.8 s -> 32.0 s / 16.0 s, after the photometric shadow rays went to the segment kernel
in batches and the cone prefilter to matrix products (lux equal within 2e-12). Then the
photometric direct light went into one OpenCL kernel (kernels/photometric.cl: cone test,
table lookup, shadow ray; 2 shared cores, load 8-11, runs alternated old/new, wall / CPU
s): box 78.3 / 12.9 and 54.1 / 15.2 -> 21.3 / 4.7 and 20.1 / 5.0, pillar 81.5 / 19.3 and
85.6 / 18.3 -> 38.1 / 7.3 and 19.3 / 6.2 (mean lux 219.7231 both; pillar 210.6482 ->
210.6483, float32). Through the CLI, ``verify`` of 10,000 luminaires with
tests/data/photometry/spot.ies on the example one_ceiling room (render and report, load
~8): 135.2 s wall / 57.7 CPU s -> 66.4 / 22.7, Em 146.366827 -> 146.366819 lx.

Usage: python bench/bench_render.py [--cell 0.08] [--repeat 3] [--many 10000]
       [--only-many] [--photometric]
"""
import argparse
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import numpy as np  # noqa: E402

from invrad_wb.core.synthetic import generate as g  # noqa: E402
from invrad_wb.core.accel.clenv import opencl_available, get_env  # noqa: E402
from invrad_wb.core.model.luminaires import Luminaire  # noqa: E402
from invrad_wb.core.forward.render import render  # noqa: E402


def best_of(fn, repeat):
    times = []
    out = None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return min(times), out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--cell", type=float, default=0.08)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--many", type=int, default=10000,
                    help="luminaires of the many-luminaire figures (0: none)")
    ap.add_argument("--only-many", action="store_true", help="only those figures")
    ap.add_argument("--photometric", action="store_true",
                    help="of those, only the 40-degree distribution")
    args = ap.parse_args()
    if not args.only_many:
        few(args)
    if args.many:
        many(args.many, args.photometric)


def many(n, photometric_only=False):
    """Render ``n`` luminaires (the cost that grows as luminaires x points)."""
    from invrad_wb.core.model.photometry import Photometry
    rng = np.random.default_rng(0)
    xy = rng.uniform([0.2, 0.2], [5.8, 3.8], size=(n, 2))
    gam = np.arange(181.0)
    narrow = Photometry(np.tile(np.where(gam < 40, np.cos(np.radians(gam)), 0.0), (361, 1)),
                        name="40 degrees")
    print(f"\n{n} luminaires 5 cm under the ceiling, 6 x 4 x 3 m, mesh 10 cm, with"
          " interreflection")
    print(f"{'room':8s} {'distribution':14s} {'seconds':>8s} {'CPU s':>8s} {'vertices':>9s}"
          "  mean lux")
    for room, scene in (("box", g.box_room((6, 4, 3), cell=0.1, reflectance=0.5)),
                        ("pillar", g.pillar_room(cell=0.1, reflectance=0.5))):
        for name, phot in (("lambertian", None), ("40 degrees", narrow))[photometric_only:]:
            lums = [Luminaire([x, y, 2.95], [0, 0, -1], 12000.0 / n, photometry=phot)
                    for x, y in xy]
            scene.__dict__.pop("_bvh", None)
            scene.__dict__.pop("_radiosity", None)
            t, cpu = time.perf_counter(), time.process_time()
            lux = render(scene, lums)
            print(f"{room:8s} {name:14s} {time.perf_counter() - t:8.2f}"
                  f" {time.process_time() - cpu:8.2f} {len(scene.vertices):9d}"
                  f"  {lux.mean():8.4f}", flush=True)


def few(args):
    lums = [Luminaire([x, y, 3.0], [0, 0, -1], 3000.0) for x in (1.5, 4.5) for y in (1.0, 3.0)]
    backends = ["numpy"] + (["opencl"] if opencl_available() else [])
    if "opencl" in backends:
        print(f"OpenCL device: {get_env().description}")
    print(f"room 6 x 4 x 3 m, mesh {args.cell * 100:.0f} cm, {len(lums)} point luminaires")
    scene = g.box_room((6, 4, 3), cell=args.cell, reflectance=0.6)
    rows = []
    for backend in backends:
        for inter in (False, True):
            def run():
                # drop the per-scene caches: the BVH and the radiosity model are part of
                # the time of a first render
                scene.__dict__.pop("_bvh", None)
                scene.__dict__.pop("_radiosity", None)
                return render(scene, lums, interreflection=inter, backend=backend), scene
            run()  # builds the kernels
            t, (lux, s) = best_of(run, args.repeat)
            rows.append((backend, inter, t, len(s.vertices), lux))
    print(f"{'backend':8s} {'light':16s} {'seconds':>8s} {'vertices':>9s}  mean lux")
    for backend, inter, t, nv, lux in rows:
        print(f"{backend:8s} {'+ interreflection' if inter else 'direct':16s} {t:8.3f}"
              f" {nv:9d}  {lux.mean():8.2f}")
    if len(backends) == 2:
        for inter in (False, True):
            tn = [r[2] for r in rows if r[0] == "numpy" and r[1] == inter][0]
            tc = [r[2] for r in rows if r[0] == "opencl" and r[1] == inter][0]
            ln = [r[4] for r in rows if r[0] == "numpy" and r[1] == inter][0]
            lc = [r[4] for r in rows if r[0] == "opencl" and r[1] == inter][0]
            print(f"{'interreflection' if inter else 'direct'}: OpenCL {tn / tc:.1f}x faster"
                  f" than numpy; max difference {np.abs(ln - lc).max():.3g} lx")


if __name__ == "__main__":
    main()
