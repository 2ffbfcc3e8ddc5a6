#!/usr/bin/env python3
"""Robustness benchmark: random rooms with random known luminaires, located with defaults.

Rooms of random size (3-10 m, 2.5-4 m high), 1-6 luminaires (ceiling, wall, pendant; random
flux 500-5000 lm, the same within a scene), direct light or with interreflection
(reflectance 0.3-0.7). Only the flux is given to locate. Prints found/true, spurious, the
worst error and seconds per scene, and a summary. Seeded: the same scenes every run.

Usage: python bench/bench_random.py [--n 20] [--seed 7] [--interreflection]
"""
import argparse
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import numpy as np  # noqa: E402

from invrad_wb.core.synthetic import generate as g  # noqa: E402
from invrad_wb.core.inverse.locate import locate  # noqa: E402
from invrad_wb.core.model.luminaires import Luminaire  # noqa: E402
from invrad_wb.core.forward.render import render  # noqa: E402
from invrad_wb.core.synthetic.scenarios import match  # noqa: E402


def random_scene(rng, interreflection):
    w, d = rng.uniform(3, 10), rng.uniform(3, 8)
    h = rng.uniform(2.5, 4.0)
    rho = rng.uniform(0.3, 0.7) if interreflection else 0.0
    scene = g.box_room((w, d, h), cell=0.1, reflectance=rho)
    flux = float(rng.uniform(500, 5000))
    n = int(rng.integers(1, 7))
    lums, tries = [], 0
    while len(lums) < n and tries < 200:
        tries += 1
        kind = rng.choice(["ceiling", "ceiling", "ceiling", "wall", "pendant"])
        if kind == "ceiling":
            p, nrm = [rng.uniform(0.4, w - 0.4), rng.uniform(0.4, d - 0.4), h], [0, 0, -1]
        elif kind == "pendant":
            p, nrm = [rng.uniform(0.6, w - 0.6), rng.uniform(0.6, d - 0.6),
                      rng.uniform(max(1.9, h - 1.2), h - 0.3)], [0, 0, -1]
        else:
            side = int(rng.integers(4))
            z = rng.uniform(1.8, h - 0.3)
            if side == 0:
                p, nrm = [0.0, rng.uniform(0.4, d - 0.4), z], [1, 0, 0]
            elif side == 1:
                p, nrm = [w, rng.uniform(0.4, d - 0.4), z], [-1, 0, 0]
            elif side == 2:
                p, nrm = [rng.uniform(0.4, w - 0.4), 0.0, z], [0, 1, 0]
            else:
                p, nrm = [rng.uniform(0.4, w - 0.4), d, z], [0, -1, 0]
        if all(np.linalg.norm(np.array(p) - l.position) > 1.0 for l in lums):
            lums.append(Luminaire(p, nrm, flux))
    lux = render(scene, lums, interreflection=interreflection)
    return scene.with_vertex_lux(lux), lums, (w, d, h, rho)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=20)
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--interreflection", action="store_true")
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    ok = 0
    times, worst = [], []
    for k in range(args.n):
        scene, lums, (w, d, h, rho) = random_scene(rng, args.interreflection)
        t = time.perf_counter()
        r = locate(scene, lums[0].flux_lm)
        dt = time.perf_counter() - t
        m = match(r.luminaires, lums)
        good = m["found"] == m["true"] and m["spurious"] == 0 and (m["max_error_cm"] or 99) < 10
        ok += good
        times.append(dt)
        worst.append(m["max_error_cm"] or float("nan"))
        print(f"{k:3d} {w:4.1f}x{d:4.1f}x{h:3.1f} rho {rho:.2f} flux {lums[0].flux_lm:6.0f}"
              f" {m['found']}/{m['true']} spurious {m['spurious']} max err"
              f" {m['max_error_cm'] or float('nan'):6.2f} cm {dt:6.2f} s {'ok' if good else 'FAIL'}",
              flush=True)
        if not good:
            for l in lums:
                print(f"      true  {np.round(l.position, 2)} {np.round(l.normal, 2)}")
            for l in r.luminaires:
                print(f"      found {np.round(l.position, 2)} {np.round(l.normal, 2)}"
                      f" score {l.score}")
    print(f"{ok}/{args.n} scenes fully right; median {np.median(times):.2f} s per scene;"
          f" median worst error {np.nanmedian(worst):.2f} cm")


if __name__ == "__main__":
    main()
