#!/usr/bin/env python3
"""Generate the toroidal Poisson-disk tile used to place voting points (thesis 4.1.1.1).

The thesis precalculates a tileable Poisson-disk sampling of a square and looks it up at run
time; so do we. Output: ``tables/poisson_tile.npz`` with ``points (N, 2)`` in [0, 1)^2, the
minimum toroidal distance ``r_min`` and the parameters, plus ``poisson_tile.json`` with a
sha256 checksum. Deterministic (fixed seed): re-running reproduces the file bit for bit.

Method: Bridson's dart throwing on a torus with an acceleration grid, then the points are
ordered so that every prefix is itself well spread (greedy farthest-point order), which lets
a caller thin the tile to a lower density by taking a prefix.

Usage: python tables/make_poisson_tile.py [--n 4096] [--check]
"""
import argparse
import hashlib
import json
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
VERSION = 1


def bridson_torus(n_target, seed, k=30):
    rng = np.random.default_rng(seed)
    # radius for ~n_target points: maximal Poisson density ~ 0.7 / r^2 per unit area
    r = np.sqrt(0.7 / n_target)
    cell = r / np.sqrt(2)
    g = int(np.floor(1 / cell))
    cell = 1.0 / g
    grid = -np.ones((g, g), dtype=np.int64)
    pts = []

    def fits(p):
        gx, gy = int(p[0] / cell), int(p[1] / cell)
        for dx in range(-2, 3):
            for dy in range(-2, 3):
                j = grid[(gx + dx) % g, (gy + dy) % g]
                if j >= 0:
                    d = np.abs(pts[j] - p)
                    d = np.minimum(d, 1 - d)
                    if d @ d < r * r:
                        return False
        return True

    first = rng.random(2)
    pts.append(first)
    grid[int(first[0] / cell), int(first[1] / cell)] = 0
    active = [0]
    while active:
        i = active[rng.integers(len(active))]
        found = False
        ang = rng.random(k) * 2 * np.pi
        rad = r * (1 + rng.random(k))
        for a, rr in zip(ang, rad):
            p = np.mod(pts[i] + rr * np.array([np.cos(a), np.sin(a)]), 1.0)
            if fits(p):
                pts.append(p)
                grid[int(p[0] / cell) % g, int(p[1] / cell) % g] = len(pts) - 1
                active.append(len(pts) - 1)
                found = True
                break
        if not found:
            active.remove(i)
    return np.array(pts), r


def farthest_point_order(pts, seed):
    rng = np.random.default_rng(seed + 1)
    n = len(pts)
    order = np.empty(n, dtype=np.int64)
    order[0] = rng.integers(n)
    d = np.full(n, np.inf)
    for i in range(1, n):
        diff = np.abs(pts - pts[order[i - 1]])
        diff = np.minimum(diff, 1 - diff)
        d = np.minimum(d, np.einsum("ij,ij->i", diff, diff))
        order[i] = int(np.argmax(d))
    return pts[order]


def min_torus_distance(pts):
    best = np.inf
    for i in range(len(pts)):
        diff = np.abs(pts[i + 1:] - pts[i])
        diff = np.minimum(diff, 1 - diff)
        if len(diff):
            best = min(best, float(np.sqrt(np.einsum("ij,ij->i", diff, diff).min())))
    return best


def build(n, seed):
    pts, r = bridson_torus(n, seed)
    pts = farthest_point_order(pts, seed)
    return pts, r


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=4096, help="approximate number of points")
    ap.add_argument("--seed", type=int, default=20091)
    ap.add_argument("--check", action="store_true",
                    help="regenerate in memory and compare with the stored tile")
    args = ap.parse_args(argv)
    t0 = time.time()
    pts, r = build(args.n, args.seed)
    dt = time.time() - t0
    npz = os.path.join(HERE, "poisson_tile.npz")
    if args.check:
        stored = np.load(npz)["points"]
        same = stored.shape == pts.shape and np.array_equal(stored, pts)
        print("poisson tile matches" if same else "poisson tile DIFFERS from its generator")
        return 0 if same else 1
    rmin = min_torus_distance(pts)
    tmp = npz + ".tmp.npz"
    np.savez(tmp, points=pts, r_min=rmin, seed=args.seed)
    os.replace(tmp, npz)
    with open(npz, "rb") as fh:
        digest = hashlib.sha256(fh.read()).hexdigest()
    meta = {"generator": "tables/make_poisson_tile.py", "version": VERSION, "n_points": len(pts),
            "seed": args.seed, "radius_param": r, "r_min": rmin, "seconds": round(dt, 2),
            "numpy": np.__version__, "sha256": digest}
    with open(os.path.join(HERE, "poisson_tile.json"), "w") as fh:
        json.dump(meta, fh, indent=2)
        fh.write("\n")
    print(json.dumps(meta, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
