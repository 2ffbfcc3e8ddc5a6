"""The optimiser's reuse of a trial's forward model for its Jacobian (refine.py,
``residuals(..., memo=...)``): the same numbers as computing it again, fewer model
evaluations, and no reuse when the luminaires, their visibility or the fixed light differ."""
import numpy as np

from invrad_wb.core.inverse import refine as R
from test_refine import _ceiling_light, _problem


def _bits(lights):
    return [(L.position.tobytes(), L.normal.tobytes(), L.flux_scale) for L in lights]


def _fit(memo_on, free_flux=False):
    truth = [_ceiling_light(2.0, 1.5), _ceiling_light(4.2, 2.5), _ceiling_light(3.0, 3.2)]
    p = _problem(truth, fluxes=[2000.0, 2600.0, 1500.0] if free_flux else None)
    p.free_flux = free_flux
    start = [_ceiling_light(2.3, 1.2), _ceiling_light(3.9, 2.8), _ceiling_light(3.3, 3.0)]
    fixed = np.full(len(p.positions), 3.0)
    if not memo_on:
        plain = R.RefineProblem.residuals
        p.residuals = lambda lights, vis, jac=False, extra=None, memo=None: plain(
            p, lights, vis, jac, extra)
    got, cost = p.levenberg_marquardt(start, fixed=fixed)
    return _bits(got), cost, p.stats["evaluations"]


def test_reuse_gives_the_same_fit_with_fewer_evaluations():
    for free_flux in (False, True):
        with_memo, without = _fit(True, free_flux), _fit(False, free_flux)
        assert with_memo[:2] == without[:2]          # bit for bit, cost too
        assert with_memo[2] < 0.8 * without[2]       # the accepted trials' models reused


def test_no_reuse_for_other_lights_masks_or_fixed_light():
    p = _problem([_ceiling_light(2.0, 1.5)])
    k = len(p.positions)
    a, b = [_ceiling_light(2.2, 1.4)], [_ceiling_light(2.2, 1.45)]
    vis = [np.ones(k, bool)]
    half = [np.arange(k) % 2 == 0]
    extra = np.full(k, 5.0)
    cases = [(b, vis, None), (a, half, None), (a, vis, extra)]
    for lights, masks, fixed in cases:
        memo = {}
        p.residuals(a, vis, False, None, memo=memo)            # the trial
        r, J = p.residuals(lights, masks, True, fixed, memo=memo)
        r0, J0 = p.residuals(lights, masks, True, fixed)
        assert np.array_equal(r, r0) and np.array_equal(J, J0)
    memo = {}
    r1, _ = p.residuals(a, vis, False, None, memo=memo)
    n = p.stats["evaluations"]
    r, J = p.residuals(a, [vis[0].copy()], True, None, memo=memo)   # equal masks: reused
    assert p.stats["evaluations"] == n and r is r1
    assert np.array_equal(J, p.residuals(a, vis, True)[1])
    assert "trial" not in memo                                      # used once
