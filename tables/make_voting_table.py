#!/usr/bin/env python3
"""Generate the voting table (thesis 4.1.1.2): maximum, rotation and deformed ellipses.

For every angle ``alpha`` between the voting point's normal and the luminaire plane's normal
and every level ``q = e / e_max`` below the maximum it stores the deformed ellipse
``(a, b, d, x_m, y_m)`` of the contour ``e`` at *unit distance*; the distance dimension of
the thesis' table is exact scaling (``e ~ 1/h^2``, lengths ~ ``h``, see
``invrad_wb/core/inverse/formfactor.py``), which also lifts its 0.1-10 m limit. The fits are
``invrad_wb/core/inverse/tablefit.py``'s. Layout, axes and the
interpolation the vote kernel must use are documented in ``invrad_wb/core/inverse/table.py`` and
``tables/README.md``.

Every entry is fitted from the thesis' starting values (no warm start), so any entry can be
regenerated on its own: ``--check`` recomputes a random sample of entries and compares.

Outputs (written atomically): ``voting_table.npz`` and ``voting_table.json`` (generation
parameters, shapes, generator/numpy versions, seconds, error summary, sha256 of the npz).

Usage: python tables/make_voting_table.py [--levels 512] [--q-min 1e-4] [--check [N]]
       [--bench]
"""
import argparse
import json
import math
import os
import platform
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))

from invrad_wb.core.inverse import formfactor as ff  # noqa: E402
from invrad_wb.core.inverse import tablefit  # noqa: E402
from invrad_wb.core.io.atomic import atomic_path, atomic_write_text  # noqa: E402
from invrad_wb.core.inverse.table import sha256  # noqa: E402

#: Bump when the generator's numbers change; table.py checks FORMAT, not this.
VERSION = 1
#: Layout version of the npz; invrad_wb.core.inverse.table refuses other formats.
FORMAT = 1
#: Columns of (a, b, d, x_m, y_m) that are lengths (stored in units of h * r_max).
LENGTHS = [0, 1, 3, 4]


def axes(angle_step_deg, n_levels, q_min):
    """Angle axis (rad) and level axis (lambda = sqrt(ln(1/q)), q)."""
    n_angles = int(round(180.0 / angle_step_deg))
    if abs(n_angles * angle_step_deg - 180.0) > 1e-9:
        raise SystemExit("--angle-step-deg must divide 180")
    angles = np.radians(angle_step_deg) * np.arange(1, n_angles + 1)
    lam_max = math.sqrt(math.log(1.0 / q_min))
    lam = np.linspace(0.0, lam_max, n_levels)
    return angles, lam, np.exp(-lam * lam)


def build(angles, lam, q, k, k_orth, n_check, progress=True):
    """All entries; returns the dict of arrays written to the npz (plus float64 extras)."""
    A, L = len(angles), len(lam)
    mx = ff.maximum_closed_form(1.0, angles)
    r_max = np.sqrt(1.0 + mx.x ** 2)
    params = np.zeros((A, L, 5))
    err_max = np.zeros((A, L))
    err_mean = np.zeros((A, L))
    err_max_lm = np.zeros((A, L))
    r_eq = np.zeros((A, L))
    t0 = time.time()
    for j in range(1, L):  # j = 0 is q = 1: the contour is the point at the maximum
        ent = tablefit.table_entries(angles, q[j], k=k, k_orth=k_orth, n_check=n_check)
        params[:, j] = ent["params"]
        params[:, j, LENGTHS] /= r_max[:, None]
        err_max[:, j] = ent["err_max"]
        err_mean[:, j] = ent["err_mean"]
        err_max_lm[:, j] = ent["err_max_lm"]
        r_eq[:, j] = ent["r_eq"] / r_max
        if progress and (j % 64 == 0 or j == L - 1):
            print(f"  level {j}/{L - 1} (q = {q[j]:.3g}), {time.time() - t0:.0f} s",
                  flush=True)
    return {
        "format": np.int64(FORMAT),
        "angles": angles, "lam": lam, "q": q,
        "e_max": mx.e, "x_max": mx.x, "rotation": mx.rotation, "r_max": r_max,
        "params": params.astype(np.float32),
        "fit_error": err_max.astype(np.float32),
        "fit_error_mean": err_mean.astype(np.float32),
        "fit_error_thesis": err_max_lm.astype(np.float32),
        "r_eq": r_eq.astype(np.float32),
    }


def summary(arrs, angles, q):
    """Fit-error statistics for the json and the report."""
    fe = arrs["fit_error"].astype(np.float64)[:, 1:]
    fm = arrs["fit_error_mean"].astype(np.float64)[:, 1:]
    ft = arrs["fit_error_thesis"].astype(np.float64)[:, 1:]
    i, j = np.unravel_index(np.argmax(fe), fe.shape)
    out = {
        "fit_error_max_rel": {"median": float(np.median(fe)), "p90": float(np.percentile(fe, 90)),
                              "p99": float(np.percentile(fe, 99)), "max": float(fe.max()),
                              "worst_alpha_deg": float(np.degrees(angles[i])),
                              "worst_q": float(q[j + 1])},
        "fit_error_mean_rel": {"median": float(np.median(fm)), "max": float(fm.max())},
        "thesis_fit_error_max_rel": {"median": float(np.median(ft)),
                                     "p90": float(np.percentile(ft, 90)),
                                     "max": float(ft.max())},
        "entries_fit_error_above": {str(t): int((fe > t).sum()) for t in (0.01, 0.02, 0.03, 0.05)},
        "by_q": {},
    }
    for qq in (0.9, 0.5, 0.1, 0.01, 1e-3, 1e-4):
        jj = int(np.argmin(np.abs(np.log(q[1:]) - math.log(qq))))
        out["by_q"][f"{q[jj + 1]:.3g}"] = {
            "max_over_angles": float(fe[:, jj].max()),
            "median_over_angles": float(np.median(fe[:, jj])),
            "thesis_max_over_angles": float(ft[:, jj].max())}
    return out


def check(npz_path, n, k, k_orth, n_check, seed=7):
    """Recompute ``n`` random entries (plus the extreme corners) and compare."""
    z = np.load(npz_path)
    angles, q = z["angles"], z["q"]
    A, L = len(angles), len(q)
    rng = np.random.default_rng(seed)
    ii = np.concatenate([[0, A - 1, A // 2, 0], rng.integers(0, A, n)])
    jj = np.concatenate([[1, L - 1, L // 2, L - 1], rng.integers(1, L, n)])
    ent = tablefit.table_entries(angles[ii], q[jj], k=k, k_orth=k_orth, n_check=n_check)
    r_max = z["r_max"][ii]
    new = ent["params"].copy()
    new[:, LENGTHS] /= r_max[:, None]
    old = z["params"][ii, jj].astype(np.float64)
    scale = np.maximum(np.abs(old[:, :2]).max(axis=1, keepdims=True), 1e-30)
    dev = np.abs(new - old)
    dev[:, [0, 1, 3, 4]] /= scale
    worst = float(dev.max())
    mx = ff.maximum_closed_form(1.0, angles)
    dmax = max(float(np.abs(mx.x - z["x_max"]).max()), float(np.abs(mx.e / z["e_max"] - 1).max()),
               float(np.abs(mx.rotation - z["rotation"]).max()))
    derr = float(np.abs(ent["err_max"] - z["fit_error"][ii, jj]).max())
    ok = worst < 1e-5 and dmax < 1e-12 and derr < 1e-5
    print(f"checked {len(ii)} entries: largest parameter deviation {worst:.2e} (relative), "
          f"maximum/rotation {dmax:.1e}, fit error {derr:.1e} -> {'OK' if ok else 'MISMATCH'}")
    return ok


def bench(k):
    """Newton/LM versus (1+1)-ES, one problem at a time (thesis 3.2.4)."""
    rows = tablefit.compare_methods(k=k)
    print("\nMaximum (error vs closed form in units of h, seconds per problem):")
    seen = set()
    for r in rows:
        if r["alpha_deg"] in seen:
            continue
        seen.add(r["alpha_deg"])
        print(f"  alpha {r['alpha_deg']:5.1f} deg: Newton {r['max_newton_err']:.1e} "
              f"({r['max_newton_iter']} it, {r['max_newton_s'] * 1e3:.2f} ms)   "
              f"(1+1)-ES {r['max_es_err']:.1e} ({r['max_es_gen']} gen, "
              f"{r['max_es_s'] * 1e3:.1f} ms)")
    print("\nEllipse fit, thesis objective eq. 3.30 (mse normalised by b^4; geometric error "
          "max/r_eq; seconds per fit incl. sampling):")
    for r in rows:
        b4 = r["lm_params"][1] ** 4
        print(f"  alpha {r['alpha_deg']:5.1f} q {r['q']:<5g}: "
              f"LM mse {r['lm_mse'] / b4:.1e} geo {r['lm_geo_max']:.4f} "
              f"{r['lm_iter']:3d} it {r['lm_s'] * 1e3:6.1f} ms | "
              f"ES mse {r['es_mse'] / b4:.1e} geo {r['es_geo_max']:.4f} "
              f"{r['es_iter']:5d} gen {r['es_s'] * 1e3:7.1f} ms")
    lm_s = float(np.mean([r["lm_s"] for r in rows]))
    es_s = float(np.mean([r["es_s"] for r in rows]))
    return {"rows": rows, "lm_mean_s": lm_s, "es_mean_s": es_s}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--angle-step-deg", type=float, default=1.0)
    ap.add_argument("--levels", type=int, default=512)
    ap.add_argument("--q-min", type=float, default=1e-4)
    ap.add_argument("--k", type=int, default=ff.DEFAULT_SAMPLES,
                    help="thesis contour samples per fit (rays from the maximum)")
    ap.add_argument("--k-orth", type=int, default=32,
                    help="samples for the orthogonal refinement (rays from the centre)")
    ap.add_argument("--n-check", type=int, default=128,
                    help="curve points used to measure the geometric fit error")
    ap.add_argument("--out", default=HERE, help="output folder (default: tables/)")
    ap.add_argument("--check", nargs="?", type=int, const=24, default=None, metavar="N",
                    help="recompute N random stored entries and compare (no writing)")
    ap.add_argument("--bench", action="store_true",
                    help="also compare Newton/LM with the (1+1)-ES and record it in the json")
    args = ap.parse_args(argv)
    npz = os.path.join(args.out, "voting_table.npz")
    js = os.path.join(args.out, "voting_table.json")
    if args.check is not None:
        with open(js) as fh:
            meta = json.load(fh)
        if sha256(npz) != meta["sha256"]:
            print(f"{npz}: checksum does not match {js}")
            return 1
        g = meta["parameters"]
        return 0 if check(npz, args.check, g["k"], g["k_orth"], g["n_check"]) else 1
    if not 0 < args.q_min < 1 or args.levels < 16:
        raise SystemExit("need 0 < --q-min < 1 and --levels >= 16")
    angles, lam, q = axes(args.angle_step_deg, args.levels, args.q_min)
    print(f"voting table: {len(angles)} angles x {len(lam)} levels "
          f"(q from 1 to {args.q_min:g})", flush=True)
    t0 = time.time()
    arrs = build(angles, lam, q, args.k, args.k_orth, args.n_check)
    seconds = time.time() - t0
    with atomic_path(npz) as tmp:
        np.savez(tmp, **arrs)
        os.chmod(tmp, 0o644)
    meta = {
        "generator": "tables/make_voting_table.py", "version": VERSION, "format": FORMAT,
        "numpy": np.__version__, "python": platform.python_version(),
        "seconds": round(seconds, 1),
        "parameters": {
            "angle_step_deg": args.angle_step_deg, "n_angles": len(angles),
            "angle_first_deg": float(np.degrees(angles[0])),
            "angle_last_deg": float(np.degrees(angles[-1])),
            "n_levels": len(lam), "q_min": args.q_min, "lambda_max": float(lam[-1]),
            "level_axis": "lam[j] = j * lambda_max / (n_levels - 1), q = exp(-lam^2)",
            "k": args.k, "k_orth": args.k_orth, "n_check": args.n_check,
            "fit": "thesis LM on eq. 3.30 from thesis starting values, then orthogonal-"
                   "distance LM on k_orth samples seen from the minor-axis midpoint; "
                   "the better of the two by the geometric error",
            "length_unit": "r_max = sqrt(1 + x_max^2): distance from the voting point to the "
                           "maximum at unit distance (h = 1); multiply by h * r_max",
        },
        "arrays": {name: {"shape": list(np.shape(v)), "dtype": str(np.asarray(v).dtype)}
                   for name, v in arrs.items()},
        "summary": summary(arrs, angles, q),
    }
    if args.bench:
        b = bench(args.k)
        meta["method_comparison"] = {
            "lm_mean_seconds_per_fit": b["lm_mean_s"], "es_mean_seconds_per_fit": b["es_mean_s"],
            "rows": [{key: val for key, val in r.items() if not key.endswith("params")}
                     for r in b["rows"]]}
    meta["sha256"] = sha256(npz)
    atomic_write_text(js, json.dumps(meta, indent=2) + "\n")
    os.chmod(js, 0o644)
    print(json.dumps({key: meta[key] for key in ("seconds", "summary", "sha256")}, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
