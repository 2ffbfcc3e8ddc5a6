"""The last refit on every target vertex, streamed in chunks (:mod:`invrad_wb.core.inverse.
locate_vertices`): the chunked refit is the unchunked one, no target vertex is left out,
the interpolated interreflection is the exact gather within a stated tolerance."""
import numpy as np
import pytest

from invrad_wb.core.synthetic import generate as g
from invrad_wb.core.model.luminaires import Luminaire
from invrad_wb.core.forward.render import render
from invrad_wb.core.inverse import locate_problem as lp
from invrad_wb.core.inverse import locate_vertices as lv
from invrad_wb.core.inverse.locate import LocateSettings, locate
from invrad_wb.core.inverse.locate_fit import _rebase
from invrad_wb.core.inverse.locate_placement import _occluders, _snap_to_surfaces
from invrad_wb.core.inverse.refine import Light
from invrad_wb.core.inverse.votemaps import build_canvas

TRUE = [Luminaire([1.2, 1.0, 2.5], [0, 0, -1], 2000.0),
        Luminaire([2.9, 1.9, 2.5], [0, 0, -1], 3000.0)]


def _scene(cell, noise=0.05):
    scene = g.with_reflectances(g.box_room((4.0, 3.0, 2.5), cell=cell))
    lux = render(scene, TRUE, interreflection=True)
    lux = lux * (1.0 + noise * np.random.default_rng(0).standard_normal(len(lux)))
    return scene.with_vertex_lux(lux)


def _problem(scene, pts, free):
    """The last refit's problem on ``pts`` (exact interreflection there), its radiosity
    gather and a function luminaires -> their Lights on it."""
    s = LocateSettings()
    canvas = build_canvas(scene, int(scene.rooms[0]), pixel=s.pixel_m, dummy=False)
    prob, ind = lp._refine_problem(scene, pts, canvas, _occluders(scene, s), s, 2000.0,
                                   "numpy", True, {"radiosity": 0.0})
    prob.free_flux = free

    def lights(lums):
        out = [_snap_to_surfaces([Light("free", np.asarray(t.position, float),
                                        np.array([0, 0, -1.0]), -1,
                                        flux_scale=t.flux_lm / 2000.0, free_flux=free)],
                                 canvas, scene)[0] for t in lums]
        return _rebase(prob, out)
    return prob, ind, lights


def _moved(dx):
    return [Luminaire(np.asarray(t.position) + np.array(dx), [0, 0, -1], 1.1 * t.flux_lm)
            for t in TRUE]


@pytest.fixture(scope="module")
def room():
    """A small room at a 0.25 m mesh (1102 target vertices), 5 % noise: its vertices and
    the last refit's problem on every one of them."""
    scene = _scene(0.25)
    pts = lp.vertex_points(scene)
    prob, _ind, lights = _problem(scene, pts, True)
    return scene, pts, prob, lights


@pytest.mark.parametrize("free", [True, False])
def test_the_chunked_refit_is_the_unchunked_one(room, free):
    # every vertex of a small room in chunks of 97 (the last one shorter): the same
    # cost, steps and answer as RefineProblem's own refit on the same points
    scene, pts, prob, lights = room
    prob.free_flux = free
    vp = lv.VertexProblem(pts, prob, pts.plane, chunk=97, identical=True)
    assert len(vp.chunks) == -(-len(pts) // 97) and len(vp) == len(pts)
    start = lights(_moved([0.1, -0.07, 0.0]))
    assert vp.cost(start) == pytest.approx(prob.cost(start), rel=1e-12)
    a, ca = prob.levenberg_marquardt(start, iterations=100)
    b, cb = vp.levenberg_marquardt(start, iterations=100)
    assert cb == pytest.approx(ca, rel=1e-9)
    assert ca < 0.95 * prob.cost(start)                     # it did refit
    for x, y in zip(a, b):
        np.testing.assert_allclose(y.position, x.position, rtol=1e-9, atol=1e-9)
        assert y.flux_scale == pytest.approx(x.flux_scale, rel=1e-9)
    # the bound from the chunked Fisher information is fitcheck's
    from invrad_wb.core.inverse.fitcheck import position_sd
    sd, fsd = position_sd(prob, a, sigma=0.05)
    sd2, fsd2 = lv.position_sd(vp, a, sigma=0.05)
    np.testing.assert_allclose(sd2, sd, rtol=1e-9)
    if free:
        np.testing.assert_allclose(fsd2, fsd, rtol=1e-9)
    prob.free_flux = True


def test_the_interpolation_is_exact_for_light_linear_along_each_plane():
    scene = g.box_room((4.0, 3.0, 2.5), cell=0.25)
    scene = scene.with_vertex_lux(np.ones(len(scene.vertices)))
    pts = lp.vertex_points(scene)
    sub = lp.vertex_points(scene, most=400)
    it = lv.IndirectInterpolator(sub.positions, sub.plane, pts.positions, pts.plane)
    f = lambda p, pl: 3.0 + p @ np.array([0.5, -1.25, 2.0]) + 0.1 * pl   # noqa: E731
    np.testing.assert_allclose(it.apply(f(sub.positions, sub.plane)),
                               f(pts.positions, pts.plane), rtol=1e-5)
    # at the subset's own points, any values come back as they are
    v = np.random.default_rng(1).random(len(sub))
    key = {(tuple(p), pl): i for i, (p, pl) in enumerate(zip(sub.positions, sub.plane))}
    at = [(j, key[tuple(p), pl]) for j, (p, pl) in enumerate(zip(pts.positions, pts.plane))
          if (tuple(p), pl) in key]
    assert len(at) == len(sub)
    j, i = np.array(at).T
    np.testing.assert_allclose(it.apply(v)[j], v[i], rtol=1e-6)


def test_the_interpolated_interreflection_is_the_exact_gather(room):
    # luminaires 3.6 cm from where their interreflection was gathered at every vertex,
    # their value at a quarter of the vertices (0.5 m apart): the streamed problem's
    # interreflection (the exact gather at the start + the change interpolated from the
    # quarter) against the exact gather at every vertex where they are now. Measured:
    # 0.25 % RMS, 2.9 % at worst (a vertex on the ceiling's edge, where the gather's
    # value itself jumps); interpolating the value itself: 7.7 % RMS, 93 % at worst.
    scene, pts, exact, lights_exact = room
    quarter = lp.vertex_points(scene, most=len(pts) // 4)
    sub, ind, lights_sub = _problem(scene, quarter, True)
    vp = lv.VertexProblem(pts, sub, quarter.plane, indirect_model=ind)
    start = lights_sub(TRUE)
    vp.exact_indirect(start)
    was = np.array([L.indirect for L in lights_exact(TRUE)])
    np.testing.assert_allclose(np.array([f for _c, f in vp._exact]).T, was.T, rtol=1e-5)
    now = lights_sub(_moved([0.03, -0.02, 0.0]))
    got = np.array([q.indirect for q in vp._at(now, slice(None))])
    want = np.array([L.indirect for L in lights_exact(_moved([0.03, -0.02, 0.0]))])
    rel = got / want - 1.0
    assert np.max(np.abs(want / was - 1.0)) > 0.01            # they did change
    assert np.sqrt(np.mean(rel ** 2)) < 0.005 and np.max(np.abs(rel)) < 0.05
    plain = lv.VertexProblem(pts, sub, quarter.plane)        # no exact gather
    rel_plain = np.array([q.indirect for q in plain._at(now, slice(None))]) / want - 1.0
    assert np.sqrt(np.mean(rel_plain ** 2)) > 10 * np.sqrt(np.mean(rel ** 2))


def test_locate_refits_on_every_target_vertex_beyond_the_subset(monkeypatch):
    # the subset of the count search and regroup capped at 800 vertices: the last refit
    # still uses every one of the room's target vertices
    scene = g.box_room((4.0, 3.0, 2.5), cell=0.2, reflectance=0.0)
    true = [Luminaire([1.7, 1.4, 2.5], [0, 0, -1], 3000.0)]
    lux = render(scene, true, interreflection=False)
    lux = lux * (1.0 + 0.05 * np.random.default_rng(3).standard_normal(len(lux)))
    scene = scene.with_vertex_lux(lux)
    monkeypatch.setattr(lp, "VERTEX_POINTS_MAX", 800)
    res = locate(scene, None, votes_per_m2=8, pixel_m=0.1, dummy_planes=False)
    trace = res.rooms[0].trace
    every = [e for e in trace if "polish_vertices" in e]
    assert [e["polish_points"] for e in trace if "polish_points" in e] == [800]
    assert every and every[0]["polish_vertices"] == len(lp.vertex_points(scene)) > 1000
    assert every[0]["cost_after"] <= every[0]["cost_before"]
    assert len(res.luminaires) == 1
    err = np.linalg.norm(np.asarray(res.luminaires[0].position) - true[0].position)
    assert err < 0.02 and res.luminaires[0].flux_lm == pytest.approx(3000.0, rel=0.03)


def _judged_on_every_vertex(room, got_lums, alt_lums, one_pass=False):
    """locate_fit._RoomFit.count_on_every_vertex of ``alt_lums`` (the count search's split
    that its subset turned down) against ``got_lums`` refitted on every vertex, the subset
    a quarter of the room's vertices. ``one_pass``: the split's interreflection gathered
    with ``got_lums``' (as polish_every_vertex does), else in a pass of its own."""
    from types import SimpleNamespace
    from invrad_wb.core.inverse.locate_fit import _RoomFit
    scene, pts, _exact, _lights = room
    quarter = lp.vertex_points(scene, most=len(pts) // 4)
    sub, ind, lights_sub = _problem(scene, quarter, True)
    sub.indirect_gradient = True
    vp = lv.VertexProblem(pts, sub, quarter.plane, indirect_model=ind)
    got = lights_sub(got_lums)
    alt = _rebase(sub, lights_sub(alt_lums))
    alt_exact = vp.exact_indirect(got, *([alt] if one_pass else []))
    got, _c = vp.levenberg_marquardt(got, iterations=100)
    fit = SimpleNamespace(trace=[], rejected_split=alt)
    if one_pass:
        out = _RoomFit.count_on_every_vertex(fit, vp, sub, got, 4, alt, alt_exact[0])
    else:
        out = _RoomFit.count_on_every_vertex(fit, vp, sub, got, 4)
    return out, fit.trace[-1]


def test_more_arrangements_gather_in_the_same_pass_as_one_alone(room):
    # exact_indirect(lights, alt): lights' values kept, alt's returned, each what a pass
    # of its own gathers; an arrangement without interreflection comes back as None
    scene, pts, _exact, _lights = room
    quarter = lp.vertex_points(scene, most=len(pts) // 4)
    sub, ind, lights_sub = _problem(scene, quarter, True)
    got, alt = lights_sub(TRUE), lights_sub(_moved([0.4, -0.3, 0.0]))
    vp = lv.VertexProblem(pts, sub, quarter.plane, indirect_model=ind)
    bare = [L.copy() for L in alt]
    for L in bare:
        L.indirect = None
    more = vp.exact_indirect(got, alt, bare)
    assert len(more) == 2 and more[1] is None and len(more[0]) == len(alt)
    both = [f for _c, f in vp._exact] + [f for _c, f in more[0]]
    alone = lv.VertexProblem(pts, sub, quarter.plane, indirect_model=ind)
    alone.exact_indirect(got)
    first = [f for _c, f in alone._exact]
    alone.exact_indirect(alt)
    want = first + [f for _c, f in alone._exact]
    for a, b in zip(both, want):
        np.testing.assert_allclose(a, b, rtol=1e-6, atol=1e-6 * float(np.max(b)))
    assert np.max(np.abs(want[0] - want[2])) > 0.01 * np.max(want[0])   # alt's differ
    vp.use_exact(more[0])
    np.testing.assert_allclose(vp._at(alt, slice(None))[0].indirect, want[2], rtol=1e-6)
    # nothing to gather: the kept values stay, nothing is returned for the others
    vp.exact_indirect(bare, alt)
    assert vp._exact is more[0]


def test_every_vertex_keeps_the_luminaire_the_subset_turned_down(room):
    # one luminaire of the pair's flux between them (what a subset's criterion may keep)
    # against the split it turned down: every vertex holds the second luminaire
    s = sum(t.flux_lm for t in TRUE)
    centre = sum(t.flux_lm * np.asarray(t.position) for t in TRUE) / s
    one = [Luminaire(centre, [0, 0, -1], s)]
    out, said = _judged_on_every_vertex(room, one, _moved([0.05, 0.04, 0.0]))
    assert said["count_search"] == "every vertex" and said["kept"]
    # the split gathered in the start's pass (polish_every_vertex's way): the same check
    out1, said1 = _judged_on_every_vertex(room, one, _moved([0.05, 0.04, 0.0]), True)
    assert said1["kept"] and len(out1) == len(out)
    for k in ("bic_before", "bic_after"):
        assert said1[k] == pytest.approx(said[k], rel=1e-6)
    for a, b in zip(out, out1):
        np.testing.assert_allclose(b.position, a.position, atol=1e-5)
    assert len(out) == 2
    for t in TRUE:
        near = min(out, key=lambda L: np.linalg.norm(L.position - t.position))
        assert np.linalg.norm(near.position - t.position) < 0.05
        assert near.flux_scale * 2000.0 == pytest.approx(t.flux_lm, rel=0.05)


def test_every_vertex_turns_down_a_split_the_data_do_not_need(room):
    # the true pair against a split of its brighter luminaire into halves 0.3 m apart
    a, b = TRUE
    halves = [Luminaire(np.asarray(b.position) + [dx, 0.0, 0.0], [0, 0, -1], b.flux_lm / 2)
              for dx in (-0.15, 0.15)]
    for one_pass in (False, True):
        out, said = _judged_on_every_vertex(room, TRUE, [a] + halves, one_pass)
        assert said["count_search"] == "every vertex" and not said["kept"]
        assert said["bic_after"] > said["bic_before"]
        assert len(out) == 2
