"""The least power any placement of the bench catalogue could draw in a bench room: a
lower bound to hold the designs and the grid reference against (figures only).

Every mean requirement (work plane, immediate surroundings, walls, ceiling, Ez) is linear
in the luminaires' outputs. One luminaire of each type is solved alone by the exact model
(shadows, radiosity) at every position of a plan grid (``--step`` m) where it may hang;
then a linear programme (HiGHS) finds the least watts of outputs ``0 <= x_i <= 1`` that
meet every mean at its minimum (no design margin). Uniformity, UGR and the dimming floor
are left out and every output may be any fraction (a relaxation), and a luminaire solved
alone has no other opening covering the ceiling (more light than in a layout): no layout
of these positions and types meets the means for less, by the exact model.

Measured 2026-11-26 (load 5-12): L corridor (--step 0.5) 48.5 W, the ceiling alone 46.0
W, against the grid reference's 52.0 W by Radiance; hall (--step 1.2) 731.7 W, all from
the clear HB-15000 that meets UGR 22 in no layout (grid reference 895.0 W).

Run: ``.venv/bin/python bench/bench_design_bound.py [--step 0.4] room ...`` (rooms of
``bench_design_radiance``).
"""
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
sys.path.insert(0, HERE)

import bench_design_radiance as B  # noqa: E402
from invrad_wb.core.design.evaluate import luminaires_of  # noqa: E402
from invrad_wb.core.design.layouts import mount  # noqa: E402
from invrad_wb.core.design.search import RoomSearch  # noqa: E402
from invrad_wb.core.model.photometry import read_photometry  # noqa: E402


def bound(name, step):
    from scipy.optimize import linprog
    cat = B.catalogue(B.JOBS)
    phot = {e["name"]: read_photometry(e["photometry"]) for e in cat}
    build, room = B.ROOMS[name]
    scene = build()
    spec = B.room_spec(cat, room)
    rs, droom, model, cyl, _ = B.full_room_model(scene, spec)
    search = RoomSearch(model, rs.work_plane, rs,
                        spec.entries_for(rs, droom.top_z - droom.floor_z), phot, mixed=False)
    lay = model.layout
    ls, lt = droom.size
    s = np.arange(0.5 * step, ls, step)
    t = np.arange(0.5 * step, lt, step)
    plan = np.stack(np.meshgrid(s, t, indexing="ij"), -1).reshape(-1, 2)
    wp_z = droom.floor_z + rs.work_plane.height_m
    names, need = ["work plane"], [rs.work_plane.lux]
    for k in lay.parts:
        if k in rs.surfaces:
            names.append(k)
            need.append(rs.surfaces[k].lux)
    if cyl is not None:
        names.append("Ez")
        need.append(rs.cylindrical["lux"])
    cols, watts, what = [], [], []
    t0 = time.perf_counter()
    for k, e in enumerate(search.entries):
        pos, nrm, ok = mount(droom, plan, rs.mounting, search._half_size(e), wp_z)
        for p, n in zip(pos[ok], nrm[ok]):
            lums = luminaires_of(p[None], n[None], np.array([e.flux_lm]), search.entries,
                                 np.array([k]), droom.room, phot, search._axes)
            total, _ = model.exact(lums)
            m = [float(total[:lay.n_wp].mean())]
            for key in names[1:]:
                if key == "Ez":
                    m.append(float(np.mean(cyl.evaluate(lums)[0])))
                else:
                    sl, w = lay.parts[key]
                    m.append(float(np.sum(total[sl] * w) / w.sum()))
            cols.append(m)
            watts.append(e.watts)
            what.append((e.name, e.orientation, tuple(np.round(p[:2], 2))))
    A = np.array(cols).T                                       # (means, positions)
    res = linprog(np.array(watts), A_ub=-A, b_ub=-np.array(need),
                  bounds=[(0.0, 1.0)] * len(watts), method="highs")
    s_ = time.perf_counter() - t0
    if res.status != 0:
        print(f"{name}: no outputs of {len(watts)} positions meet the means ({s_:.0f} s)")
        return
    x = res.x
    used = np.flatnonzero(x > 1e-6)
    binding = [nm for nm, v, r in zip(names, A @ x, need) if v <= r * (1 + 1e-6)]
    print(f"{name}: least watts for the means {res.fun:.1f} W ({len(watts)} positions x"
          f" types solved alone, {s_:.0f} s); binding: {', '.join(binding)}; "
          + ", ".join(f"{what[i][0]} {what[i][2]} {100 * x[i]:.0f} %" for i in used[:8])
          + (" ..." if len(used) > 8 else ""), flush=True)
    for nm, v, r in zip(names, A @ x, need):
        print(f"    {nm:13s} {v:7.1f} lx (minimum {r:.0f})")
    # the best lux per watt of each mean over every position and type
    for j, nm in enumerate(names):
        i = int(np.argmax(A[j] / np.array(watts)))
        print(f"    {nm:13s} needs >= {need[j] / (A[j, i] / watts[i]):6.1f} W alone"
              f" (best: {what[i][0]} at {what[i][2]})")


if __name__ == "__main__":
    args = sys.argv[1:]
    step = 0.4
    if "--step" in args:
        i = args.index("--step")
        step = float(args[i + 1])
        del args[i:i + 2]
    for n in args or ["L_corridor"]:
        bound(n, step)
