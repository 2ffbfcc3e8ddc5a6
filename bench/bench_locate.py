#!/usr/bin/env python3
"""Locate benchmark: accuracy and seconds per scenario for both vote models, votes per
second OpenCL vs numpy, and how time grows with voting density and with the number of
planes. Everything in one run (the machines are noisy: compare ratios within a run).

Usage: python bench/bench_locate.py [--quick] [--skip-numpy] [--rho R] [--accuracy-only]
       [--free-flux-only]
"""
import argparse
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import numpy as np  # noqa: E402

from invrad_wb.core.accel.clenv import opencl_available, get_env  # noqa: E402
from invrad_wb.core.inverse.locate import locate  # noqa: E402
from invrad_wb.core.inverse.sampling import voting_points  # noqa: E402
from invrad_wb.core.synthetic.scenarios import (known_scene, match, SCENARIOS,  # noqa: E402
                                                 MIXED_SCENARIOS)
from invrad_wb.core.inverse.votemaps import build_canvas  # noqa: E402
from invrad_wb.core.inverse.votes import vote_weights, cast_exact_numpy, cast_exact_opencl  # noqa: E402
from invrad_wb.core.inverse.votes_ellipse import (cast_ellipse_numpy, cast_ellipse_opencl,  # noqa: E402
                                          ellipse_votes_params)


def timed(fn, repeat=1):
    best, out = np.inf, None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


def raw_peak_errors(result, true):
    """Distance (cm) from each true luminaire to the nearest unrefined peak."""
    peaks = [p.position for run in result.rooms for p in run.peaks]
    if not peaks:
        return [None] * len(true)
    P = np.array(peaks)
    return [round(float(np.min(np.linalg.norm(P - t.position, axis=1))) * 100, 1)
            for t in true]


def accuracy_table(backend, models, rhos, repeat):
    print("\n== Accuracy and seconds per scene (true flux given; 0.10 m pixels, ~3000 points)")
    print(f"{'scenario':12s} {'rho':>4s} {'model':8s} {'found':>6s} {'spur':>4s}"
          f" {'max err cm':>10s} {'mean cm':>8s} {'raw peak cm':>12s} {'seconds':>8s}  (votes / refine / radiosity)")
    rows = []
    for rho in rhos:
        for name in SCENARIOS:
            scene, true = known_scene(name, reflectance=rho, backend=backend)
            for model in models:
                t, r = timed(lambda: locate(scene, true[0].flux_lm, vote_model=model,
                                            backend=backend), repeat)
                m = match(r.luminaires, true)
                raw = locate(scene, true[0].flux_lm, vote_model=model, backend=backend,
                             refine=False, threshold=64)
                rp = raw_peak_errors(raw, true)
                rp_s = "/".join("-" if e is None else f"{e:.0f}" for e in rp)
                tm = r.timings
                mx = m["max_error_cm"] if m["max_error_cm"] is not None else float("nan")
                mean = float(np.mean(m["errors_cm"])) if m["errors_cm"] else float("nan")
                print(f"{name:12s} {rho:4.1f} {model:8s} {m['found']:>3d}/{m['true']:<2d}"
                      f" {m['spurious']:4d} {mx:10.2f} {mean:8.2f}"
                      f" {rp_s:>12s} {t:8.2f}  ({tm['votes']:.2f} / {tm['postprocess']:.2f}"
                      f" / {tm['radiosity']:.2f})", flush=True)
                rows.append((name, rho, model, m, t))
    for model in models:
        for rho in rhos:
            sel = [r for r in rows if r[2] == model and r[1] == rho]
            ok = all(r[3]["found"] == r[3]["true"] and r[3]["spurious"] == 0
                     and r[3]["max_error_cm"] < 10 for r in sel)
            worst = max(99 if r[3]["max_error_cm"] is None else r[3]["max_error_cm"]
                        for r in sel)
            tot = np.median([r[4] for r in sel])
            print(f"  {model:8s} rho {rho:.1f}: all found, none spurious: {ok};"
                  f" worst error {worst:.2f} cm; median {tot:.2f} s per scene")
    return rows


def free_flux_table(backend, rhos):
    """Locate without a flux: the generated scenes with luminaires of different fluxes, and
    the one-flux scenarios with each luminaire's flux drawn from 1200-4800 lm."""
    print("\n== Without a flux: count, position error and flux error per scene")
    print(f"{'scenario':20s} {'rho':>4s} {'found':>6s} {'out':>4s} {'max cm':>7s}"
          f" {'max flux %':>10s} {'s':>6s} {'(of it votes s)':>15s}")
    rng = np.random.default_rng(1)
    worst_cm, worst_flux, all_ok = 0.0, 0.0, True
    for name in MIXED_SCENARIOS + SCENARIOS:
        for rho in rhos:
            scene, true = known_scene(name, reflectance=rho, backend=backend)
            if name in SCENARIOS:       # redraw each luminaire's flux and render again
                from invrad_wb.core.forward.render import render
                for L in true:
                    L.flux_lm = float(np.round(rng.uniform(1200.0, 4800.0)))
                scene = scene.with_vertex_lux(render(scene, true, interreflection=rho > 0,
                                                     backend=backend))
            t, r = timed(lambda: locate(scene, None, backend=backend))
            m = match(r.luminaires, true)
            ferr = 0.0
            for tl in true:
                near = min(r.luminaires, default=None,
                           key=lambda l: np.linalg.norm(np.asarray(l.position) - tl.position))
                if near is not None:
                    ferr = max(ferr, abs(near.flux_lm / tl.flux_lm - 1.0) * 100.0)
            ok = m["found"] == m["true"] == len(r.luminaires)
            all_ok &= ok
            worst_cm = max(worst_cm, m["max_error_cm"] or 0.0)
            worst_flux = max(worst_flux, ferr)
            print(f"{name:20s} {rho:4.1f} {m['found']:>3d}/{m['true']:<2d} "
                  f"{len(r.luminaires):4d} {m['max_error_cm'] or 0.0:7.2f} {ferr:10.2f}"
                  f" {t:6.2f} {r.timings['votes']:15.2f}")
    print(f"  every count right: {all_ok}; worst {worst_cm:.2f} cm, worst flux {worst_flux:.2f} %")


def votes_per_second(backends, repeat):
    print("\n== Vote casting, one 6 x 4 x 3 m room (two ceiling lights), OpenCL vs numpy")
    scene, true = known_scene("two_ceiling", reflectance=0.0)
    pts = voting_points(scene)
    canvas = build_canvas(scene, 0, pixel=0.1)
    W = vote_weights(canvas, pts, pts.lux, "illumination")
    pairs = int(np.sum(W > 0, axis=1) @ np.array([m.mask.sum() for m in canvas.maps]))
    n_ell = len(ellipse_votes_params(canvas, pts, W, pts.lux, 3000.0)["K"])
    print(f"  {len(pts)} voting points, {len(canvas.maps)} maps, {canvas.size} pixels;"
          f" exact model: {pairs / 1e6:.1f} M (point, pixel) pairs; ellipse model:"
          f" {n_ell} ellipses")
    res = {}
    for backend in backends:
        fe = cast_exact_opencl if backend == "opencl" else cast_exact_numpy
        fl = cast_ellipse_opencl if backend == "opencl" else cast_ellipse_numpy
        fe(canvas, pts, W, pts.lux, 3000.0)
        te, _ = timed(lambda: fe(canvas, pts, W, pts.lux, 3000.0), repeat)
        fl(canvas, pts, W, pts.lux, 3000.0)
        tl, _ = timed(lambda: fl(canvas, pts, W, pts.lux, 3000.0), repeat)
        res[backend] = (te, tl)
        print(f"  {backend:7s} exact {te:7.3f} s = {pairs / te / 1e6:8.1f} M pairs/s,"
              f" {len(pts) / te:9.0f} votes/s | ellipse {tl:7.3f} s ="
              f" {n_ell / tl:9.0f} ellipses/s")
    if len(res) == 2:
        print(f"  OpenCL speed-up: exact {res['numpy'][0] / res['opencl'][0]:.0f}x,"
              f" ellipse {res['numpy'][1] / res['opencl'][1]:.0f}x")


def scaling(backend, repeat):
    print(f"\n== Growth of time ({backend}): voting density and number of planes")
    scene, true = known_scene("two_ceiling", reflectance=0.0, backend=backend)
    print(f"  {'votes/m^2':>9s} {'points':>7s} {'votes s':>8s} {'locate s':>9s} {'err cm':>7s}")
    for density in (10, 20, 30, 60, 120):
        t, r = timed(lambda: locate(scene, 3000.0, votes_per_m2=density, backend=backend),
                     repeat)
        m = match(r.luminaires, true)
        print(f"  {density:9d} {len(r.rooms[0].points):7d} {r.timings['votes']:8.3f}"
              f" {t:9.3f} {m['max_error_cm'] or float('nan'):7.2f}")
    print(f"  {'dummies':>9s} {'maps':>7s} {'pixels':>8s} {'votes s':>8s} {'locate s':>9s}")
    for count in (0, 5, 10, 20, 40):
        t, r = timed(lambda: locate(scene, 3000.0, dummy_planes=count > 0,
                                    dummy_count=count or None, dummy_spacing_m=0.05
                                    if count > 20 else 0.1, backend=backend), repeat)
        c = r.rooms[0].canvas
        print(f"  {count:9d} {len(c.maps):7d} {c.size:8d} {r.timings['votes']:8.3f} {t:9.3f}")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="direct light, exact model only")
    ap.add_argument("--skip-numpy", action="store_true", help="no numpy vote timing")
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--rho", type=float, default=None, help="one reflectance only")
    ap.add_argument("--accuracy-only", action="store_true",
                    help="only the flux-given accuracy table")
    ap.add_argument("--free-flux-only", action="store_true",
                    help="only the table without a flux")
    args = ap.parse_args()
    backend = "opencl" if opencl_available() else "numpy"
    print(f"backend: {backend}" + (f" ({get_env().description})" if backend == "opencl" else ""))
    models = ["exact"] if args.quick else ["exact", "ellipse"]
    rhos = [0.0] if args.quick else [0.0, 0.6]
    if args.rho is not None:
        rhos = [args.rho]
    if args.accuracy_only:
        accuracy_table(backend, models, rhos, args.repeat)
        return
    if args.free_flux_only:
        free_flux_table(backend, rhos)
        return
    accuracy_table(backend, models, rhos, args.repeat)
    free_flux_table(backend, rhos)
    votes_per_second(([] if args.skip_numpy else ["numpy"]) + ([backend] if backend == "opencl"
                                                                else []), args.repeat)
    scaling(backend, args.repeat)


if __name__ == "__main__":
    main()
