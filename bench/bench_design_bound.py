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

``--full``: every item the design meets (means, every uniformity, Ez, the points that
must stay dark, UGR as in :mod:`invrad_wb.core.design.refine`: a variable per squared
output), no design, uniformity or UGR margin; only the dimming floor and the count are
relaxed (each position any output 0..1, a type that does not dim too). ``--milp S``: then
each position off, or on within its type's range (a type that does not dim: full output),
HiGHS's mixed-integer programme (S s per solve; its answer and its lower bound are
printed); ``--cap W``: then the same with at most W watts (infeasible: a proof that none
exists). ``--types A,B``: only these types. The positions' solves are kept in
``out/bound_<room>_<step>_...pkl`` for the next run.

Measured 2026-11-26 round 9 (load 5-7; the exact model, which agrees with Radiance within
0.1-0.7 % on the grid references: 52.3 -> 52.0 W, 895.9 -> 895.0 W):

* L corridor, --step 0.5: every item, floor and count relaxed: 49.1 W; on / off with the
  floor: 49.5 W (10 luminaires of three types, DL-1200N, DL-2200W, PN-3600, most of them
  0.25 m from a wall, six at 10-14 %); with the two dimmable types only: 49.9 W relaxed,
  50.0 W on / off. 0.95 x the grid is 49.4 W (Radiance) / 49.7 W (exact): only a layout
  of three types in no grid, with no design margin, comes under it, by under 1 %.
* hall, --step 1.2, the diffused HB-13000D only: every item 873.5 W relaxed, 874.1 W on
  / off (11 luminaires): 0.976 x the grid (895.0 W); its work plane's U0 0.6 costs what
  the means alone (about 844 W at 130 lm/W) leave out. 0.95 x the grid (850.3 W) needs
  the clear HB-15000 too: with both types, every item, relaxed: 734.3 W (the clear one
  at fractions of its output: too loose for a type that does not dim, whose glare grows
  with its output squared). On / off with both types (--milp 30): after 20 UGR cuts
  (10 min) the last answer, 7 x HB-15000 + 1 x HB-13000D at 43 % (743 W), still broke
  UGR 22 (25.6 by the exact model): whether a mix meets UGR 22 under 850 W is not
  settled by this programme.

Round 10 (2026-11-26, load 3-5), UGR by a variable per squared output (secant and
tangents, :func:`refine.ugr_rows`) instead of Kelley planes on the glare sum:

* hall, --step 1.2 --full --milp 60 --types HB-15000,HB-13000D: relaxed 734.3 W (as
  before; without UGR 733.5 W; 20 s of solves); on / off with the floor, every item with
  UGR 22 and no margin: **812.8 W** (UGR 21.89) in the first 60 s solve, the solver's
  lower bound then 781.6 W: 4 clear HB-15000 at full output, two by each short wall
  near its middle ((1.8, 5.4), (1.8, 6.6), (17.4, 3.0), (18.6, 6.6)), where the
  observers at the short walls see them steeply or not at all, and 13 HB-13000D at
  10-100 %. So a mix does meet UGR 22 well under 0.95 x the grid (850.3 W): 0.908 of
  it by the exact model. The design search finds such a mix since round 10
  (:func:`refine.swap_entry`): 16 HB-13000D + 4 HB-15000 of a 4 x 6 grid, 828.4 W.

Round 11 (2026-11-26, load 3-5): is 0.95 x the grid reachable in the L corridor? Every
item, no margin (``--full --milp 120``), positions on a 0.25 m plan grid (``--step 0.25
--offset 0.25``: the 0.5 m grid's points and those between them), all three types a 2.6
m room allows (the high-bays hang at 4 m or more); then ``--polish``: the on / off
answer's luminaires moved off the grid (steps of 0.125, 0.0625, 0.031 m along s and t,
each solved alone, kept where the on / off outputs draw less; then every one solved
again with the whole layout's openings in place, and the outputs solved with no margin
and with the design's margins); ``--radiance``: that layout judged by
``bench_design_radiance``'s Radiance judge (job ``out/radjobs/<room>/bound``). The grid
reference: 52.31 W by the exact model (0.95 x: 49.70 W), 52.0 W by Radiance (49.40 W).

* the rooms' own mesh (0.3 m cells): relaxed 48.7 W, on / off 49.3 W (lower bound
  48.9 W), polished **48.82 W** (49.36 W with the design's margins; 7 luminaires of the
  three types): 0.933 x the grid by this model. But the polish moved its downlights to
  the mounting's wall clearance (0.22 m), within a cell of the walls, where the model is
  not converged: the same layout on 0.15 m cells has the ceiling at 28.4 lx (30
  needed) and the surroundings at 98.6 lx / U0 0.386; Radiance: 28.5 lx, 97.4 lx /
  0.385: fails both.
* 0.15 m cells (``--mesh 0.5``; 177 s of solves): relaxed 49.3 W, on / off 49.7 W
  (lower bound 49.5 W), polished 49.09 W (49.60 W with margins), again 0.22 m from the
  walls; on 0.075 m cells the ceiling 28.5 lx, surroundings 98.7 / 0.395; Radiance 28.9
  lx, 97.8 / 0.386: fails both.
* every luminaire at least 0.45 m from the walls (``--min-wall 0.45``, 0.3 m cells):
  relaxed **50.2 W = 0.960 x the grid**, on / off 50.6 W (lower bound 50.5 W), polished
  50.52 W (51.05 W with margins); this layout is converged (ceiling 30.0 / 29.6 / 29.6
  lx on 0.3 / 0.15 / 0.075 m cells), Radiance finds 28.4 lx: fails the ceiling; traced
  again with -ab 8 -ad 1024 -as 256 -aa 0.05 -ar 64 (649 s): 28.6 lx, every other item
  within 0.2 % of the bench's settings: the judge is settled, the model reads this
  layout's ceiling 3.5 % high.
* the grid reference and invrad's design (luminaires 0.9 m from the walls) read the
  same on 0.3, 0.15 and 0.075 m cells within 0.3 % on every item, and within 1 % of
  Radiance.

So no layout found meets every item by Radiance under 0.95 x the grid: those under
it by the exact model light the ceiling through light thrown on the walls next to
the luminaires, which the model reads 4-5 % above Radiance (unconverged within a cell
of a wall, and 4 % apart even where converged). A bound by Radiance itself (each
position traced alone) was not computed.

Run: ``.venv/bin/python bench/bench_design_bound.py [--step 0.4] [--offset O] [--mesh S]
[--min-wall D] [--full [--milp S [--polish [--radiance]]]] [--types A,B] room ...``
(rooms of ``bench_design_radiance``).
"""
import math
import os
import subprocess
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


#: the rooms' mesh cells x this (``--mesh S``): the exact model's patches near a
#: luminaire that hangs close to a wall
MESH_SCALE = 1.0
#: luminaires' plan positions at least this far from every wall (m; ``--min-wall D``;
#: 0: as close as the mounting allows, :func:`layouts.mount`)
MIN_WALL_M = 0.0


def _scaled_mesh(scale):
    """Build the bench rooms with mesh cells ``scale`` x their own (the room builders
    take their cell from :class:`generate.MeshBuilder`)."""
    from invrad_wb.core.synthetic import generate as g
    global MESH_SCALE
    MESH_SCALE = scale
    if scale != 1.0 and not hasattr(g.MeshBuilder, "_unscaled"):
        orig = g.MeshBuilder

        def scaled(cell, *a, **kw):
            return orig(cell * scale, *a, **kw)
        scaled._unscaled = orig
        g.MeshBuilder = scaled


def bound(name, step, full=False, types=None, milp_s=0, cap=None, offset=None,
          polish=False, radiance=False):
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
    off = 0.5 * step if offset is None else offset
    s = np.arange(off, ls, step)
    t = np.arange(off, lt, step)
    plan = np.stack(np.meshgrid(s, t, indexing="ij"), -1).reshape(-1, 2)
    if MIN_WALL_M:
        plan = plan[droom.wall_distance(droom.to_world(plan)) >= MIN_WALL_M - 1e-9]
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
    luxes, directs, ezs, T, Bg = [], [], [], [], []
    t0 = time.perf_counter()
    # the positions' solves, kept for the next run (out/, ignored by git)
    import pickle
    cache = os.path.join(os.path.dirname(HERE), "out", f"bound_{name}_{step:g}_"
                         + ("" if offset is None else f"o{offset:g}_")
                         + ("" if MESH_SCALE == 1 else f"m{MESH_SCALE:g}_")
                         + ("" if not MIN_WALL_M else f"w{MIN_WALL_M:g}_") + f"{full}_"
                         + ("all" if not types else "+".join(sorted(types))) + ".pkl")
    if os.path.exists(cache):
        with open(cache, "rb") as fh:
            cols, watts, what, luxes, directs, ezs, T, Bg = pickle.load(fh)
    for k, e in enumerate(search.entries):
        if types and e.name not in types or os.path.exists(cache):
            continue
        pos, nrm, ok = mount(droom, plan, rs.mounting, search._half_size(e), wp_z)
        for p, n in zip(pos[ok], nrm[ok]):
            lums = luminaires_of(p[None], n[None], np.array([e.flux_lm]), search.entries,
                                 np.array([k]), droom.room, phot, search._axes)
            total, direct = model.exact(lums)
            if full:
                luxes.append(total)
                directs.append(direct)
                if cyl is not None:
                    ezs.append(cyl.evaluate(lums)[0])
                gl = search.exact_glare(lums)
                if gl is not None:
                    T.append(gl[0])
                    Bg.append(gl[1])
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
    if not os.path.exists(cache):
        os.makedirs(os.path.dirname(cache), exist_ok=True)
        with open(cache, "wb") as fh:
            pickle.dump((cols, watts, what, luxes, directs, ezs, T, Bg), fh)
    A = np.array(cols).T                                       # (means, positions)
    if full:
        return _full(name, search, rs, cyl, luxes, directs, ezs, T, Bg, watts, what,
                     time.perf_counter() - t0, milp_s, cap,
                     ctx=dict(droom=droom, wp_z=wp_z, scene=scene, spec=spec, phot=phot,
                              cat=cat, cache=cache, polish=polish, radiance=radiance))
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


def _milp(name, search, parts, glare, w, what, limit_s, max_watts=None):
    """The same programme with each position on or off: off, or on within its type's
    dimming range (at full output where it has none): a mixed-integer programme
    (HiGHS, :func:`refine.solve_outputs` with groups of one luminaire), UGR by a variable
    per squared output and tangents, ``limit_s`` s per solve; ``max_watts``: only
    answers of at most these watts (infeasible: none exists, a proof)."""
    from invrad_wb.core.design import refine
    ent = {e.name: e for e in search.entries}
    lo = np.array([ent[t[0]].dimming[0] for t in what])
    hi = np.array([ent[t[0]].dimming[1] for t in what])
    t0 = time.perf_counter()
    x = refine.solve_outputs(parts, w, lo, hi, search, glare, may_drop=True,
                             time_limit=limit_s, max_watts=max_watts,
                             log=lambda m: print('   ', m, flush=True))
    bound_w = refine.solve_outputs.dual_bound
    secs = time.perf_counter() - t0
    cap = "" if max_watts is None else f" at most {max_watts:.1f} W,"
    if x is None:
        why = ("none exists (infeasible)" if bound_w == math.inf
               else "no answer within the time limit")
        print(f"{name}: on/off with the floor,{cap} every item with UGR: {why}"
              f" ({secs:.0f} s)", flush=True)
        return None
    used = np.flatnonzero(x > 0)
    u = ""
    if glare is not None:
        from invrad_wb.core.output.glare import ugr_from_sum
        uu = ugr_from_sum((x ** 2) @ glare[0], x @ glare[1])
        u = f", UGR {np.nanmax(uu):.2f}"
    print(f"{name}: on/off with the floor,{cap} every item with UGR (MILP, {secs:.0f} s):"
          f" {float(x @ w):.1f} W (solver's lower bound {bound_w or float('nan'):.1f} W)"
          f"{u}, {len(used)} luminaires: "
          + ", ".join(f"{what[i][0]} {what[i][2]} {100 * x[i]:.0f} %" for i in used),
          flush=True)
    return x


def _full(name, search, rs, cyl, luxes, directs, ezs, T, Bg, watts, what, secs,
          milp_s=0, cap=None, ctx=None):
    """The least watts of outputs 0 <= x <= 1 at the positions that meet every item the
    design meets (means, uniformities, stay-dark points, Ez, UGR: a variable per squared
    output, :func:`refine.ugr_rows`) with no design margin, no uniformity or UGR margin:
    only the dimming floor and the count of luminaires (each output any fraction) are
    relaxed; then (``milp_s``) on / off with the floor (:func:`_milp`)."""
    from invrad_wb.core.design import refine
    search.margin = 0.0
    saved = refine.U0_MARGIN, refine.UGR_MARGIN, refine.UGR_CUTS
    refine.U0_MARGIN, refine.UGR_MARGIN, refine.UGR_CUTS = 0.0, 0.0, 400
    if cyl is not None:
        search.cylindrical, search.cyl_req = cyl, cyl.req
    try:
        parts = {"lux": np.array(luxes), "direct": np.array(directs),
                 "ez": np.array(ezs) if ezs else None}
        glare = (np.array(T), np.array(Bg)) if T and search.ugr_max is not None else None
        w = np.array(watts)
        x = refine.solve_outputs(parts, w, np.zeros(len(w)), np.ones(len(w)), search,
                                 glare)
        x0 = refine.solve_outputs(parts, w, np.zeros(len(w)), np.ones(len(w)), search,
                                  None)
        w0 = "none" if x0 is None else f"{float(x0 @ w):.1f} W"
        if x is None:
            print(f"{name}: no outputs meet every item with UGR (without UGR: {w0};"
                  f" {len(w)} positions, {secs:.0f} s)")
        else:
            used = np.flatnonzero(x > 1e-6)
            print(f"{name}: least watts for every item but the floor and the count"
                  f" {float(x @ w):.1f} W (without UGR {w0}; {len(w)} positions x types, "
                  f"{secs:.0f} s): "
                  + ", ".join(f"{what[i][0]} {what[i][2]} {100 * x[i]:.0f} %"
                              for i in used[:12])
                  + (f" ... ({len(used)} used)" if len(used) > 12 else ""), flush=True)
        if milp_s and x is not None:
            import pickle
            keep = ctx["cache"][:-4] + f"_milp{milp_s:g}.pkl"
            if os.path.exists(keep):
                with open(keep, "rb") as fh:
                    xm = pickle.load(fh)
                print(f"{name}: on/off answer of {keep} (kept): {float(xm @ w):.1f} W")
            else:
                xm = _milp(name, search, parts, glare, w, what, milp_s)
                with open(keep, "wb") as fh:
                    pickle.dump(xm, fh)
            if xm is not None and ctx["polish"]:
                layout = [(what[i], float(xm[i])) for i in np.flatnonzero(xm > 0)]
                lums = _polish(name, search, rs, layout, ctx)
                if ctx["radiance"]:
                    _radiance_judge(name, lums, ctx)
            if cap is not None:
                _milp(name, search, parts, glare, w, what, milp_s, max_watts=cap)
    finally:
        refine.U0_MARGIN, refine.UGR_MARGIN, refine.UGR_CUTS = saved


def _solo(search, rs, k, xy, ctx, covering=None):
    """Exact figures of entry ``k`` alone at plan point ``xy`` at full output:
    (luminaire, lux, direct, ez, eh, T, B), or None where it may not hang there."""
    e = search.entries[k]
    droom = ctx["droom"]
    if MIN_WALL_M and droom.wall_distance(droom.to_world(
            np.asarray(xy, float)[None]))[0] < MIN_WALL_M - 1e-9:
        return None
    pos, nrm, ok = mount(ctx["droom"], np.asarray(xy, float)[None], rs.mounting,
                         search._half_size(e), ctx["wp_z"])
    if not ok[0]:
        return None
    lums = luminaires_of(pos, nrm, np.array([e.flux_lm]), search.entries, np.array([k]),
                         ctx["droom"].room, search.phot, search._axes)
    total, direct = search.model.exact(lums, covering=covering)
    ez = eh = None
    if search.cylindrical is not None:
        ez, eh = search.cylindrical.evaluate(lums, covering=covering)
    gl = search.exact_glare(lums, covering=covering)
    T, B = (None, None) if gl is None else gl
    return lums[0], total, direct, ez, eh, T, B


def _outputs(search, cols, may_drop=True):
    """(x, watts) of the least-power outputs of luminaires ``cols`` (list of (k,
    solo figures)) by :func:`refine.solve_outputs`, or (None, inf)."""
    from invrad_wb.core.design import refine
    parts = {"lux": np.array([c[1][1] for c in cols]),
             "direct": np.array([c[1][2] for c in cols]),
             "ez": (np.array([c[1][3] for c in cols]) if cols[0][1][3] is not None
                    else None)}
    glare = None
    if search.ugr_max is not None and cols[0][1][5] is not None:
        glare = (np.array([c[1][5] for c in cols]), np.array([c[1][6] for c in cols]))
    ent = search.entries
    w = np.array([ent[k].watts for k, _ in cols])
    lo = np.array([ent[k].dimming[0] for k, _ in cols])
    hi = np.array([ent[k].dimming[1] for k, _ in cols])
    x = refine.solve_outputs(parts, w, lo, hi, search, glare, may_drop=may_drop)
    return (None, math.inf) if x is None else (x, float(x @ w))


def _polish(name, search, rs, layout, ctx, steps=(0.125, 0.0625, 0.03125)):
    """The on / off answer's luminaires moved off the plan grid: each in turn tried
    ``step`` m along +-s and +-t (each solved alone, exact), kept where the least-power
    outputs (:func:`_outputs`, on / off) draw less; then every luminaire solved again
    with the whole layout's openings in place (as :func:`refine.exact_refine`) and the
    outputs solved once more. Prints the watts with no margin and with the design's
    margins; returns the luminaires at their outputs (no margin)."""
    from invrad_wb.core.design import refine
    t0 = time.perf_counter()
    kof = {(e.name, e.orientation): k for k, e in enumerate(search.entries)}
    cur = []
    for (nm, ori, xy), _ in layout:
        k = kof[nm, ori]
        cur.append([k, np.array(xy, float), _solo(search, rs, k, xy, ctx)])
    x, wbest = _outputs(search, [(k, f) for k, _, f in cur])
    print(f"{name}: polish from {wbest:.2f} W ({len(cur)} luminaires)", flush=True)
    solves = 0
    for step in steps:
        better = True
        while better:
            better = False
            for i in range(len(cur)):
                if x is not None and x[i] <= 0:
                    continue
                for d in ((step, 0), (-step, 0), (0, step), (0, -step)):
                    xy = cur[i][1] + d
                    f = _solo(search, rs, cur[i][0], xy, ctx)
                    solves += 1
                    if f is None:
                        continue
                    trial = [(k, ff) for k, _, ff in cur]
                    trial[i] = (cur[i][0], f)
                    xt, wt = _outputs(search, trial)
                    if wt < wbest - 1e-4:
                        cur[i][1:] = [xy, f]
                        x, wbest, better = xt, wt, True
                        break
        print(f"    step {step:g} m: {wbest:.2f} W ({solves} solves,"
              f" {time.perf_counter() - t0:.0f} s)", flush=True)
    cur = [c for c, xi in zip(cur, x) if xi > 0]
    # the whole layout's openings in place (a panel hides the ceiling behind it)
    cover = [c[2][0] for c in cur]
    cols = [(c[0], _solo(search, rs, c[0], c[1], ctx, covering=cover)) for c in cur]
    x, w0 = _outputs(search, cols, may_drop=False)
    saved = search.margin, refine.U0_MARGIN, refine.UGR_MARGIN
    search.margin = ctx["spec"].design_margin
    refine.U0_MARGIN, refine.UGR_MARGIN = saved[1:] if saved[1] else (0.01, 0.1)
    try:
        xm, wm = _outputs(search, cols, may_drop=False)
    finally:
        search.margin, refine.U0_MARGIN, refine.UGR_MARGIN = saved
    print(f"{name}: polished, solved with the whole layout's openings: {w0:.2f} W with no"
          f" margin, {wm:.2f} W with the design's margins ({len(cols)} luminaires): "
          + ", ".join(f"{search.entries[c[0]].name} ({c[1][0]:.3f}, {c[1][1]:.3f})"
                      f" {100 * xi:.0f} %" for c, xi in zip(cur, x)), flush=True)
    from dataclasses import replace
    import pickle
    out = [replace(c[2][0], flux_lm=c[2][0].flux_lm * xi) for c, xi in zip(cur, x)]
    with open(ctx["cache"][:-4] + "_polished.pkl", "wb") as fh:
        pickle.dump(out, fh)
    return out


def _radiance_judge(name, lums, ctx):
    """Radiance's verdict on luminaires (:mod:`bench_design_radiance`'s judge, its job in
    out/radjobs/<room>/bound), dimmed to Radiance's need as the bench dims the designs."""
    b, env = B._radiance()
    job = os.path.join(B.JOBS, name, "bound")
    scene, spec = ctx["scene"], ctx["spec"]
    phot_paths = {e["name"]: e["photometry"] for e in ctx["cat"]}
    plan = B.judge_prepare(scene, spec, lums, job, phot_paths)
    t = time.perf_counter()
    subprocess.run(["sh", os.path.join(job, "run.sh")], env=dict(env, RADBIN=b), check=True)
    rad = B.judge_finish(job, plan, spec, lums)
    rs = B.judge_grids(scene, spec)[0]
    w = sum(next(e for e in spec.catalogue if e.name == lum.extra["type"]).watts
            * lum.flux_lm / next(e for e in spec.catalogue
                                 if e.name == lum.extra["type"]).flux_lm for lum in lums)
    ok = B.verdict(rad, rs)
    print(f"{name}: Radiance ({time.perf_counter() - t:.0f} s) of {w:.2f} W: Em"
          f" {rad['em']:.1f}/{rad['u0']:.3f}, "
          + ", ".join(f"{k} {rad[k][0]:.1f}/{rad[k][1]:.3f}"
                      for k in ("surroundings", "walls", "ceiling") if k in rad)
          + f", UGR {rad['ugr']:.1f}; fails: {[k for k, v in ok.items() if not v]}",
          flush=True)
    scale, rad2 = B.radiance_dimmed(lums, rad, rs, spec)
    if scale != 1.0:
        print(f"    dimmed evenly to Radiance's need: x {scale:.4f} -> {w * scale:.2f} W,"
              f" every item {all(B.verdict(rad2, rs).values())}", flush=True)
    elif all(ok.values()):
        re = B.redim_at_floor(name, "bound", lums, rad, rs, spec, scene, phot_paths, True)
        print("    above the floor dimmed to Radiance's need and re-traced: "
              + ("fails" if re is None else f"x {re[0]:.4f} -> {re[1]:.2f} W"), flush=True)


if __name__ == "__main__":
    args = sys.argv[1:]
    step = 0.4
    if "--step" in args:
        i = args.index("--step")
        step = float(args[i + 1])
        del args[i:i + 2]
    full = "--full" in args
    types = None
    if "--types" in args:
        i = args.index("--types")
        types = args[i + 1].split(",")
        del args[i:i + 2]
    milp_s = 0
    if "--milp" in args:
        i = args.index("--milp")
        milp_s = float(args[i + 1])
        del args[i:i + 2]
    cap = None
    if "--cap" in args:
        i = args.index("--cap")
        cap = float(args[i + 1])
        del args[i:i + 2]
    offset = None
    if "--offset" in args:
        i = args.index("--offset")
        offset = float(args[i + 1])
        del args[i:i + 2]
    if "--mesh" in args:
        i = args.index("--mesh")
        _scaled_mesh(float(args[i + 1]))
        del args[i:i + 2]
    if "--min-wall" in args:
        i = args.index("--min-wall")
        MIN_WALL_M = float(args[i + 1])
        del args[i:i + 2]
    polish, radiance = "--polish" in args, "--radiance" in args
    args = [a for a in args if a not in ("--full", "--polish", "--radiance")]
    for n in args or ["L_corridor"]:
        bound(n, step, full, types, milp_s, cap, offset, polish, radiance)
