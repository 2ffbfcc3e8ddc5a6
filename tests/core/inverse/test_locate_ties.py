"""Luminaires of one kind (:mod:`invrad_wb.core.inverse.locate_ties`): with the flux
unknown, fluxes the data cannot tell apart share one parameter; different kinds stay
apart; the tied fit is the fit with the flux given, pinned as precisely."""
import numpy as np
import pytest

from invrad_wb.core.synthetic import generate as g
from invrad_wb.core.model.luminaires import Luminaire
from invrad_wb.core.forward.render import render
from invrad_wb.core.inverse import locate_problem as lp
from invrad_wb.core.inverse import locate_vertices as lv
from invrad_wb.core.inverse.locate import LocateSettings, locate
from invrad_wb.core.inverse.locate_count import _params
from invrad_wb.core.inverse.locate_fit import _rebase
from invrad_wb.core.inverse.locate_placement import _occluders, _snap_to_surfaces
from invrad_wb.core.inverse.locate_ties import flux_groups
from invrad_wb.core.inverse.refine import Light
from invrad_wb.core.inverse.tiedparams import flux_ties
from invrad_wb.core.inverse.votemaps import build_canvas

FOUR = [Luminaire([1.25 + 2.5 * i, 1.1 + 2.2 * j, 2.6], [0, 0, -1], 2500.0)
        for i in range(2) for j in range(2)]


def _scene(lums, size=(5.0, 4.4, 2.6), cell=0.2, seed=0):
    scene = g.with_reflectances(g.box_room(size, cell=cell))
    lux = render(scene, lums, interreflection=True)
    lux = lux * (1.0 + 0.05 * np.random.default_rng(seed).standard_normal(len(lux)))
    return scene.with_vertex_lux(lux)


def _problem(scene, free=True, flux=2500.0):
    s = LocateSettings()
    canvas = build_canvas(scene, int(scene.rooms[0]), pixel=s.pixel_m, dummy=False)
    prob, _ind = lp._refine_problem(scene, lp.vertex_points(scene), canvas,
                                    _occluders(scene, s), s, flux, "numpy", True,
                                    {"radiosity": 0.0})
    prob.free_flux = free

    def lights(lums, scale=1.0):
        out = [_snap_to_surfaces([Light("free", np.asarray(t.position, float),
                                        np.array([0, 0, -1.0]), -1,
                                        flux_scale=scale * t.flux_lm / flux,
                                        free_flux=free)], canvas, scene)[0]
               for t in lums]
        return _rebase(prob, out)
    return prob, lights


def test_groups_join_fluxes_within_their_noise_and_keep_kinds_apart():
    sd = 0.016
    cov = np.eye(6) * sd ** 2
    # two kinds, 2000 and 3500 lm, each three times, fitted within 1 sd
    theta = np.log([2000, 2030, 1975, 3500, 3460, 3550])
    groups = flux_groups(theta, cov, np.log(20000))
    assert sorted(sorted(x) for x in groups) == [[0, 1, 2], [3, 4, 5]]
    # far less precise fluxes (sd 60 %): the data cannot tell the kinds apart
    assert len(flux_groups(theta, cov * 1500, np.log(20000))) == 1
    # nothing to tie at a penalty of 0
    assert len(flux_groups(theta, cov, 0.0)) == 6


def test_a_shared_flux_is_one_parameter():
    ls = [Light("surface", np.zeros(3), np.array([0, 0, -1.0]), 0, free_flux=True,
                origin=np.zeros(3), u=np.eye(3)[0], v=np.eye(3)[1]) for _ in range(3)]
    assert _params(ls) == 9 and flux_ties(ls) is None
    ls[0].flux_group = ls[2].flux_group = 0
    assert _params(ls) == 8
    T = flux_ties(ls)
    assert T.shape == (9, 8)
    # the first and the third luminaires' log fluxes (their last parameters) share a column
    assert np.argmax(T[2]) == np.argmax(T[8]) != np.argmax(T[5])


@pytest.fixture(scope="module")
def four():
    scene = _scene(FOUR)
    prob, lights = _problem(scene)
    return scene, prob, lights


def test_a_tied_refit_keeps_one_flux_per_group_chunked_or_not(four):
    scene, prob, lights = four
    start = lights([Luminaire(np.asarray(t.position) + [0.08, -0.05, 0], [0, 0, -1],
                              t.flux_lm * f) for t, f in zip(FOUR, (1.1, 0.95, 1.0, 0.9))])
    for L in start[:3]:
        L.flux_group = 0
    a, ca = prob.levenberg_marquardt(start, iterations=100)
    assert ca < 0.9 * prob.cost(start)
    assert a[0].flux_scale == a[1].flux_scale == a[2].flux_scale != a[3].flux_scale
    # the streamed refit on the same points (chunks of 97): the same steps and answer
    pts = lp.vertex_points(scene)
    vp = lv.VertexProblem(pts, prob, pts.plane, chunk=97, identical=True)
    b, cb = vp.levenberg_marquardt(start, iterations=100)
    assert cb == pytest.approx(ca, rel=1e-9)
    for x, y in zip(a, b):
        np.testing.assert_allclose(y.position, x.position, atol=1e-9)
        assert y.flux_scale == pytest.approx(x.flux_scale, rel=1e-9)
    # the tie costs what the data allow: the shared flux is the mean of the free ones
    for L in start:
        L.flux_group = -1
    free, _c = prob.levenberg_marquardt(start, iterations=100)
    mean = np.exp(np.mean(np.log([L.flux_scale for L in free[:3]])))
    assert a[0].flux_scale == pytest.approx(mean, rel=0.02)


def test_tied_fluxes_pin_the_positions_as_the_flux_given_does(four):
    # the Cramer-Rao bound of the true four: fluxes free, tied (one kind), given
    from invrad_wb.core.inverse.fitcheck import sd_of
    _scene_, prob, lights = four
    true = prob._own_copies(lights(FOUR))
    vis = [prob.visibility(L) for L in true]
    _r, J = prob.residuals(true, vis, with_jac=True)
    F = J[prob.target > 0].T @ J[prob.target > 0]
    free = sd_of(np.linalg.pinv(F), true)[0].max()
    for L in true:
        L.flux_group = 0
    T = flux_ties(true)
    tied = sd_of(T @ np.linalg.pinv(T.T @ F @ T) @ T.T, true)[0].max()
    pos = [j for j in range(F.shape[0]) if (j + 1) % 3]       # 2 + 1 parameters each
    given = sd_of(np.linalg.pinv(F[np.ix_(pos, pos)]),
                  [Light(L.kind, L.position, L.normal, L.map_index, origin=L.origin, u=L.u,
                         v=L.v) for L in true])[0].max()
    assert tied < 0.8 * free
    assert tied == pytest.approx(given, rel=0.1)


@pytest.mark.parametrize("subset", [None, 800])
def test_locate_finds_four_of_one_kind_with_one_flux(monkeypatch, subset):
    # flux unknown: the four come back with one flux, within 1 % of theirs; with a subset
    # of 800 vertices the ties are judged on every vertex (the streamed last refit)
    kw = {}
    if subset:
        monkeypatch.setattr(lp, "VERTEX_POINTS_MAX", subset)
        kw = {"votes_per_m2": 6}                        # fewer voting points than that
    scene = _scene(FOUR, seed=1)
    res = locate(scene, None, **kw)
    trace = res.rooms[0].trace
    ties = [e for e in trace if "flux_ties" in e and e.get("kept")]
    assert ties and ties[-1]["flux_ties"] == [4]
    if subset:
        assert any("polish_vertices" in e for e in trace)
    assert len(res.luminaires) == 4
    assert len({L.flux_lm for L in res.luminaires}) == 1
    assert res.luminaires[0].flux_lm == pytest.approx(2500.0, rel=0.01)
    for t in FOUR:
        d = min(np.linalg.norm(np.asarray(L.position) - t.position) for L in res.luminaires)
        assert d < 0.06


def test_locate_keeps_two_kinds_apart():
    # 2000 and 3500 lm, two of each: two fluxes, each within 5 %
    lums = [Luminaire(t.position, [0, 0, -1], f) for t, f in
            zip(FOUR, (2000.0, 3500.0, 3500.0, 2000.0))]
    res = locate(_scene(lums, seed=2), None)
    assert len(res.luminaires) == 4
    assert len({L.flux_lm for L in res.luminaires}) == 2
    assert sorted({L.extra["flux_group"] for L in res.luminaires}) == [1, 2]   # as said
    for t in lums:
        near = min(res.luminaires, key=lambda L: np.linalg.norm(np.asarray(L.position)
                                                                - t.position))
        assert near.flux_lm == pytest.approx(t.flux_lm, rel=0.05)
        assert np.linalg.norm(np.asarray(near.position) - t.position) < 0.06
