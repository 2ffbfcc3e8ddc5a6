"""The interreflection follows a luminaire's position in the last refit
(:attr:`~invrad_wb.core.inverse.refine.RefineProblem.indirect_gradient`): its Jacobian is
the full model's derivative (the interreflection recomputed where the luminaire moved to),
and the refit from the true arrangement ends at a lower cost of that full model than the
refit with each luminaire's interreflection held where it was last computed."""
import numpy as np
import pytest

from invrad_wb.core.synthetic import generate as g
from invrad_wb.core.model.luminaires import Luminaire
from invrad_wb.core.forward.render import render
from invrad_wb.core.inverse import locate_problem as lp
from invrad_wb.core.inverse import locate_vertices as lv
from invrad_wb.core.inverse.locate import LocateSettings
from invrad_wb.core.inverse.locate_fit import _rebase
from invrad_wb.core.inverse.locate_placement import _occluders, _snap_to_surfaces
from invrad_wb.core.inverse.refine import Light
from invrad_wb.core.inverse.votemaps import build_canvas

TRUE = [Luminaire([1.2, 1.0, 2.5], [0, 0, -1], 2000.0),
        Luminaire([2.9, 1.9, 2.5], [0, 0, -1], 3000.0)]


@pytest.fixture(scope="module")
def room():
    """A 4 x 3 x 2.5 m room at a 0.25 m mesh, targets with interreflection and 2 % noise
    per vertex: the last refit's problem on every vertex (fluxes free, the
    interreflection's gradient on) and a function luminaires -> their Lights."""
    scene = g.with_reflectances(g.box_room((4.0, 3.0, 2.5), cell=0.25))
    lux = render(scene, TRUE, interreflection=True)
    lux = lux * (1.0 + 0.02 * np.random.default_rng(3).standard_normal(len(lux)))
    scene = scene.with_vertex_lux(lux)
    pts = lp.vertex_points(scene)
    s = LocateSettings()
    canvas = build_canvas(scene, int(scene.rooms[0]), pixel=s.pixel_m, dummy=False)
    prob, ind = lp._refine_problem(scene, pts, canvas, _occluders(scene, s), s, 2000.0,
                                   "numpy", True, {"radiosity": 0.0})
    prob.free_flux = True
    prob.indirect_gradient = True

    def lights(lums):
        out = [_snap_to_surfaces([Light("free", np.asarray(t.position, float),
                                        np.array([0, 0, -1.0]), -1,
                                        flux_scale=t.flux_lm / 2000.0, free_flux=True)],
                                 canvas, scene)[0] for t in lums]
        return _rebase(prob, out)
    return scene, pts, prob, ind, lights


def _exact(prob, lights):
    """``lights`` with their interreflection computed exactly where they are."""
    out = []
    for L in lights:
        L = L.copy()
        L.indirect_at = None
        out.append(L)
    return prob.refresh_indirect(out, moved=0.0)[0]


def test_the_jacobian_is_the_full_models_derivative(room):
    # the ceiling gets interreflected light only: its residuals move with a luminaire
    # through that light alone, and the Jacobian has to say so
    scene, pts, prob, _ind, lights = room
    ls = lights(TRUE)
    assert ls[0].indirect_grad is not None and ls[0].indirect_grad.shape == (len(pts), 3)
    vis = [prob.visibility(L) for L in ls]
    _r, J = prob.residuals(ls, vis, with_jac=True)
    h = 0.01
    n = ls[0].n_params()
    ceiling = pts.positions[:, 2] > 2.49
    assert np.count_nonzero(ceiling) > 100
    for i in range(len(ls)):
        for j in range(2):                       # the two position parameters on the ceiling
            rs = []
            for sign in (1.0, -1.0):
                p = ls[i].params().copy()
                p[j] += sign * h
                moved = list(ls)
                moved[i] = ls[i].with_params(p)
                moved = _exact(prob, moved)
                rs.append(prob.residuals(moved, [prob.visibility(L) for L in moved])[0])
            fd = (rs[0] - rs[1]) / (2 * h)
            col = J[:, i * n + j]
            # on the ceiling the derivative is the interreflection's alone: not zero
            assert np.linalg.norm(fd[ceiling]) > 0.05
            np.testing.assert_allclose(col[ceiling], fd[ceiling], rtol=0.02,
                                       atol=0.02 * np.abs(fd[ceiling]).max())
            # everywhere: within a few per cent of the derivative's size
            assert np.linalg.norm(col - fd) < 0.03 * np.linalg.norm(fd)


def test_the_refit_ends_at_the_full_models_minimum(room):
    # refitted from the true arrangement on the noisy targets, each luminaire's
    # interreflection refreshed after each fit: with the gradient the answer fits the
    # data better (the interreflection recomputed exactly at both answers) than with the
    # interreflection held between refreshes, which stops where the direct light's
    # gradient alone vanishes; and the bound of the full model is the wider one
    scene, pts, prob, _ind, lights = room

    def refit(grad):
        prob.indirect_gradient = grad
        try:
            ls = lights(TRUE)
            for _ in range(6):
                ls, _c = prob.levenberg_marquardt(ls, iterations=100)
                ls, changed = prob.refresh_indirect(ls, moved=0.005)
                if not changed:
                    break
            return ls
        finally:
            prob.indirect_gradient = True
    held, follows = refit(False), refit(True)
    c_held, c_follows = prob.cost(_exact(prob, held)), prob.cost(_exact(prob, follows))
    # in noise variances (2 k x cost / sigma^2, sigma = 2 %): a gain, not rounding (0.5 to
    # 0.9 over six noise draws; twelve downlights in a 10 x 9 m room: 6 to 22)
    gain = 2 * len(pts) * (c_held - c_follows) / 0.02 ** 2
    assert gain > 0.3

    def full_gradient(ls, h=0.005):
        """d cost / d position parameters, the interreflection recomputed exactly."""
        out = []
        for i in range(len(ls)):
            for j in range(2):
                cs = []
                for sign in (1.0, -1.0):
                    p = ls[i].params().copy()
                    p[j] += sign * h
                    moved = list(ls)
                    moved[i] = ls[i].with_params(p)
                    cs.append(prob.cost(_exact(prob, moved)))
                out.append((cs[0] - cs[1]) / (2 * h))
        return np.array(out)
    # the answer with the gradient is where the full model's cost is stationary
    assert np.linalg.norm(full_gradient(follows)) < 0.2 * np.linalg.norm(full_gradient(held))


def test_the_streamed_refit_interpolates_the_gradient(room):
    # the VertexProblem on the subset's own points (interpolation the identity) has the
    # same Jacobian as the problem itself, gradient included
    scene, pts, prob, _ind, lights = room
    vp = lv.VertexProblem(pts, prob, pts.plane, chunk=397, identical=True)
    assert vp.indirect_gradient
    ls = lights(TRUE)
    _r, A, g_ = vp.normal_equations(ls, weights=False)
    vis = [prob.visibility(L) for L in ls]
    _r2, J = prob.residuals(ls, vis, with_jac=True)
    lit = prob.target > 0
    np.testing.assert_allclose(A, J[lit].T @ J[lit], rtol=1e-9, atol=1e-12)
    # a refresh in the streamed problem computes the gradient at the base points
    moved = [L.with_params(L.params() + np.r_[0.03, 0.0, 0.0]) for L in ls]
    got, changed = vp.refresh_indirect(moved, moved=0.005)
    assert changed and all(L.indirect_grad is not None for L in got)
    assert got[0].indirect_grad.shape == (len(prob.target), 3)
