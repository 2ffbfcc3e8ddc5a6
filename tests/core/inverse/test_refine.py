"""Joint refinement on its own (inverse/refine.py): the analytic model and Jacobian, the
Levenberg-Marquardt fit pulling perturbed luminaires back, the greedy selection keeping
only luminaires that explain light, and the cost's robustness."""
import numpy as np
import pytest

from invrad_wb.core.inverse.refine import Light, RefineProblem
from invrad_wb.core.inverse.select import greedy_select


def _points():
    """Receivers on a 6 x 4 m floor (facing up) and on one wall (facing +x)."""
    x, y = np.meshgrid(np.linspace(0.1, 5.9, 30), np.linspace(0.1, 3.9, 20), indexing="ij")
    floor = np.c_[x.ravel(), y.ravel(), np.zeros(x.size)]
    y, z = np.meshgrid(np.linspace(0.1, 3.9, 15), np.linspace(0.1, 2.9, 10), indexing="ij")
    wall = np.c_[np.zeros(y.size), y.ravel(), z.ravel()]
    pts = np.concatenate([floor, wall])
    nrm = np.concatenate([np.tile([0, 0, 1.0], (len(floor), 1)),
                          np.tile([1.0, 0, 0], (len(wall), 1))])
    return pts, nrm


def _ceiling_light(x, y, h=3.0):
    """A luminaire on the ceiling plane z = h (3 m unless given), facing down, moving in
    that plane."""
    return Light("surface", np.array([x, y, h]), np.array([0, 0, -1.0]), 0,
                 origin=np.array([0.0, 0.0, h]), u=np.array([1.0, 0, 0]),
                 v=np.array([0, 1.0, 0]))


def _problem(true_lights, flux=2000.0, fluxes=None):
    """The problem of luminaires of ``flux`` lm (or each its own of ``fluxes``)."""
    pts, nrm = _points()
    target = np.zeros(len(pts))
    fluxes = fluxes or [flux] * len(true_lights)
    for L, F in zip(true_lights, fluxes):   # the textbook lambertian formula, independently
        d = pts - L.position
        r2 = (d * d).sum(1)
        cos_l = np.maximum(d @ L.normal, 0) / np.sqrt(r2)
        cos_s = np.maximum(-(d * nrm).sum(1), 0) / np.sqrt(r2)
        target += F * cos_l * cos_s / (np.pi * r2)
    return RefineProblem(positions=pts, normals=nrm, target=target, flux=flux,
                         area=np.ones(len(pts)), inside=lambda L: L)


def test_model_matches_the_textbook_formula():
    truth = [_ceiling_light(2.0, 1.5)]
    p = _problem(truth)
    e, _ = p.light_of(truth[0], np.ones(len(p.positions), bool))
    np.testing.assert_allclose(e, p.target, rtol=1e-12)


def _check_jacobian(p, lights):
    """The analytic Jacobian of the residuals against forward differences."""
    vis = [p.visibility(L) for L in lights]
    r, J = p.residuals(lights, vis, with_jac=True)
    h = 1e-6
    k = 0
    for i, L in enumerate(lights):
        for j in range(len(L.params())):
            q = L.params().copy()
            q[j] += h
            moved = [M if m != i else L.with_params(q) for m, M in enumerate(lights)]
            r2, _ = p.residuals(moved, vis)
            np.testing.assert_allclose(J[:, k], (r2 - r) / h, rtol=1e-4, atol=1e-6)
            k += 1
    assert k == J.shape[1]


def test_jacobian_matches_finite_differences():
    p = _problem([_ceiling_light(2.0, 1.5), _ceiling_light(4.2, 2.5)])
    _check_jacobian(p, [_ceiling_light(2.3, 1.2), _ceiling_light(3.9, 2.8)])


def test_jacobian_with_free_flux_matches_finite_differences():
    """With each luminaire's flux a parameter (its log), the Jacobian's flux column is the
    luminaire's whole light, its interreflection (scaled with the flux) included."""
    p = _problem([_ceiling_light(2.0, 1.5)])
    p.free_flux = True
    lights = p._own_copies([_ceiling_light(2.3, 1.2), _ceiling_light(3.9, 2.8)])
    lights[0].flux_scale, lights[1].flux_scale = 0.6, 1.7
    lights[1].indirect = np.linspace(1.0, 30.0, len(p.positions))
    assert all(len(L.params()) == 3 for L in lights)
    _check_jacobian(p, lights)


def test_levenberg_marquardt_fits_each_flux_with_the_position():
    truth = [_ceiling_light(1.5, 1.0), _ceiling_light(4.5, 3.0)]
    p = _problem(truth, flux=2000.0, fluxes=[1200.0, 3100.0])
    p.free_flux = True
    start = [_ceiling_light(1.75, 0.8), _ceiling_light(4.3, 3.2)]      # 20-30 cm off
    fixed_flux = _problem(truth, flux=2000.0, fluxes=[1200.0, 3100.0])
    _, cost_fixed = fixed_flux.levenberg_marquardt(start, iterations=60)
    lights, cost = p.levenberg_marquardt(start, iterations=60)
    lights.sort(key=lambda L: L.position[0])
    for L, T, F in zip(lights, truth, [1200.0, 3100.0]):
        assert np.linalg.norm(L.position - T.position) < 1e-3
        assert L.position[2] == pytest.approx(3.0)
        assert 2000.0 * L.flux_scale == pytest.approx(F, rel=1e-3)
    assert cost < 1e-8 < cost_fixed       # one flux for both cannot explain the light


def test_levenberg_marquardt_pulls_luminaires_back():
    truth = [_ceiling_light(1.5, 1.0), _ceiling_light(4.5, 3.0)]
    p = _problem(truth)
    start = [_ceiling_light(1.75, 0.8), _ceiling_light(4.3, 3.2)]      # 20-30 cm off
    lights, cost = p.levenberg_marquardt(start, iterations=60)
    for L, T in zip(sorted(lights, key=lambda L: L.position[0]), truth):
        assert np.linalg.norm(L.position - T.position) < 1e-3
        assert L.position[2] == pytest.approx(3.0)       # stays on its plane
    assert cost < 1e-8 < p.cost(start)


def test_greedy_selection_ends_with_the_luminaires_that_explain_the_light():
    truth = [_ceiling_light(1.5, 1.0), _ceiling_light(4.5, 3.0)]
    p = _problem(truth)
    # two good candidates (a few cm off) and a phantom in the middle, offered first
    cands = [_ceiling_light(3.0, 2.0), _ceiling_light(1.55, 1.05),
             _ceiling_light(4.45, 2.95)]
    lights, cost, trace = greedy_select(p, cands, patience=5)
    assert len(lights) == 2
    found = sorted(L.position[0] for L in lights)
    assert found == pytest.approx([1.5, 4.5], abs=1e-3)
    assert cost < 1e-8
    # the phantom between them was refined onto a real luminaire, not kept as a third
    assert trace[0]["result"] == "kept" and all(t["result"] == "kept" for t in trace)
    assert all(L.score > 0 for L in lights)


def test_cost_is_robust_to_a_hot_spot():
    truth = [_ceiling_light(3.0, 2.0)]
    p = _problem(truth)
    r = np.zeros(len(p.target))
    r[0] = 5.0                                       # one point wildly off (e ~ 150x)
    c = p.robust_scale
    one = p.w_area[0] * c * c * (np.sqrt(1 + (5.0 / c) ** 2) - 1)
    assert p.cost_of(r) == pytest.approx(one)
    assert one < p.w_area[0] * 0.5 * 5.0 ** 2         # linear, not quadratic, far out


def test_evolution_strategy_pulls_a_luminaire_back():
    truth = [_ceiling_light(2.5, 1.5)]
    p = _problem(truth)
    start = [_ceiling_light(2.7, 1.35)]                                  # 25 cm off
    lights, cost = p.evolution_strategy(start, iterations=600, seed=3)
    assert np.linalg.norm(lights[0].position - truth[0].position) < 0.01
    assert lights[0].position[2] == pytest.approx(3.0)
    assert cost < 1e-3 * p.cost(start)


def test_fixed_light_is_held_while_the_other_moves():
    """``fixed``: the light of luminaires that stay put; only the given one moves."""
    truth = [_ceiling_light(1.5, 1.0), _ceiling_light(4.5, 3.0)]
    p = _problem(truth)
    held = p.fixed_light([truth[0]])
    lights, cost = p.levenberg_marquardt([_ceiling_light(4.3, 3.2)], iterations=60,
                                         fixed=held)
    assert len(lights) == 1
    assert np.linalg.norm(lights[0].position - truth[1].position) < 1e-3
    assert cost < 1e-8
    # without the held light the same start explains less of the room
    _, alone = p.levenberg_marquardt([_ceiling_light(4.3, 3.2)], iterations=60)
    assert alone > 100 * max(cost, 1e-12)


def test_a_luminaire_stays_in_its_allowed_region():
    truth = [_ceiling_light(2.6, 1.5)]
    p = _problem(truth)
    # only x <= 2.2 is allowed (e.g. the ceiling's edge): the fit presses against it
    p.inside = lambda L: L if L.position[0] <= 2.2 else None
    for opt in (p.levenberg_marquardt, p.evolution_strategy):
        lights, cost = opt([_ceiling_light(1.8, 1.3)])
        assert lights[0].position[0] <= 2.2
        assert lights[0].position[0] > 2.1                    # went as far as it may
        assert cost < p.cost([_ceiling_light(1.8, 1.3)])


def test_robust_cost_ignores_hot_spots_in_the_targets():
    truth = [_ceiling_light(2.5, 1.5), _ceiling_light(4.0, 2.8)]
    p = _problem(truth)
    rng = np.random.default_rng(5)
    hot = rng.choice(len(p.target), 15, replace=False)
    p.target[hot] *= 20.0                                    # reflections, sensor faults
    p.log_target = np.log(p.target + p.eps_lux)
    start = [_ceiling_light(2.7, 1.3), _ceiling_light(3.8, 3.0)]

    def worst_error():
        lights, _ = p.levenberg_marquardt(start, iterations=60)
        return max(np.linalg.norm(L.position - T.position) for L, T in
                   zip(sorted(lights, key=lambda L: L.position[0]), truth))

    robust = worst_error()
    p.robust_scale = 100.0                                   # ~ plain least squares
    quadratic = worst_error()
    assert robust < 0.02 and quadratic > 3 * robust


def _twelve_under_noise(h):
    """Twelve 1000 lm lights facing down at height ``h`` on a 4 x 3 grid 1.5 m apart, and
    the problem of their light under 5 % noise per point."""
    truth = [_ceiling_light(x, y, h) for x in (0.75, 2.25, 3.75, 5.25)
             for y in (0.67, 2.0, 3.33)]
    clean = _problem(truth, flux=1000.0)
    noisy = clean.target * (1 + 0.05 * np.random.default_rng(0).standard_normal(len(clean.target)))
    p = RefineProblem(positions=clean.positions, normals=clean.normals, target=noisy,
                      flux=1000.0, area=np.ones(len(noisy)), inside=lambda L: L)
    return truth, p


def test_greedy_selection_judges_a_luminaire_against_the_noise_not_the_empty_room():
    """Twelve 1000 lm ceiling lights 1.5 m apart at 4 m (0.4 x the mounting height), 5 %
    noise per point: the last one lowers the cost (the others refitted) by about a
    quarter, some 250 noise variances, but by only 0.1 % of the cost without any
    luminaire (the former floor was 0.5 % of it, and pruned it again). It is kept; a
    luminaire offered where the light is already explained (it could only fit the noise)
    is not."""
    truth, p = _twelve_under_noise(4.0)

    def light(x, y):
        return _ceiling_light(x, y, 4.0)
    rest = truth[:-1]
    gain = p.levenberg_marquardt(rest)[1] - p.levenberg_marquardt(truth)[1]
    assert gain < 0.005 * p.cost([])              # below the former floor
    assert gain > 0.2 * p.cost(truth)
    lights, cost, trace = greedy_select(p, [light(5.3, 3.29)], initial=rest)
    assert len(lights) == 12 and trace[0]["result"] == "kept"
    # (where they end is the noise's: 750 floor points do not pin lights 0.5 x the
    # mounting height apart; a refit from the truth moves them as far)
    assert cost < p.cost(truth)
    # nothing left to explain: a further luminaire between the others is not kept
    lights, cost, trace = greedy_select(p, [light(3.0, 1.3)], initial=truth)
    assert len(lights) == 12 and trace[0]["result"] == "rejected"


def test_with_free_fluxes_too_a_luminaire_is_judged_against_the_noise():
    """Twelve 1000 lm lights as above but 1.3 m over the floor, fluxes free (locate without
    --flux), 5 % noise: one of them lowers the cost (the others refitted, fluxes and all)
    by about 30 % of it but by under 0.2 % of the empty room's cost (the former free-flux
    floor, FREE_FLUX_MIN_GAIN_TOTAL, rejected it). Locate's selection keeps it now; a
    luminaire that could only fit the noise is still rejected. (At 4 m, eleven lights with
    free fluxes explain the noisy data as well as twelve: nothing to test there.)"""
    from types import SimpleNamespace
    from invrad_wb.core.inverse.locate_fit import _RoomFit

    truth, p = _twelve_under_noise(1.3)

    def light(x, y):
        return _ceiling_light(x, y, 1.3)
    p.free_flux = True
    # (2.25, 3.33) missing: refitted, the twelve end 0.08 % of the empty room's cost and
    # 30 % of their own below the eleven (measured with levenberg_marquardt)
    rest = truth[:5] + truth[6:]
    fit = _RoomFit(SimpleNamespace(problem=p), SimpleNamespace(optimiser="lm", min_gain=0.05,
                                                              aim="fixed"))
    lights, cost, trace = fit._greedy([light(2.3, 3.29)], initial=rest)
    assert len(lights) == 12 and trace[0]["result"] == "kept"
    lights, cost, trace = fit._greedy([light(3.0, 1.3)], initial=truth)
    assert len(lights) == 12 and trace[0]["result"] == "rejected"
