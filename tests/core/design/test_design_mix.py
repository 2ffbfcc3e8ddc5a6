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
