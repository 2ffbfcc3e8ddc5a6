"""The fast design model on the immediate surroundings and the background area: how far
its figures are from the exact model's (figures only).

The search ranks layouts by a fast model (direct light per layout, interreflection per
lumen learnt from one exact solve per type) and checks the best by the exact model. The
surroundings and the background are left out of the fast model's compliance filter
(``search.EXACT_ONLY``; judged on every exact check, their Em serving the fast dimming
level). This measures, on bench_design_radiance's rooms with their task area set in (so
that both bands exist), the fast figures of 23 layouts per room (the 12 the fast model
ranks first and 12 spread over its table) against the exact model's, before any per-point
correction: Em as a ratio fast / exact, U0 as a difference fast - exact.

Run: ``.venv/bin/python bench/bench_fast_surroundings.py [room:margin ...]`` (default
``lab:2 classroom:1.5 hall:4 L_office:0.5``); ``... --filter [room ...]`` designs each
room as is and with both bands in the fast filter (default ``meeting lab``).

Measured 2026-11-26 (round 10, shared 2-core machine at load 3-5; 68-305 s per room):

=================  ==============  ==================  ==================  ===============
room (task in)     item            Em fast/exact       median              U0 fast - exact
=================  ==============  ==================  ==================  ===============
lab (2 m)          work plane      0.990 - 1.016       1.009               -0.000 / +0.004
                   surroundings    0.992 - 1.018       1.013               -0.000 / +0.009
                   background      0.989 - 1.040       1.023               -0.004 / +0.049
                   walls           0.989 - 1.065       1.023               -0.005 / +0.097
classroom (1.5 m)  work plane      1.008 - 1.034       1.017               -0.009 / +0.013
                   surroundings    1.013 - 1.036       1.024               -0.015 / +0.020
                   background      1.024 - 1.065       1.047               -0.019 / +0.041
                   walls           1.004 - 1.055       1.041               -0.006 / +0.077
hall (4 m)         work plane      0.991 - 1.006       1.003               -0.002 / +0.009
                   surroundings    0.994 - 1.009       1.003               -0.001 / +0.018
                   background      0.998 - 1.020       1.010               -0.000 / +0.053
                   walls           0.999 - 1.035       1.014               -0.008 / +0.097
L office (0.5 m)   work plane      0.997 - 1.020       1.007               -0.007 / +0.053
                   surroundings    1.005 - 1.038       1.019               -0.001 / +0.069
                   walls           0.996 - 1.026       1.010               -0.010 / +0.092
=================  ==============  ==================  ==================  ===============

The fast model does predict both bands, as well as it predicts the walls that it does
filter on (Em a few % high, U0 up to 0.07 high). With the surroundings and the background
in the fast filter (``EXACT_ONLY = ()``) the meeting room and the lab (task areas the
rooms less 0.5 m) are designed exactly as without: 107.7 W and 238.7 W, 12 and 25 exact
solves; so the filter is left as it is.
"""
from dataclasses import replace
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.dirname(HERE))

import bench_design_radiance as B  # noqa: E402
from invrad_wb.core.design.background import with_background  # noqa: E402
from invrad_wb.core.design.design import _with_surroundings  # noqa: E402
from invrad_wb.core.design.evaluate import RoomModel, surface_grids  # noqa: E402
from invrad_wb.core.design.room import DesignRoom  # noqa: E402
from invrad_wb.core.design.search import RoomSearch  # noqa: E402
from invrad_wb.core.model.photometry import read_photometry  # noqa: E402

OUT = os.path.join(os.path.dirname(HERE), "out", "radjobs_bg")
ITEMS = ("work_plane", "surroundings", "background", "walls")


def room(name, margin, cat, phot):
    """Fast against exact figures of 23 layouts of room ``name`` with its task area
    ``margin`` m in: {item: (k, 2) array of (Em fast / exact, U0 fast - exact)}."""
    build, rm = B.ROOMS[name]
    sc = build()
    spec = B.room_spec(cat, rm)
    rs = spec.room_spec(0)
    rs = replace(rs, work_plane=replace(rs.work_plane, margin_m=margin))
    dr = DesignRoom(sc, 0)
    req = rs.work_plane
    pts, _ = dr.grid(req.height_m, req.margin_m)
    surfaces = surface_grids(sc, 0, dr)
    words = type("Words", (), {"notes": []})()
    rs = _with_surroundings(rs, dr, req, surfaces, words)
    rs = with_background(rs, dr, req, surfaces, words)
    model = RoomModel(sc, dr, pts, spec.maintenance_factor, surfaces=surfaces)
    s = RoomSearch(model, req, rs, spec.entries_for(rs, dr.top_z - dr.floor_z), phot,
                   mixed=False)
    s._calibrate_all()
    t = s.table()
    n = len(t["geom"])
    rows = np.unique(np.r_[np.arange(min(12, n)), np.linspace(0, n - 1, 12).astype(int)])
    res = {k: [] for k in ITEMS}
    for r in rows:
        met = s.check(s.candidate(t, r))
        d = t["dim"][r]
        res["work_plane"].append((t["em"][r] / d / met.em, t["u0"][r] - met.u0))
        for k in ITEMS[1:]:
            if k in met.surfaces:
                res[k].append((t[f"{k}_em"][r] / d / met.surfaces[k][0],
                               t[f"{k}_u0"][r] - met.surfaces[k][2]))
    return {k: np.array(v) for k, v in res.items() if v}, len(rows), n


def main(args):
    os.makedirs(OUT, exist_ok=True)
    cat = B.catalogue(OUT)
    phot = {e["name"]: read_photometry(e["photometry"]) for e in cat}
    for a in args:
        name, margin = a.split(":")
        t0 = time.perf_counter()
        res, k, n = room(name, float(margin), cat, phot)
        print(f"{name} (task area {float(margin):g} m in), {k} layouts of {n},"
              f" {time.perf_counter() - t0:.0f} s:")
        for item, v in res.items():
            print(f"  {item:13s} fast/exact Em {v[:, 0].min():.3f}-{v[:, 0].max():.3f}"
                  f" (median {np.median(v[:, 0]):.3f}), U0 fast-exact"
                  f" {v[:, 1].min():+.3f} to {v[:, 1].max():+.3f}", flush=True)


def filter_check(names):
    """Each room of ``names`` designed as is and with the surroundings and the background
    in the fast model's compliance filter (``EXACT_ONLY = ()``)."""
    import invrad_wb.core.design.refine as refine_mod
    import invrad_wb.core.design.search as search_mod
    from invrad_wb.core.design.design import design_room
    cat = B.catalogue(OUT)
    phot = {e["name"]: read_photometry(e["photometry"]) for e in cat}
    saved = search_mod.EXACT_ONLY
    try:
        for name in names:
            build, rm = B.ROOMS[name]
            sc = build()
            spec = B.room_spec(cat, rm)
            for label, eo in (("as is", saved), ("fast filter", ())):
                search_mod.EXACT_ONLY = refine_mod.EXACT_ONLY = eo
                t = time.process_time()
                rd = design_room(sc, spec, 0, photometry=phot)
                su = rd.metrics.surfaces["surroundings"]
                print(f"{name:10s} {label:12s} {rd.watts:7.1f} W compliant {rd.compliant}"
                      f" surroundings {su[0]:.0f}/{su[2]:.2f} exact solves"
                      f" {rd.exact_solves} CPU {time.process_time() - t:.0f} s"
                      f"  {rd.candidate.geom.describe()}", flush=True)
    finally:
        search_mod.EXACT_ONLY = refine_mod.EXACT_ONLY = saved


if __name__ == "__main__":
    if sys.argv[1:2] == ["--filter"]:
        filter_check(sys.argv[2:] or ["meeting", "lab"])
    else:
        main(sys.argv[1:] or ["lab:2", "classroom:1.5", "hall:4", "L_office:0.5"])
