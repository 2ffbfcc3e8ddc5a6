"""Two types per place in the per-group programme (design/refine.py): an efficient type
that glares and a diffused one; the programme puts each where UGR allows."""
from types import SimpleNamespace

import numpy as np

from invrad_wb.core.design.evaluate import Layout
from invrad_wb.core.output.glare import ugr_from_sum


def _search(ugr_max):
    return SimpleNamespace(model=SimpleNamespace(layout=Layout(2, {}, 2)), margin=0.0,
                           req=SimpleNamespace(lux=250.0, u0=0.0), surf_reqs={},
                           rs=SimpleNamespace(shade_limit_lux=1e9), cyl_req=None,
                           ugr_max=ugr_max)


def test_the_efficient_type_goes_where_it_does_not_glare_and_the_answer_is_the_least():
    """Two places; groups 0, 1: the clear type (no dimming: off or full) at place 0, 1;
    groups 2, 3: the diffused type (10-100 %) there; per place one type or none. The
    clear one glares at the observer from place 0, hardly from place 1. Without UGR the
    programme takes the clear one at place 0 (it lights best); with UGR the clear one
    moves to place 1, and its answer is the least power of every choice of types and
    outputs (brute force), meets UGR and keeps one type per place."""
    from invrad_wb.core.design.refine import UGR_MARGIN, solve_outputs
    lux = np.array([[160.0, 160.0], [150.0, 150.0], [130.0, 130.0], [130.0, 130.0]])
    parts = {"lux": lux, "direct": 0.5 * lux}
    watts = np.full(4, 10.0)
    lo, hi = np.array([1.0, 1.0, 0.1, 0.1]), np.ones(4)
    T = np.array([[1e5], [2e3], [1e3], [1e3]])
    B = np.array([[20.0], [20.0], [20.0], [20.0]])
    pairs = [(0, 2), (1, 3)]
    plain = solve_outputs(parts, watts, lo, hi, _search(None), may_drop=True,
                          exclusive=pairs)
    assert plain[0] == 1.0 and plain[1] == 0.0 and plain[2] == 0.0
    x = solve_outputs(parts, watts, lo, hi, _search(19.0), glare=(T, B), may_drop=True,
                      exclusive=pairs)
    assert x is not None
    assert not (x[0] > 0 and x[2] > 0) and not (x[1] > 0 and x[3] > 0)
    assert x[0] == 0.0 and x[1] == 1.0 and x[2] > 0
    assert x @ lux[:, 0] >= 250.0 * (1 - 1e-6)
    assert ugr_from_sum((x ** 2) @ T, x @ B)[0] <= 19.0 - UGR_MARGIN + 1e-3
    # brute force: per place none / clear / diffused at 0.1 ... 1
    a = np.linspace(0.1, 1.0, 901)
    best = np.inf
    for p0 in ("-", "c", "d"):
        for p1 in ("-", "c", "d"):
            X = np.zeros((len(a), 4))
            if p0 == "c":
                X[:, 0] = 1.0
            if p1 == "c":
                X[:, 1] = 1.0
            if p0 == "d":
                X[:, 2] = a
            if p1 == "d":
                X = np.repeat(X, len(a), axis=0)
                X[:, 3] = np.tile(a, len(X) // len(a))
            ok = ((X @ lux[:, 0] >= 250.0 - 1e-9)
                  & (ugr_from_sum((X ** 2) @ T, X @ B)[:, 0] <= 19.0 - UGR_MARGIN))
            if ok.any():
                best = min(best, float((X[ok] @ watts).min()))
    assert x @ watts <= best + 0.02
    assert x @ watts > plain @ watts + 0.5        # UGR costs power here


def test_a_layout_takes_the_efficient_type_in_some_groups_where_that_draws_less():
    """A box room, a dimmable type and an efficient one that does not dim (same size):
    the layouts of the dimmable type get the efficient one in the groups where it draws
    less (:func:`refine.swap_entry`); the result is a real design (an independent exact
    solve of its luminaires gives its figures, every requirement met with the margin),
    each luminaire within its type's range, for less power than without the swap."""
    from invrad_wb.core.design import refine
    from invrad_wb.core.design.design import _with_surroundings
    from invrad_wb.core.design.evaluate import RoomModel, surface_grids
    from invrad_wb.core.design.room import DesignRoom
    from invrad_wb.core.design.search import (Candidate, Metrics, RoomSearch,
                                              metrics_comply)
    from invrad_wb.core.design.spec import spec_from_dict
    from invrad_wb.core.synthetic import generate as g
    size = (5.0, 4.0, 2.8)
    sc = g.with_reflectances(g.box_room(size=size, cell=0.5))
    cat = [{"name": "D", "flux_lm": 3500, "watts": 26.0, "dimming": [0.1, 1.0],
            "radius_m": 0.25},
           {"name": "E", "flux_lm": 3500, "watts": 22.0, "radius_m": 0.25}]
    spec = spec_from_dict({"maintenance_factor": 0.8, "catalogue": cat, "rooms": {"0": {
        "work_plane": {"lux": 500, "u0": 0.6}, "walls": {"lux": 75}}}})
    rs = spec.room_spec(0)
    droom = DesignRoom(sc, 0)
    req = rs.work_plane
    pts, _ = droom.grid(req.height_m, req.margin_m)
    surfaces = surface_grids(sc, 0, droom)
    rs = _with_surroundings(rs, droom, req, surfaces, type("RD", (), {"notes": []})())
    model = RoomModel(sc, droom, pts, spec.maintenance_factor, surfaces=surfaces)
    search = RoomSearch(model, req, rs, spec.entries_for(rs, size[2]), {}, mixed=False,
                        fractions=(0.5,))
    search.margin = spec.design_margin
    d = next(k for k, e in enumerate(search.entries) if e.name == "D")
    e_ = next(k for k, e in enumerate(search.entries) if e.name == "E")
    # a classic 3 x 3 grid of the dimmable type (its end columns a class of their own)
    geom = next(x for x in search.geoms if (x.ns, x.nt) == (3, 3)
                and x.edge_deviation == 0 and x.count == 9)
    cand = Candidate(geom, (d, d), 1.0, 0.0, 0, 0, 0, False)
    assert refine.swap_entry(search, cand) == e_
    got = refine.exact_refine(search, cand)
    saved = refine.swap_entry
    refine.swap_entry = lambda *a: None
    try:
        plain = refine.exact_refine(search, cand)
    finally:
        refine.swap_entry = saved
    assert got is not None and got[0].ok
    c, met = got
    assert plain is None or c.watts < plain[0].watts - 0.5
    lums = search.luminaires(c)
    kinds = [lum.extra["type"] for lum in lums]
    assert "E" in kinds
    for lum in lums:
        f = lum.flux_lm / 3500.0
        assert (f == 1.0) if lum.extra["type"] == "E" else (0.1 - 1e-9 <= f <= 1 + 1e-9)
    assert abs(sum((22.0 if k == "E" else 26.0) * lum.flux_lm / 3500.0
                   for k, lum in zip(kinds, lums)) - c.watts) < 1e-6
    total, direct = model.exact(lums)
    ind = Metrics.of(total, direct, model.layout)
    # the groups' solves add up to the whole (to the solver's float32 sums)
    assert abs(ind.em - met.em) < 1e-5 * met.em and abs(ind.u0 - met.u0) < 1e-5
    assert metrics_comply(ind, search) and ind.em >= 500 * (1 + search.margin) - 1e-3

