"""How precisely noisy targets pin luminaires (:func:`invrad_wb.core.inverse.fitcheck.
position_sd`) and the last refit on every target vertex (:func:`invrad_wb.core.inverse.
locate_problem.vertex_points`, :meth:`_RoomFit.polish`)."""
import numpy as np
import pytest

from invrad_wb.core.synthetic import generate as g
from invrad_wb.core.model.luminaires import Luminaire
from invrad_wb.core.forward.render import render
from invrad_wb.core.inverse.fitcheck import position_sd
from invrad_wb.core.inverse.locate import locate
from invrad_wb.core.inverse.locate_problem import vertex_points
from invrad_wb.core.inverse.refine import Light, RefineProblem


def _floor_problem(target, flux=3000.0):
    x, y = np.meshgrid(np.linspace(0.1, 3.9, 20), np.linspace(0.1, 3.9, 20), indexing="ij")
    pts = np.c_[x.ravel(), y.ravel(), np.zeros(x.size)]
    nrm = np.tile([0, 0, 1.0], (len(pts), 1))
    return RefineProblem(positions=pts, normals=nrm, target=target, flux=flux,
                         area=np.ones(len(pts)), inside=lambda L: L, free_flux=True)


def _light():
    return Light("surface", np.array([2.0, 2.0, 2.5]), np.array([0, 0, -1.0]), 0,
                 origin=np.array([0.0, 0.0, 2.5]), u=np.array([1.0, 0, 0]),
                 v=np.array([0, 1.0, 0]))


def test_position_sd_is_the_spread_of_refits_under_noise():
    # one 3000 lm downlight 2.5 m over 400 floor points, its flux free, 5 % noise per
    # point: refitted from the truth for 40 noise draws, its positions scatter as the
    # bound says (the estimate is efficient here), and the noise is read off the residual
    exact = _floor_problem(np.ones(400))
    truth = _light()
    e, _ = exact.light_of(truth, np.ones(400, bool))
    sd, fsd = position_sd(_floor_problem(e), [truth], sigma=0.05)
    rng = np.random.default_rng(1)
    xs, fl, est = [], [], []
    for _ in range(40):
        prob = _floor_problem(e * (1.0 + 0.05 * rng.standard_normal(400)))
        got, _c = prob.levenberg_marquardt([truth], iterations=50)
        xs.append(got[0].position[:2])
        fl.append(np.log(got[0].flux_scale))
        est.append(position_sd(prob, got)[0][0])
    xs = np.array(xs)
    spread = float(np.sqrt(np.max(np.linalg.eigvalsh(np.cov(xs.T)))))
    assert 0.002 < sd[0] < 0.02        # millimetres, as 400 points of 5 % noise give
    assert spread == pytest.approx(sd[0], rel=0.35)
    assert float(np.std(fl)) == pytest.approx(fsd[0], rel=0.35)
    # the noise estimated from each fit's residual gives the same bound
    assert np.median(est) == pytest.approx(sd[0], rel=0.15)
    # twice the noise, twice the spread
    assert position_sd(_floor_problem(e), [truth], sigma=0.1)[0][0] == pytest.approx(2 * sd[0])


def test_vertex_points_are_every_target_vertex_once():
    scene = g.box_room((3.0, 2.0, 2.5), cell=0.5)
    lux = np.linspace(10.0, 200.0, len(scene.vertices))
    lux[::7] = np.nan                                   # some vertices without a target
    scene = scene.with_vertex_lux(lux)
    pts = vertex_points(scene)
    used = np.isfinite(lux)
    assert len(pts) == int(used.sum())
    # each point is its vertex with its target, on its face, facing into the room
    np.testing.assert_allclose(pts.lux, lux[used])
    np.testing.assert_allclose(pts.positions, scene.vertices[used])
    corners = scene.vertices[scene.faces[pts.face]]                     # (k, 3, 3)
    np.testing.assert_allclose(np.einsum("ij,ijk->ik", pts.bary, corners), pts.positions)
    np.testing.assert_allclose(pts.normals, scene.face_normals[pts.face])
    # the areas: a third of every face to each of its corners
    full = vertex_points(scene.with_vertex_lux(np.ones(len(scene.vertices))))
    assert full.area.sum() == pytest.approx(scene.face_areas.sum())
    # a finely meshed room: an even subset that stands for the same area
    few = vertex_points(scene.with_vertex_lux(np.ones(len(scene.vertices))), most=50)
    assert len(few) == 50 and few.area.sum() == pytest.approx(scene.face_areas.sum())
    # targets per face: no vertex points
    assert vertex_points(g.box_room((3.0, 2.0, 2.5), cell=0.5)) is None


def test_locate_ends_with_a_refit_on_every_target_vertex():
    # one 3000 lm downlight, 5 % noise per vertex, few voting points: the answer is refitted
    # on all target vertices and lies within three standard deviations of the bound there
    scene = g.box_room((4.0, 3.0, 2.5), cell=0.2, reflectance=0.0)
    true = [Luminaire([1.7, 1.4, 2.5], [0, 0, -1], 3000.0)]
    lux = render(scene, true, interreflection=False)
    lux = lux * (1.0 + 0.05 * np.random.default_rng(3).standard_normal(len(lux)))
    scene = scene.with_vertex_lux(lux)
    res = locate(scene, 3000.0, votes_per_m2=8, pixel_m=0.1, dummy_planes=False)
    run = res.rooms[0]
    polish = [e for e in run.trace if "polish_points" in e]
    assert polish and polish[0]["polish_points"] == len(vertex_points(scene))
    assert polish[0]["polish_points"] > 3 * len(run.points)
    assert len(res.luminaires) == 1
    err = np.linalg.norm(np.asarray(res.luminaires[0].position) - true[0].position)
    assert err < 0.01
