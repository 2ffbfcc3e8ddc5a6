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
(HiGHS through :func:`scipy.optimize.milp`). UGR is not linear: at an observer its glare
sum grows with ``x^2``, its background with ``x``, and ``UGR <= limit`` is ``0.25 pi
sum_g x_g^2 T_g <= 10^(limit / 8) sum_g x_g B_g``: convex in ``x`` (a sum of convex
squares on the left, a linear right-hand side). Each square gets a variable ``s_g >=
x_g^2``, which makes the constraint linear in ``(x, s)``; ``s_g >= x_g^2`` itself is
described from below by the secant through 0 and the dimming floor (exact for a group
that is off or at one output: a type that does not dim) and by tangents, more of them
where an answer breaks UGR (:func:`ugr_rows`). Each square is cut apart, so the
programme closes in within a few rounds where cutting planes on the whole glare sum
(Kelley) stalled: the hall of ``bench_design_bound.py``, 320 on / off positions of two
types, found a layout meeting UGR 22 in one round that 20 rounds of the sum's planes had
not. Every figure of the result is the exact model's (the groups' solves added up),
judged by :func:`.search.metrics_comply` like any other design.

A group may also be left out (its luminaires not installed) where that draws less: the
same rows with each group off or within its range, a mixed-integer programme; and in a
layout of one type each group may hold another type instead (:func:`swap_entry`: the
catalogue's most efficient other type, e.g. a clear high-bay among diffused ones), one
type or none per group: the programme puts the efficient, glaring type where the CIE 117
observers see it at high angles or not at all. The luminaires kept are then solved again
as a layout of their own (:func:`exact_refine`).

Which layouts: the search's own design and the fast model's cheapest candidates (those
within :data:`WATTS_WINDOW` of it, even ones that miss a uniformity when dimmed evenly:
brighter outer rows may meet it), ranked first by the same programme on the fast model
(no solves), then the best :data:`EXACT_TRIES` solved exactly.
"""
from dataclasses import replace
import math

import numpy as np

from invrad_wb.core.design.evaluate import unit_response
from invrad_wb.core.design.openings import half_sides
from invrad_wb.core.design.roomglare import seen_shares
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
#: a glare sum this share over the limit's counts as met (0.0004 UGR; UGR_MARGIN keeps the
#: design below the limit)
UGR_CUT_TOL = 1e-4


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


def solve_outputs(parts, watts, lo, hi, search, glare=None, may_drop=False,
                  time_limit=None, max_watts=None, exclusive=(), log=None):
    """The least-power outputs ``x`` (G,) of groups, or None where none meets the room.

    ``parts``: dict with ``lux`` (G, k) maintained lux at the model's points at full
    output, ``direct`` (G, k) its direct part, optionally ``ez`` (G, c) maintained Ez;
    ``watts`` (G,) rated power per group; ``lo``, ``hi`` (G,) output range; ``glare``:
    (T (G, O), B (G, O)) glare sums and background lux (new, as :mod:`.roomglare` rates
    UGR) per group at full output, or None (UGR not constrained). ``may_drop``: a group
    may also be left out (``x = 0``, its luminaires not installed) where that draws less:
    a mixed-integer programme, each group off or within its range (a type that does not
    dim: off or at full output).
    ``time_limit``: seconds per programme (HiGHS); ``max_watts``: no answer over it;
    ``exclusive``: pairs of groups of which at most one is on (with ``may_drop``);
    ``log``: called with a line per programme solved (figures of the rounds).

    UGR: each group's squared output gets a variable ``s_g >= x_g^2`` (see
    :func:`ugr_rows`), kept linear by tangents, so that the glare constraint is linear in
    ``(x, s)``; tangents are added where an answer breaks UGR (per group: Kelley on each
    square, not on the sum), an exact description where a group is off or at one output.
    The last programme's answer is returned with :attr:`solve_outputs.dual_bound` set to
    the solver's lower bound on the watts (``None`` where not known)."""
    from scipy.optimize import Bounds, LinearConstraint, milp
    A, b = constraints(parts, search)
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    watts = np.asarray(watts, dtype=float)
    G = len(watts)
    ugr_max = search.ugr_max if glare is not None else None
    solve_outputs.dual_bound = None
    # variables: x (G), z (G) when groups may be left out, s (G) when UGR is constrained
    nz = G if may_drop else 0
    ns = G if ugr_max is not None else 0
    n = G + nz + ns
    c = np.zeros(n)
    c[:G] = watts
    if may_drop:
        # a hair per luminaire on the objective: of two answers of the same watts, the
        # one with fewer groups on
        c[G:G + nz] = DROP_TIE * max(float(watts.max()), 1e-12)
    rows = [np.hstack([A, np.zeros((len(A), nz + ns))])]
    ub = [b]
    if max_watts is not None:
        rows.append(c[None, :] * (np.arange(n) < G))
        ub.append([max_watts])
    if may_drop:
        # x_g <= hi_g z_g, x_g >= lo_g z_g with z_g in {0, 1}
        rows.append(np.hstack([np.eye(G), -np.diag(hi), np.zeros((G, ns))]))
        rows.append(np.hstack([-np.eye(G), np.diag(lo), np.zeros((G, ns))]))
        ub += [np.zeros(G), np.zeros(G)]
        for a, b_ in exclusive:
            r = np.zeros((1, n))
            r[0, G + a] = r[0, G + b_] = 1.0
            rows.append(r)
            ub.append([1.0])
    integ = np.r_[np.zeros(G), np.ones(nz), np.zeros(ns)]
    lb_x = np.zeros(G) if may_drop else lo
    bounds = Bounds(np.r_[lb_x, np.zeros(nz + ns)],
                    np.r_[hi, np.ones(nz), hi ** 2 if ns else np.zeros(0)])
    if ugr_max is not None:
        T, Bg = glare
        K = 10.0 ** ((ugr_max - UGR_MARGIN) / 8.0)
        S0 = G + nz
        T0, B0 = _fixed_glare(search, T.shape[1])
        r, u = ugr_rows(T, Bg, K, lo, hi, G, n, S0,
                        fixed=getattr(search, "fixed_glare", None))
        rows.append(r)
        ub.append(u)
    opts = {"mip_rel_gap": MIP_GAP}
    if time_limit:
        opts["time_limit"] = float(time_limit)
    for _ in range(UGR_CUTS + 1):
        res = milp(c, constraints=[LinearConstraint(np.vstack(rows), -np.inf,
                                                    np.concatenate(ub))],
                   integrality=integ if may_drop else None, bounds=bounds,
                   options=opts)
        solve_outputs.dual_bound = getattr(res, "mip_dual_bound", None)
        if res.x is None:
            if res.status == 2:          # infeasible: a bound of +inf
                solve_outputs.dual_bound = math.inf
            return None
        if res.status == 0 and not may_drop:
            solve_outputs.dual_bound = float(res.fun)
        x = res.x[:G]
        if may_drop:
            on = res.x[G:G + nz] > 0.5
            x = np.where(on, np.clip(x, lo, hi), 0.0)
        else:
            x = np.clip(x, lo, hi)
        if ugr_max is None:
            return x
        # g(x) = 0.25 pi (sum x^2 T + T0) - K (sum x B + B0) <= 0 at every observer
        # (convex; T0, B0 the fixed luminaires')
        gx = 0.25 * math.pi * ((x ** 2) @ T + T0) - K * (x @ Bg + B0)
        tol = UGR_CUT_TOL * np.maximum(K * (x @ Bg + B0), 1e-12)
        if log is not None:
            u = ugr_from_sum((x ** 2) @ T + T0, x @ Bg + B0)
            log(f"programme {_ + 1}: {float(x @ watts):.1f} W (lower bound"
                f" {solve_outputs.dual_bound}), UGR {np.nanmax(u):.2f},"
                f" {len(rows)} blocks of rows, {res.message}")
        if (gx <= tol).all():
            return x
        # tangents of each square where the answer's s_g falls short of x_g^2
        s = res.x[S0:S0 + G]
        short = np.flatnonzero(x ** 2 - s > 1e-9 * np.maximum(x ** 2, 1.0))
        if len(short) == 0:
            return x                     # the squares are met: UGR is as the solver saw
        cut = np.zeros((len(short), n))
        cut[np.arange(len(short)), short] = 2.0 * x[short]
        cut[np.arange(len(short)), S0 + short] = -1.0
        rows.append(cut)
        ub.append(x[short] ** 2)
    return None


#: tangents of each group's squared output laid at first, evenly over its range
UGR_TANGENTS = 8


def _fixed_glare(search, O):
    """(T0 (O,), B0 (O,)): the glare sums and background lux at the observers of the
    luminaires that stay as they are (``search.fixed_glare``, a room's accents), zeros
    where there are none."""
    fixed = getattr(search, "fixed_glare", None)
    if fixed is None:
        return np.zeros(O), np.zeros(O)
    return np.asarray(fixed[0], dtype=float), np.asarray(fixed[1], dtype=float)


def ugr_rows(T, B, K, lo, hi, G, n, S0, fixed=None):
    """(rows, ub) of the UGR constraints on the variables ``(x, ..., s)`` (``n`` in all,
    the squares ``s`` from ``S0``): per observer ``o``, ``UGR <= limit`` is ``0.25 pi
    (sum_g s_g T_go + T0_o) <= K (sum_g x_g B_go + B0_o)`` (``K = 10^(limit / 8)``, the
    background lux ``B`` linear in ``x``, the glare sums ``T`` in ``x^2``; ``fixed``:
    ``(T0 (O,), B0 (O,))`` of luminaires that stay as they are, e.g. accents, whose glare
    the general lighting's background must dilute: the rows' bound ``K B0 - 0.25 pi T0``;
    None: 0), and ``s_g >= x_g^2``
    described from below: the secant ``s_g >= lo_g x_g`` (exact where ``x_g`` is 0 or
    ``lo_g``: a type that does not dim, off or on, is described exactly) and tangents at
    :data:`UGR_TANGENTS` outputs of its range. Every answer of the true constraints is
    one of these (a relaxation): a lower bound, tightened by the caller's tangents where
    an answer breaks UGR."""
    T, B = np.asarray(T, dtype=float), np.asarray(B, dtype=float)
    O = T.shape[1]
    rows = np.zeros((O, n))
    rows[:, S0:S0 + G] = 0.25 * math.pi * T.T
    rows[:, :G] = -K * B.T
    ub = [np.zeros(O) if fixed is None else
          K * np.asarray(fixed[1], dtype=float) - 0.25 * math.pi * np.asarray(fixed[0],
                                                                             dtype=float)]
    out = [rows]
    sec = np.zeros((G, n))
    sec[np.arange(G), np.arange(G)] = lo
    sec[np.arange(G), S0 + np.arange(G)] = -1.0
    out.append(sec)
    ub.append(np.zeros(G))
    for g in range(G):
        if hi[g] - lo[g] < 1e-9:
            continue
        for a in np.linspace(lo[g], hi[g], UGR_TANGENTS):
            r = np.zeros(n)
            r[g], r[S0 + g] = 2.0 * a, -1.0
            out.append(r[None])
            ub.append([a * a])
    return np.vstack(out), np.concatenate(ub)


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


def _fast_parts(search, cand, groups):
    """(parts, glare, watts, lo, hi) of a layout's groups by the fast model (no solve):
    see :func:`solve_outputs`; glare None where UGR is not constrained or the fast model
    has no background light at the eyes for a type."""
    m, g = search.model, cand.geom
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
                glare[1][gi] += (e.flux_lm * int(cols.sum())    # new (roomglare)
                                 * search.eye_ind[e.key])
        if glare is not None:
            # a type of high luminance ranks by what it really may draw under the UGR
            # limit, not by its lumens per watt alone
            for o, (eye, view) in enumerate(search.obs):
                seen = seen_shares(m, eye, g.positions[sel], g.normals[sel],
                                   half_sides(e.radius_m, search.phot.get(e.name)),
                                   search._c0(e))
                u = unit_glare(eye, view, g.positions[sel], g.normals[sel], search._area(e),
                               search.phot.get(e.name), search._c0(e), seen)
                glare[0][:, o] += e.flux_lm ** 2 * np.bincount(groups[sel], weights=u,
                                                               minlength=G)
    w, lo, hi = _group_watts(search, cand, groups)
    return {"lux": lux, "direct": direct}, glare, w, lo, hi


def _fast_solve(search, *args, **kw):
    """:func:`solve_outputs` as the fast table judges: not Ez, not the surfaces it
    leaves to the exact checks."""
    saved = search.cyl_req, search.surf_reqs
    try:
        search.cyl_req = None
        search.surf_reqs = {k: v for k, v in saved[1].items()
                            if not k.startswith(EXACT_ONLY)}
        return solve_outputs(*args, **kw)
    finally:
        search.cyl_req, search.surf_reqs = saved


def fast_watts(search, cand):
    """Watts of a layout with per-group outputs by the fast model (no solve; surfaces,
    Ez and UGR as the fast model knows them: Ez not; UGR with the background light per
    lumen at the eyes of the search's calibration), or inf where none meets it."""
    g = cand.geom
    parts, glare, w, lo, hi = _fast_parts(search, cand, groups_of(g.plan, g.cls))
    # every group burning: the fast model's answer with groups left out is too hopeful
    # to rank by (the exact check tries leaving them out)
    x = _fast_solve(search, parts, w, lo, hi, search, glare)
    return math.inf if x is None else float(x @ w)


def swap_entry(search, cand):
    """Index of the catalogue entry that may take the places of some groups of a layout
    of one type (:func:`exact_refine`), or None: the entry of most lumens per watt among
    those of another name whose luminous opening the layout's positions are clear for
    (of a type that is itself the most efficient: the next). A more efficient type
    glares more or spreads its light otherwise (a clear high-bay beside a diffused one);
    where each of a layout's groups may be either, the programme puts the efficient one
    where glare and uniformity allow."""
    g = cand.geom
    own = {int(cand.entries[c]) for c in np.unique(g.cls)}
    if len(own) != 1:
        return None
    name = search.entries[own.pop()].name
    clear = g.clearance if g.clearance is not None else math.inf
    best, eff = None, -math.inf
    for k, e in enumerate(search.entries):
        if e.name == name or search._half_size(e) > clear + 1e-9 or e.watts <= 0:
            continue
        if e.flux_lm / e.watts > eff + 1e-12:
            best, eff = k, e.flux_lm / e.watts
    return best


def _group_solves(search, full, groups, G, covering):
    """Per group ``g < G`` of luminaires ``full`` (grouped by ``groups``), lit alone
    under the openings of ``covering``: lists of maintained lux, direct lux, Ez, Eh,
    glare sums and background lux at the eyes (the last four empty where not asked)."""
    m = search.model
    lux, direct, ez, eh, T, B = [], [], [], [], [], []
    for gi in range(G):
        lums = [lum for lum, q in zip(full, groups) if q == gi]
        # each group lit alone under the whole layout's openings: the groups add up
        t, d = m.exact(lums, covering=covering)
        lux.append(t)
        direct.append(d)
        if search.cylindrical is not None:
            z, h = search.cylindrical.evaluate(lums, covering=covering)
            ez.append(z)
            eh.append(h)
        gl = search.exact_glare(lums, covering=covering)
        if gl is not None:
            T.append(gl[0])
            B.append(gl[1])
    return lux, direct, ez, eh, T, B


def exact_refine(search, cand, may_drop=True, limit=math.inf, groups=None):
    """(Candidate with per-luminaire outputs ``dims``, Metrics) of a layout dimmed per
    group at least power on the exact model, or None where no outputs meet the room.
    ``may_drop``: groups may also be left out (:func:`solve_outputs`), and in a layout
    of one type each group may instead hold the luminaires of :func:`swap_entry` (per
    group one type or none); the luminaires kept are then solved again as a layout of
    their own (the openings left out no longer cover the ceiling), dimmed per group on
    that, and win where they draw less; not where the programme's answer draws no less
    than every group burning, or over :data:`DROP_TRUST` x ``limit`` (the best design's
    watts so far). ``groups``: (L,) group of each luminaire (default :func:`groups_of`)."""
    g = cand.geom
    if groups is None:
        groups = groups_of(g.plan, g.cls)
    G = int(groups.max()) + 1
    full = search.luminaires(Candidate(g, cand.entries, 1.0, 0.0, 0, 0, 0, False))
    lux, direct, ez, eh, T, B = _group_solves(search, full, groups, G, full)
    parts = {"lux": np.array(lux), "direct": np.array(direct),
             "ez": np.array(ez) if ez else None, "B": np.array(B) if B else None}
    glare = (np.array(T), np.array(B)) if T and search.ugr_max is not None else None
    w, lo, hi = _group_watts(search, cand, groups)
    x = solve_outputs(parts, w, lo, hi, search, glare)
    best = None if x is None else _refined(search, cand, groups, parts, T, ez, eh, w, x)
    if not may_drop:
        return best
    # the programme's answers with groups left out: every group of the layout's own
    # types, and where another type may take their places, per group one type or none
    xd = solve_outputs(parts, w, lo, hi, search, glare, may_drop=True)
    offers = [] if xd is None else [(float(xd @ w), xd, None)]
    k = swap_entry(search, cand)
    if k is not None:
        # each group's twin: the same places with entry k's luminaires
        own = int(cand.entries[int(g.cls[0])])
        other = Candidate(g, (k, k), 1.0, 0.0, 0, 0, 0, False)
        twin = search.luminaires(other)
        lux2, direct2, ez2, eh2, T2, B2 = _group_solves(search, twin, groups, G, full)
        w2, lo2, hi2 = _group_watts(search, other, groups)
        both = {"lux": np.array(lux + lux2), "direct": np.array(direct + direct2),
                "ez": np.array(ez + ez2) if ez else None}
        glare2 = ((np.array(T + T2), np.array(B + B2))
                  if T and search.ugr_max is not None else None)
        xx = solve_outputs(both, np.r_[w, w2], np.r_[lo, lo2], np.r_[hi, hi2], search,
                           glare2, may_drop=True,
                           exclusive=[(i, G + i) for i in range(G)])
        if xx is not None and (xx[G:] > 0).any():
            offers.append((float(xx @ np.r_[w, w2]), xx[:G], xx[G:]))
    for wd, xd, alt in sorted(offers, key=lambda o: o[0]):
        if not ((xd <= 0).any() and (best is None or wd < best[0].watts - 1e-9)
                and wd < DROP_TRUST * limit):
            continue
        # the luminaires kept, solved again as a layout of their own: kept where it
        # meets the room for less than every group burning
        swapped = np.zeros(len(groups), dtype=bool) if alt is None else alt[groups] > 0
        keep = (xd[groups] > 0) | swapped
        cls, entries = g.cls[keep], cand.entries
        if swapped.any():
            cls, entries = swapped[keep].astype(int), (own, k)
        sub = replace(g, plan=g.plan[keep], positions=g.positions[keep],
                      normals=g.normals[keep], cls=cls)
        # the kept luminaires' own rows and rings (per type) split by the programme's
        # groups: every answer of either grouping is one of these
        rings = groups_of(sub.plan, cls)
        sub_groups = np.unique(np.c_[groups[keep] + G * swapped[keep], rings], axis=0,
                               return_inverse=True)[1].ravel()
        r = exact_refine(search, Candidate(sub, entries, 1.0, 0.0, 0, 0, 0, False),
                         may_drop=False, groups=sub_groups)
        if r is not None and r[0].ok and (best is None or not best[0].ok
                                          or r[0].watts < best[0].watts - 1e-9):
            best = r
            break
    return best


def _refined(search, cand, groups, parts, T, ez, eh, w, x):
    """(Candidate, Metrics) of a layout's groups at outputs ``x`` (exact parts added)."""
    m, g = search.model, cand.geom
    met = Metrics.of(x @ parts["lux"], x @ parts["direct"], m.layout)
    if T:
        # the whole installation's: the fixed luminaires' (accents') glare and background
        # added (light adds up)
        T0, B0 = _fixed_glare(search, np.array(T).shape[1])
        met.glare = ((x ** 2) @ np.array(T) + T0, x @ np.array(parts["B"]) + B0)
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
