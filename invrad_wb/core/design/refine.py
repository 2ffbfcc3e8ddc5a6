"""Per-group dimming of a layout: the least power of given positions, solved as a linear
programme on the exact model.

A regular grid dimmed evenly wastes light: its middle luminaires light the work plane
best, its outer ones the walls and the work plane's edge. Light adds up (radiosity is
linear), so with the luminaires of a layout split into groups (the outer and the inner
rows and columns, per catalogue class) and one exact solve per group, every requirement
is linear in the groups' outputs ``x``:

* a mean (work plane, walls, ceiling, surroundings, Ez) at least its minimum (x (1 +
  the design margin)): ``sum_g x_g mean_g >= lux``;
* a uniformity ``Emin / Em >= u0`` at every point ``j``: ``sum_g x_g (E_gj - u0 mean_g)
  >= 0``;
* the direct light on a point that must stay dark at most its limit;

and the power ``sum_g x_g W_g`` is minimised over ``x_g`` within each type's dimming range
(:func:`scipy.optimize.linprog`, HiGHS). UGR is not linear (its glare sum grows with
``x^2``, its background with ``x``) but its constraint ``0.25 pi sum_g x_g^2 T_g <=
10^(limit / 8) sum_g x_g B_g`` is convex: cutting planes at each solution that breaks it
(Kelley) until it holds. Every figure of the result is the exact model's (the groups'
solves added up), judged by :func:`.search.metrics_comply` like any other design.

A group may also be left out (its luminaires not installed) where that draws less: the
same rows with each group off or within its range, a mixed-integer programme
(:func:`scipy.optimize.milp`); the luminaires kept are then solved again as a layout of
their own (:func:`exact_refine`).

Which layouts: the search's own design and the fast model's cheapest candidates (those
within :data:`WATTS_WINDOW` of it, even ones that miss a uniformity when dimmed evenly:
brighter outer rows may meet it), ranked first by the same programme on the fast model
(no solves), then the best :data:`EXACT_TRIES` solved exactly.
"""
from dataclasses import replace
import math

import numpy as np

from invrad_wb.core.design.evaluate import unit_response
from invrad_wb.core.design.search import (EXACT_ONLY, Candidate, Metrics, margin_kept,
                                          metrics_comply)
from invrad_wb.core.output.glare import ugr_from_sum, unit_glare

#: rows / columns from each end of a layout that form their own group (2: the outer
#: ring, the next and the rest: up to 9 groups per class; finer groups never draw more,
#: they contain the coarser ones' answer; in a symmetric room a grid of up to 5 x 5 gets
#: a group per symmetry orbit, which a programme per luminaire would not beat)
RINGS = 2
#: uniformities are kept this far above their minimums in the programme (a dimmed layout
#: sits on its binding uniformity; another engine's figures scatter by about this much)
U0_MARGIN = 0.01
#: UGR is kept this far below its limit in the programme (the report's UGR sums each
#: luminaire's glare apart and differs from the glare sums by a few hundredths)
UGR_MARGIN = 0.1
#: relative gap at which the on / off programme (groups left out) stops
MIP_GAP = 1e-4
#: the luminaires a programme keeps are solved again as a layout of their own only while
#: its watts are within this factor of the best design's (their openings no longer
#: covering the ceiling change the light by a few tenths of a per cent)
DROP_TRUST = 1.01
#: the share of a group's watts charged for having it on (ties: fewer luminaires)
DROP_TIE = 1e-4
#: relative allowance for the solver's feasibility tolerance on the means
LP_TOL = 1e-5
#: fast candidates whose evenly dimmed watts are within this factor of the design's are
#: ranked by the fast programme
WATTS_WINDOW = 1.15
#: fast candidates ranked at most (those the fast programme finds an answer for) ...
FAST_TRIES = 80
#: ... among this many evaluated at most
FAST_ROWS = 300
#: layouts solved exactly at most (each: one exact solve per group)
EXACT_TRIES = 4
#: a layout is solved exactly while the fast programme's watts are within this factor of
#: the best design's (the fast model has no shadows and a per-point correction learnt on
#: other layouts)
FAST_TRUST = 1.05
#: cutting planes added for UGR at most (Kelley's method closes in slowly; each is one
#: more small programme)
UGR_CUTS = 40
#: a glare sum this share over the limit's counts as met (0.004 UGR; UGR_MARGIN keeps the
#: design below the limit)
UGR_CUT_TOL = 1e-3


def groups_of(plan, cls, rings=None, tol=0.05):
    """(L,) int group of each luminaire of a layout: its catalogue class and its ring
    along s and along t (0: the outermost of its row / column, 1: the next, ...,
    ``rings``: the rest; positions ``plan`` (L, 2) in the room's plan frame; ``tol`` m:
    the same row)."""
    rings = RINGS if rings is None else rings
    plan = np.asarray(plan, dtype=float)
    n = len(plan)
    ring = np.zeros((n, 2), dtype=int)
    for ax in (0, 1):
        other = 1 - ax
        for i in range(n):
            line = np.flatnonzero(np.abs(plan[:, other] - plan[i, other]) < tol)
            v = np.sort(plan[line, ax])
            k = int(np.searchsorted(v, plan[i, ax] - 1e-9))
            ring[i, ax] = min(k, len(v) - 1 - k, rings)
    r = rings + 1
    key = (np.asarray(cls) * r + ring[:, 0]) * r + ring[:, 1]
    _, g = np.unique(key, return_inverse=True)
    return g


def constraints(parts, search):
    """(A, b) of the linear requirements ``A x <= b`` on the groups' outputs ``x`` (see
    :func:`solve_outputs`): every mean at least its minimum x (1 + the design margin),
    every uniformity :data:`U0_MARGIN` above its minimum at every point, the direct light
    on the points that must stay dark, Ez where the room asks."""
    lay = search.model.layout
    # a hair above the margin: HiGHS meets constraints to about 1e-7 relative
    k1 = (1.0 + search.margin) * (1.0 + LP_TOL)
    L = np.asarray(parts["lux"], dtype=float)
    rows, rhs = [], []

    def mean_and_uniformity(block, w, lux, u0):
        m = block @ w / max(float(w.sum()), 1e-12)                 # (G,)
        rows.append(-m)
        rhs.append(-lux * k1)
        if u0 > 0:
            rows.extend(-(block - (u0 + U0_MARGIN) * m[:, None]).T)
            rhs.extend([0.0] * block.shape[1])

    wp = L[:, :lay.n_wp]
    mean_and_uniformity(wp, np.ones(lay.n_wp), search.req.lux, search.req.u0)
    for name, r in search.surf_reqs.items():
        if name in lay.parts:
            sl, w = lay.parts[name]
            mean_and_uniformity(L[:, sl], w, r.lux, r.u0)
    D = np.asarray(parts["direct"], dtype=float)
    if D.shape[1] > lay.shade0:
        rows.extend(D[:, lay.shade0:].T)
        rhs.extend([search.rs.shade_limit_lux] * (D.shape[1] - lay.shade0))
    if search.cyl_req is not None and parts.get("ez") is not None:
        ez = np.asarray(parts["ez"], dtype=float)
        mean_and_uniformity(ez, np.ones(ez.shape[1]), search.cyl_req["lux"],
                            search.cyl_req["u0"])
    return np.array(rows), np.array(rhs)


def solve_outputs(parts, watts, lo, hi, search, glare=None, may_drop=False):
    """The least-power outputs ``x`` (G,) of groups, or None where none meets the room.

    ``parts``: dict with ``lux`` (G, k) maintained lux at the model's points at full
    output, ``direct`` (G, k) its direct part, optionally ``ez`` (G, c) maintained Ez;
    ``watts`` (G,) rated power per group; ``lo``, ``hi`` (G,) output range; ``glare``:
    (T (G, O), B (G, O)) glare sums and maintained background lux per group at full output,
    or None (UGR not constrained). ``may_drop``: a group may also be left out (``x = 0``,
    its luminaires not installed) where that draws less: a mixed-integer programme, each
    group off or within its range (a type that does not dim: off or at full output)."""
    from scipy.optimize import Bounds, LinearConstraint, linprog, milp
    A, b = constraints(parts, search)
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    watts = np.asarray(watts, dtype=float)
    G = len(watts)
    ugr_max = search.ugr_max if glare is not None else None
    bounds = list(zip(lo, hi))
    if may_drop:
        # x_g <= hi_g z_g, x_g >= lo_g z_g with z_g in {0, 1}; a hair per luminaire on
        # the objective: of two answers of the same watts, the one with fewer groups on
        link = LinearConstraint(np.vstack([np.hstack([np.eye(G), -np.diag(hi)]),
                                           np.hstack([-np.eye(G), np.diag(lo)])]),
                                -np.inf, 0.0)
        c = np.r_[watts, np.full(G, DROP_TIE * max(float(watts.max()), 1e-12))]
        integ = np.r_[np.zeros(G), np.ones(G)]
    for _ in range(UGR_CUTS + 1):
        if may_drop:
            res = milp(c, constraints=[LinearConstraint(np.hstack([A, np.zeros_like(A)]),
                                                        -np.inf, b), link],
                       integrality=integ, bounds=Bounds(0.0, np.r_[hi, np.ones(G)]),
                       options={"mip_rel_gap": MIP_GAP})
            if res.x is None:
                return None
            on = res.x[G:] > 0.5
            x = np.where(on, np.clip(res.x[:G], lo, hi), 0.0)
        else:
            res = linprog(watts, A_ub=A, b_ub=b, bounds=bounds, method="highs")
            if res.status != 0:
                return None
            x = np.clip(res.x, lo, hi)
        if ugr_max is None:
            return x
        T, B = glare
        K = 10.0 ** ((ugr_max - UGR_MARGIN) / 8.0)
        # g(x) = 0.25 pi sum x^2 T - K sum x B <= 0 at every observer (convex)
        gx = 0.25 * math.pi * (x ** 2) @ T - K * (x @ B)
        worst = int(np.argmax(gx))
        if gx[worst] <= UGR_CUT_TOL * max(K * float(x @ B[:, worst]), 1e-12):
            return x
        grad = 0.5 * math.pi * x * T[:, worst] - K * B[:, worst]
        A = np.vstack([A, grad])
        b = np.append(b, grad @ x - gx[worst])
    return None


def _group_watts(search, cand, groups):
    """(G,) rated watts, (G,) lowest and (G,) highest output of each group."""
    g = cand.geom
    idx = np.asarray(cand.entries)[g.cls]
    G = int(groups.max()) + 1
    w = np.bincount(groups, weights=[search.entries[k].watts for k in idx], minlength=G)
    lo, hi = np.ones(G), np.ones(G)
    for gi in range(G):
        e = search.entries[int(idx[groups == gi][0])]
        if search.dimming:
            lo[gi], hi[gi] = e.dimming
    return w, lo, hi


def fast_watts(search, cand):
    """Watts of a layout with per-group outputs by the fast model (no solve; surfaces,
    Ez and UGR as the fast model knows them: Ez not; UGR with the background light per
    lumen at the eyes of the search's calibration), or inf where none meets it."""
    m, g = search.model, cand.geom
    groups = groups_of(g.plan, g.cls)
    idx = np.asarray(cand.entries)[g.cls]
    G = int(groups.max()) + 1
    lux = np.zeros((G, len(m.points)))
    direct = np.zeros((G, len(m.points)))
    O = len(search.obs)
    glare = None
    if search.ugr_max is not None and O and all(
            search.entries[k].key in search.eye_ind for k in np.unique(idx)):
        glare = (np.zeros((G, O)), np.zeros((G, O)))
    for k in np.unique(idx):
        e = search.entries[k]
        sel = idx == k
        r = unit_response(m.points, m.normals, g.positions[sel], g.normals[sel], e.radius_m,
                          search.phot.get(e.name), search._c0(e))
        for gi in np.unique(groups[sel]):
            cols = groups[sel] == gi
            d = m.mf * e.flux_lm * r[:, cols].sum(axis=1)
            direct[gi] += d
            lux[gi] += (d + m.mf * e.flux_lm * int(cols.sum())
                        * m.indirect_per_lm[e.key]) * m.correction
            if glare is not None:
                glare[1][gi] += (m.mf * e.flux_lm * int(cols.sum())
                                 * search.eye_ind[e.key])
        if glare is not None:
            # a type of high luminance ranks by what it really may draw under the UGR
            # limit, not by its lumens per watt alone
            for o, (eye, view) in enumerate(search.obs):
                u = unit_glare(eye, view, g.positions[sel], g.normals[sel], search._area(e),
                               search.phot.get(e.name), search._c0(e))
                glare[0][:, o] += e.flux_lm ** 2 * np.bincount(groups[sel], weights=u,
                                                               minlength=G)
    w, lo, hi = _group_watts(search, cand, groups)
    saved = search.cyl_req, search.surf_reqs
    try:
        # as the fast table judges: not Ez, not the surfaces it leaves to the exact checks
        search.cyl_req = None
        search.surf_reqs = {k: v for k, v in saved[1].items() if k not in EXACT_ONLY}
        # every group burning: the fast model's answer with groups left out is too
        # hopeful to rank by (the exact check tries leaving them out)
        x = solve_outputs({"lux": lux, "direct": direct}, w, lo, hi, search, glare)
    finally:
        search.cyl_req, search.surf_reqs = saved
    return math.inf if x is None else float(x @ w)


def exact_refine(search, cand, may_drop=True, limit=math.inf):
    """(Candidate with per-luminaire outputs ``dims``, Metrics) of a layout dimmed per
    group at least power on the exact model, or None where no outputs meet the room.
    ``may_drop``: groups may also be left out (:func:`solve_outputs`); the luminaires
    kept are then solved again as a layout of their own (the openings left out no longer
    cover the ceiling), dimmed per group on that, and win where they draw less; not
    where the programme's answer draws no less than every group burning, or over
    :data:`DROP_TRUST` x ``limit`` (the best design's watts so far)."""
    m, g = search.model, cand.geom
    groups = groups_of(g.plan, g.cls)
    G = int(groups.max()) + 1
    full = search.luminaires(Candidate(g, cand.entries, 1.0, 0.0, 0, 0, 0, False))
    lux, direct, ez, eh, T, B = [], [], [], [], [], []
    for gi in range(G):
        lums = [lum for lum, q in zip(full, groups) if q == gi]
        # each group lit alone under the whole layout's openings: the groups add up
        t, d = m.exact(lums, covering=full)
        lux.append(t)
        direct.append(d)
        if search.cylindrical is not None:
            z, h = search.cylindrical.evaluate(lums, covering=full)
            ez.append(z)
            eh.append(h)
        gl = search.exact_glare(lums, covering=full)
        if gl is not None:
            T.append(gl[0])
            B.append(gl[1])
    parts = {"lux": np.array(lux), "direct": np.array(direct),
             "ez": np.array(ez) if ez else None, "B": np.array(B) if B else None}
    glare = (np.array(T), np.array(B)) if T and search.ugr_max is not None else None
    w, lo, hi = _group_watts(search, cand, groups)
    x = solve_outputs(parts, w, lo, hi, search, glare)
    best = None if x is None else _refined(search, cand, groups, parts, T, ez, eh, w, x)
    if may_drop:
        xd = solve_outputs(parts, w, lo, hi, search, glare, may_drop=True)
        if (xd is not None and (xd <= 0).any()
                and (best is None or float(xd @ w) < best[0].watts - 1e-9)
                and float(xd @ w) < DROP_TRUST * limit):
            # the luminaires kept, solved again as a layout of their own: kept where it
            # meets the room for less than every group burning
            keep = xd[groups] > 0
            sub = replace(g, plan=g.plan[keep], positions=g.positions[keep],
                          normals=g.normals[keep], cls=g.cls[keep])
            r = exact_refine(search, Candidate(sub, cand.entries, 1.0, 0.0, 0, 0, 0,
                                               False), may_drop=False)
            if r is not None and r[0].ok and (best is None or not best[0].ok
                                              or r[0].watts < best[0].watts - 1e-9):
                best = r
    return best


def _refined(search, cand, groups, parts, T, ez, eh, w, x):
    """(Candidate, Metrics) of a layout's groups at outputs ``x`` (exact parts added)."""
    m, g = search.model, cand.geom
    met = Metrics.of(x @ parts["lux"], x @ parts["direct"], m.layout)
    if T:
        met.glare = ((x ** 2) @ np.array(T), x @ np.array(parts["B"]))
        u = ugr_from_sum(*met.glare)
        met.ugr = None if np.isnan(u).all() else float(np.nanmax(u))
    if ez:
        met.cyl = (x @ np.array(ez), x @ np.array(eh))
    watts = float(x @ w)
    dims = x[groups]
    ok = bool(metrics_comply(met, search) and margin_kept(met, search))
    c = Candidate(g, cand.entries, watts / max(float(w.sum()), 1e-12), watts, met.em,
                  met.u0, met.shade_max, ok, dims=dims)
    return c, met


def refine(search, cand, met, others=()):
    """The search's design ``(cand, met)`` or a cheaper compliant layout dimmed per group
    (see the module docstring): returns (Candidate, Metrics, tried) with ``tried`` the
    layouts solved exactly. ``others``: more (Candidate, Metrics) already checked exactly
    (the best regular grid, :func:`.search.classic_grids`): each competes as it stands
    and is solved per group whatever the fast programme says of it."""
    best = (cand, met) if cand is not None and cand.ok else None
    for c, m in others:
        if c is not None and c.ok and (best is None or c.watts < best[0].watts - 1e-9):
            best = (c, m)
    if not search.dimming or not any(e.dimming[0] < 1.0 for e in search.entries):
        return (best or (cand, met)) + (0,)
    limit = best[0].watts if best else math.inf
    t = search.table()
    pairs = search._pairs()
    seen, ranked, forced = set(), [], []
    for c, _ in [(cand, met), *others]:
        if c is not None and c.key() not in seen:
            seen.add(c.key())
            if any(search.entries[k].dimming[0] < 1.0 for k in c.entries):
                forced.append(c)
    for row in range(len(t["geom"])):
        if (len(seen) >= FAST_ROWS
                or sum(math.isfinite(r[0]) for r in ranked) >= FAST_TRIES):
            break
        w = float(t["watts"][row])
        if w > WATTS_WINDOW * limit:
            break
        pair = pairs[t["pair"][row]]
        if not all(search.entries[k].dimming[0] < 1.0 for k in pair):
            continue
        c = search.candidate(t, row)
        if c.key() in seen or c.u0 < search.req.u0 - 0.25:
            continue
        seen.add(c.key())
        ranked.append((fast_watts(search, c), c))
    ranked = [r for r in ranked if math.isfinite(r[0])]
    ranked.sort(key=lambda r: r[0])
    tried = 0
    todo = [(True, c) for c in forced] + [(False, c) for _, c in ranked[:EXACT_TRIES]]
    for i, (must, c) in enumerate(todo):
        fw = None if must else ranked[i - len(forced)][0]
        if fw is not None and best is not None and fw >= FAST_TRUST * best[0].watts:
            break
        tried += 1
        r = exact_refine(search, c, limit=best[0].watts if best else math.inf)
        if r is not None and r[0].ok and (best is None or r[0].watts < best[0].watts - 1e-9):
            best = r
    if best is None:
        return cand, met, tried
    return best[0], best[1], tried
