"""Form-factor distribution of one vote (formfactor.py): closed forms, contours, the ellipse
model; and the offline fits of the voting table (tablefit.py): maximum searches, ellipse fits."""
import math

import numpy as np
import pytest

from invrad_wb.core.inverse import formfactor as ff
from invrad_wb.core.inverse import tablefit as tf
from invrad_wb.errors import InvradError, SettingsError

ALPHAS_DEG = (5.0, 30.0, 60.0, 90.0, 120.0, 135.0, 170.0, 180.0)


def frame(alpha, seed=0):
    """A random 3D set-up: plane normal n, point normal m at angle alpha, frame w, v."""
    rng = np.random.default_rng(seed)
    n = rng.normal(size=3)
    n /= np.linalg.norm(n)
    w = np.cross(n, rng.normal(size=3))
    w /= np.linalg.norm(w)
    v = np.cross(n, w)
    m = math.cos(alpha) * n + math.sin(alpha) * w
    return n, m, w, v


def illuminance_3d(flux, c, n, s, m):
    """E at s (normal m) from a lambertian luminaire of flux at c facing n (the brief's form)."""
    d = s - c
    r = np.linalg.norm(d, axis=-1)
    cl = np.maximum(0.0, (d @ n) / r)
    cs = np.maximum(0.0, ((c - s) @ m) / r)
    return flux * cl * cs / (np.pi * r * r)


def rotate(vec, axis, angle):
    """Rodrigues rotation of vec about the unit axis (right-hand rule)."""
    return (vec * math.cos(angle) + np.cross(axis, vec) * math.sin(angle)
            + axis * (axis @ vec) * (1 - math.cos(angle)))


# --------------------------------------------------------------------------- distribution

@pytest.mark.parametrize("alpha_deg", [20.0, 90.0, 150.0, 180.0])
def test_illuminance_matches_3d_lambertian_formula(alpha_deg):
    alpha = math.radians(alpha_deg)
    n, m, w, v = frame(alpha, seed=int(alpha_deg))
    h, flux = 1.7, 1200.0
    s = np.array([0.3, -1.0, 2.0])
    foot = s - h * n
    rng = np.random.default_rng(1)
    xy = rng.uniform(-6, 6, size=(200, 2))
    c = foot + xy[:, :1] * w + xy[:, 1:] * v
    E = illuminance_3d(flux, c, n, s, m)
    e = ff.illuminance_per_lumen(h, alpha, xy[:, 0], xy[:, 1])
    np.testing.assert_allclose(flux * e, E, rtol=1e-12, atol=1e-15)
    assert (E > 0).any()


def test_scale_invariance_is_exact():
    rng = np.random.default_rng(2)
    alpha = rng.uniform(0.05, np.pi, 500)
    X, Y = rng.uniform(-4, 4, (2, 500))
    for h in (0.37, 3.2, 8.9):
        e_h = ff.illuminance_per_lumen(h, alpha, h * X, h * Y)
        e_1 = ff.illuminance_per_lumen(1.0, alpha, X, Y)
        np.testing.assert_allclose(e_h, e_1 / h ** 2, rtol=1e-13, atol=0)


def test_distribution_is_symmetric_and_dark_behind_the_horizon():
    alpha = math.radians(60)
    x = np.linspace(-3, 3, 61)
    np.testing.assert_array_equal(ff.illuminance_per_lumen(1.0, alpha, x, 0.7),
                                  ff.illuminance_per_lumen(1.0, alpha, x, -0.7))
    # the point's plane cuts the luminaire plane at x = h cot(alpha); beyond it: dark
    x_h = 1.0 / math.tan(alpha)
    assert np.all(ff.illuminance_per_lumen(1.0, alpha, x[x < x_h - 1e-9], 0.3) == 0)
    assert np.all(ff.illuminance_per_lumen(1.0, alpha, x[x > x_h + 1e-9], 0.3) > 0)


def test_bad_distance_is_refused():
    with pytest.raises(SettingsError):
        ff.illuminance_per_lumen(0.0, 1.0, 0.0, 0.0)
    with pytest.raises(InvradError):
        ff.maximum_closed_form(-1.0, 1.0)


# --------------------------------------------------------------------------- maximum

def grid_maximum(h, alpha):
    """Dense grid search with two zoom steps: (x, y, e)."""
    cx, cy, half = 0.0, 0.0, 100.0 * h if alpha < 0.2 else 6.0 * h
    for _ in range(4):
        xs = np.linspace(cx - half, cx + half, 401)
        ys = np.linspace(cy - half, cy + half, 401)
        X, Y = np.meshgrid(xs, ys, indexing="ij")
        E = ff.illuminance_per_lumen(h, alpha, X, Y)
        i, j = np.unravel_index(np.argmax(E), E.shape)
        cx, cy = xs[i], ys[j]
        half *= 0.02
    return cx, cy, E[i, j], 2.5 * half / 0.02 / 200


@pytest.mark.parametrize("alpha_deg", [3.0, 10.0, 45.0, 90.0, 135.0, 170.0])
@pytest.mark.parametrize("h", [0.5, 2.0])
def test_maximum_methods_agree_with_grid_search(alpha_deg, h):
    alpha = math.radians(alpha_deg)
    gx, gy, ge, res = grid_maximum(h, alpha)
    exact = ff.maximum_closed_form(h, alpha)
    newton = tf.maximum_newton(h, alpha)
    es = tf.maximum_es(h, alpha, rng=3)
    assert abs(gy) <= res
    for mx in (exact, newton, es):
        assert abs(float(mx.x) - gx) <= res + 1e-9 * h
        assert float(mx.e) >= ge * (1 - 1e-12)          # never below the best grid value
        assert float(mx.e) == pytest.approx(ge, rel=1e-6)
    assert float(newton.x) == pytest.approx(float(exact.x), rel=1e-9, abs=1e-12 * h)
    assert float(es.x) == pytest.approx(float(exact.x), rel=1e-6, abs=1e-6 * h)
    assert int(newton.iterations) < 50


def test_maximum_at_normal_incidence_is_the_foot_point():
    for h in (0.37, 1.0, 8.9):
        for mx in (ff.maximum_closed_form(h, np.pi), tf.maximum_newton(h, np.pi),
                   tf.maximum_es(h, np.pi, rng=0)):
            assert abs(float(mx.x)) < 1e-6 * h
            assert float(mx.e) == pytest.approx(1.0 / (np.pi * h * h), rel=1e-12)
            assert abs(float(mx.rotation)) < 1e-6


def test_maximum_closed_form_is_stationary_and_vectorised():
    alpha = np.radians(np.arange(1, 181))
    mx = ff.maximum_closed_form(1.0, alpha)
    dx = 1e-6 * (1 + mx.x)
    up = ff.illuminance_per_lumen(1.0, alpha, mx.x + dx, 0.0)
    dn = ff.illuminance_per_lumen(1.0, alpha, mx.x - dx, 0.0)
    assert np.all(mx.e >= up) and np.all(mx.e >= dn)
    # 3 s x^2 - 4 c x - s = 0
    resid = 3 * np.sin(alpha) * mx.x ** 2 - 4 * np.cos(alpha) * mx.x - np.sin(alpha)
    assert np.abs(resid / (1 + mx.x ** 2)).max() < 1e-12
    newton = tf.maximum_newton(1.0, alpha)
    np.testing.assert_allclose(newton.x, mx.x, rtol=1e-9, atol=1e-12)
    # the wall-to-ceiling case: x_max = h / sqrt(3), rotation 60 degrees
    wall = ff.maximum_closed_form(2.0, np.pi / 2)
    assert float(wall.x) == pytest.approx(2.0 / math.sqrt(3), rel=1e-14)
    assert float(wall.rotation) == pytest.approx(math.pi / 3, rel=1e-14)


@pytest.mark.parametrize("alpha_deg", [10.0, 60.0, 90.0, 135.0])
def test_rotation_angle_turns_the_normal_towards_the_maximum(alpha_deg):
    alpha = math.radians(alpha_deg)
    n, m, w, v = frame(alpha, seed=5)
    h = 2.3
    s = np.array([1.0, 2.0, 3.0])
    mx = ff.maximum_closed_form(h, alpha)
    target = s - h * n + float(mx.x) * w
    # the thesis' major axis n x m is our y axis v
    major = np.cross(n, m)
    np.testing.assert_allclose(major / np.linalg.norm(major), v, atol=1e-12)
    # the thesis' minor axis (its listing 4.5): major x n = w
    np.testing.assert_allclose(np.cross(v, n), w, atol=1e-12)
    direction = rotate(m, v, float(mx.rotation))
    # intersect the ray s + t direction with the plane n.(p - foot) = 0
    t = -h / (direction @ n)
    np.testing.assert_allclose(s + t * direction, target, atol=1e-9)
    assert 0 <= float(mx.rotation) < math.pi / 2


# --------------------------------------------------------------------------- contours

def circle_radius(h, q):
    """alpha = pi: e = cos^4(theta) / (pi h^2) = q e_max -> rho = h sqrt(q^-1/2 - 1)."""
    return h * np.sqrt(q ** -0.5 - 1.0)


@pytest.mark.parametrize("h", [0.37, 3.2, 8.9])
def test_contour_at_normal_incidence_is_the_closed_form_circle(h):
    q = np.array([0.95, 0.5, 0.1, 1e-3])
    e = q / (np.pi * h * h)
    smp = ff.contour_samples(h, np.pi, e, k=20)
    rho = np.hypot(smp[..., 0], smp[..., 1])
    np.testing.assert_allclose(rho, np.broadcast_to(circle_radius(h, q)[:, None], rho.shape),
                               rtol=1e-12)


@pytest.mark.parametrize("alpha_deg", ALPHAS_DEG)
def test_contour_samples_lie_on_the_level(alpha_deg):
    alpha = math.radians(alpha_deg)
    h = 1.3
    mx = ff.maximum_closed_form(h, alpha)
    for q in (0.99, 0.5, 0.01, 1e-4):
        e = q * float(mx.e)
        smp = ff.contour_samples(h, alpha, e, k=20)
        level = ff.illuminance_per_lumen(h, alpha, smp[:, 0], smp[:, 1])
        np.testing.assert_allclose(level, e, rtol=1e-9)
        # the explicit form of the contour (module docstring)
        x = smp[:, 0]
        y2 = np.sqrt(h * (x * math.sin(alpha) - h * math.cos(alpha)) / (np.pi * e)) - h * h - x * x
        np.testing.assert_allclose(y2, smp[:, 1] ** 2, rtol=0, atol=1e-7 * float(np.max(y2)))
        # symmetric about the minor axis: ray j and ray k - j mirror each other
        np.testing.assert_allclose(smp[1:, 0], smp[:0:-1, 0], rtol=1e-12, atol=1e-12 * h)


# --------------------------------------------------------------------------- ellipse model

def expanded_3_24(p, x, y):
    """Thesis eq. 3.24 as printed (centre (x_m, y_m) absolute)."""
    a, b, d, xm, ym = p
    X, Y = x - xm, y - ym
    return (X ** 2 - 2 * X * b * d + 4 * X * b * d * Y ** 2 / a ** 2
            + (b ** 2 - 4 * b ** 2 * d ** 2) * Y ** 2 / a ** 2
            + 4 * b ** 2 * d ** 2 * Y ** 4 / a ** 4 - b ** 2 + b ** 2 * d ** 2)


def test_implicit_residual_is_eq_3_24_and_vanishes_on_the_curve():
    rng = np.random.default_rng(4)
    for _ in range(20):
        p = np.array([rng.uniform(0.5, 3), rng.uniform(0.5, 3), rng.uniform(-0.2, 0.2),
                      rng.uniform(-1, 1), rng.uniform(-1, 1)])
        x, y = rng.uniform(-4, 4, (2, 50))
        np.testing.assert_allclose(ff.implicit_residual(p, x, y), expanded_3_24(p, x, y),
                                   rtol=1e-10, atol=1e-10)
        t = np.linspace(0, 2 * np.pi, 37)
        pts = ff.ellipse_points(p, t, x_max=0.7)
        r = ff.implicit_residual(p, pts[:, 0], pts[:, 1], x_max=0.7)
        assert np.abs(r).max() < 1e-12 * p[1] ** 2 * 100
        assert ff.mse(p, pts, x_max=0.7) < 1e-26


def test_ellipse_points_apices():
    p = np.array([2.0, 1.0, 0.1, 0.5, 0.0])
    pts = ff.ellipse_points(p, np.array([0, np.pi / 2, np.pi]), x_max=1.0)
    # minor apices at x_max + x_m + b d +- b; major apex at y = a
    np.testing.assert_allclose(pts[0], [1.0 + 0.5 + 0.1 + 1.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(pts[2], [1.0 + 0.5 + 0.1 - 1.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(pts[1], [1.0 + 0.5 - 0.1, 2.0], atol=1e-15)


def test_jacobian_of_the_implicit_residual():
    rng = np.random.default_rng(6)
    p = np.array([[1.3, 0.9, 0.12, 0.2, 0.05]])
    X, Y = rng.uniform(-2, 2, (2, 1, 15))
    r, J = tf._resid_jac(p, X, Y)
    for i in range(5):
        dp = np.zeros_like(p)
        dp[0, i] = 1e-6
        num = (tf._resid(p + dp, X, Y) - tf._resid(p - dp, X, Y)) / 2e-6
        np.testing.assert_allclose(J[..., i], num, rtol=1e-6, atol=1e-8)
    np.testing.assert_allclose(r, tf._resid(p, X, Y), rtol=1e-14)


# --------------------------------------------------------------------------- fits

@pytest.mark.parametrize("h", [0.37, 3.2, 8.9])
def test_fit_at_normal_incidence_is_the_circle(h):
    q = np.array([0.9, 0.3, 0.01])
    e = q / (np.pi * h * h)
    rho = circle_radius(h, q)
    for method in ("lm", "orthogonal"):
        fit = tf.fit_deformed_ellipse(h, np.pi, e, method=method)
        np.testing.assert_allclose(fit.params[:, 0], rho, rtol=1e-8)
        np.testing.assert_allclose(fit.params[:, 1], rho, rtol=1e-8)
        assert np.abs(fit.params[:, 2:]).max() < 1e-8 * h
    fit = tf.fit_deformed_ellipse(h, np.pi, e, method="es", rng=1)
    np.testing.assert_allclose(fit.params[:, :2], np.stack([rho, rho], 1), rtol=1e-5)


@pytest.mark.parametrize("alpha", [np.pi / 2, 3 * np.pi / 4, np.pi])
@pytest.mark.parametrize("method", ["lm", "orthogonal", "es"])
def test_fitted_ellipse_points_lie_near_the_level(alpha, method):
    h = 2.5
    mx = ff.maximum_closed_form(h, alpha)
    q = np.array([0.8, 0.6, 0.4])
    e = q * float(mx.e)
    fit = tf.fit_deformed_ellipse(h, alpha, e, method=method, rng=2)
    t = np.linspace(0, 2 * np.pi, 90, endpoint=False)
    pts = ff.ellipse_points(fit.params, t, fit.x_max)
    level = ff.illuminance_per_lumen(h, alpha, pts[..., 0], pts[..., 1])
    rel = np.abs(level / e[:, None] - 1)
    assert rel.max() < 0.05
    gmean, gmax, r_eq = tf.geometric_error(h, alpha, e, fit.params, fit.x_max)
    assert np.all(gmax < 0.01)
    assert np.all(np.abs(fit.params[:, 4]) < (1e-3 if method == "es" else 1e-9) * r_eq)


@pytest.mark.parametrize("alpha_deg", [1.0, 20.0, 45.0, 90.0, 120.0, 160.0])
def test_orthogonal_fit_accuracy_over_the_levels(alpha_deg):
    """Geometric accuracy of the table's fit; the deformed ellipse is only a model."""
    alpha = math.radians(alpha_deg)
    q = np.array([0.999, 0.9, 0.5, 0.1, 0.01, 1e-3, 1e-4])
    e = q * float(ff.maximum_closed_form(1.0, alpha).e)
    thesis = tf.fit_deformed_ellipse(1.0, alpha, e, method="lm")
    orth = tf.fit_deformed_ellipse(1.0, alpha, e, method="orthogonal")
    _, g_th, _ = tf.geometric_error(1.0, alpha, e, thesis.params, thesis.x_max)
    gmean, g_or, _ = tf.geometric_error(1.0, alpha, e, orth.params, orth.x_max)
    assert np.all(g_or < 0.035) and np.all(gmean < 0.015)
    assert np.all(g_th < 0.06)
    assert np.all(g_or <= g_th * 1.15 + 1e-6)
    assert np.all(np.diff(orth.params[:, 1]) > 0)   # contours grow as the level drops


def test_lm_and_es_reach_the_same_fit():
    alpha, h = math.radians(100), 1.0
    e = 0.2 * float(ff.maximum_closed_form(h, alpha).e)
    lm = tf.fit_deformed_ellipse(h, alpha, e, method="lm")
    es = tf.fit_deformed_ellipse(h, alpha, e, method="es", rng=7)
    assert float(es.mse) <= float(lm.mse) * 1.01
    np.testing.assert_allclose(es.params[:4], lm.params[:4], rtol=0, atol=2e-3 * lm.params[1])
    assert int(lm.iterations) < int(es.iterations)


@pytest.mark.parametrize("alpha_deg", [30.0, 90.0, 135.0])
def test_fresh_fits_scale_with_distance(alpha_deg):
    alpha = math.radians(alpha_deg)
    q = np.array([0.7, 0.1, 0.003])
    e1 = q * float(ff.maximum_closed_form(1.0, alpha).e)
    ref = tf.fit_deformed_ellipse(1.0, alpha, e1, method="orthogonal")
    for h in (0.37, 3.2, 8.9):
        fit = tf.fit_deformed_ellipse(h, alpha, e1 / h ** 2, method="orthogonal")
        scaled = ref.params.copy()
        scaled[:, [0, 1, 3, 4]] *= h
        np.testing.assert_allclose(fit.params[:, [0, 1, 3]], scaled[:, [0, 1, 3]],
                                   rtol=1e-6, atol=1e-9 * h)
        np.testing.assert_allclose(fit.params[:, 2], scaled[:, 2], atol=1e-7)
        np.testing.assert_allclose(fit.x_max, ref.x_max * h, rtol=1e-13)
        np.testing.assert_allclose(fit.rotation, ref.rotation, rtol=1e-13)


def test_geometric_error_sees_a_wrong_ellipse():
    h, q = 1.0, 0.25
    e = q / np.pi
    rho = float(circle_radius(h, q))
    good = np.array([rho, rho, 0, 0, 0])
    mean0, max0, r_eq = tf.geometric_error(h, np.pi, e, good, 0.0)
    assert max0 < 1e-10 and float(r_eq) == pytest.approx(rho, rel=1e-10)
    wide = np.array([rho, 1.1 * rho, 0, 0, 0])
    _, max1, _ = tf.geometric_error(h, np.pi, e, wide, 0.0)
    assert float(max1) == pytest.approx(0.1, rel=0.02)
    away = np.array([0.1 * rho, 0.1 * rho, 0, 3 * rho, 0])  # does not enclose the maximum
    _, max2, _ = tf.geometric_error(h, np.pi, e, away, 0.0)
    assert np.isinf(max2)


def test_fit_refuses_levels_without_a_contour():
    mx = ff.maximum_closed_form(1.0, 1.0)
    with pytest.raises(SettingsError):
        tf.fit_deformed_ellipse(1.0, 1.0, 1.01 * float(mx.e))
    with pytest.raises(SettingsError):
        tf.fit_deformed_ellipse(1.0, 1.0, 0.0)
    with pytest.raises(SettingsError):
        tf.fit_deformed_ellipse(1.0, 0.0, 1e-3)
    with pytest.raises(SettingsError):
        tf.fit_deformed_ellipse(1.0, 1.0, 0.5 * float(mx.e), k=18)
    with pytest.raises(SettingsError):
        tf.fit_deformed_ellipse(1.0, 1.0, 0.5 * float(mx.e), method="simplex")


def test_compare_methods_reports_both():
    rows = tf.compare_methods(alphas_deg=(90.0,), qs=(0.5,), seed=3)
    (row,) = rows
    assert row["max_newton_err"] < 1e-9 and row["max_es_err"] < 1e-6
    assert row["es_mse"] <= row["lm_mse"] * 1.01
    assert row["lm_geo_max"] < 0.01 and row["es_geo_max"] < 0.01


def test_orthogonal_schur_step_is_the_dense_marquardt_step():
    """Eliminating the per-sample curve parameters changes nothing but the cost of a step."""
    from invrad_wb.core.inverse import optim
    rng = np.random.default_rng(8)
    k = 12
    X, Y = rng.uniform(-1, 1, (2, 3, k))
    q = np.concatenate([rng.uniform(0.5, 1.5, (3, 2)), rng.uniform(-0.1, 0.1, (3, 3)),
                        rng.uniform(0, 2 * np.pi, (3, k))], axis=1)
    r, (Jx, Jy, tx, ty) = tf._orthogonal_residuals(X, Y)(q, np.arange(3), True)
    J = np.zeros((3, 2 * k, 5 + k))
    J[:, :k, :5], J[:, k:, :5] = Jx, Jy
    J[:, np.arange(k), 5 + np.arange(k)] = tx
    J[:, k + np.arange(k), 5 + np.arange(k)] = ty
    r2 = tf._orthogonal_residuals(X, Y)(q + 1e-7 * J[:, 0, :], np.arange(3), False)
    lam = np.array([1e-3, 0.1, 10.0])
    schur, _ = tf._schur_step((Jx, Jy, tx, ty), r, lam)
    dense, _ = optim.dense_step(J, r, lam, ridge=0.0)
    np.testing.assert_allclose(schur, dense, rtol=1e-6, atol=1e-9)
    # and the Jacobian is the residuals' derivative
    np.testing.assert_allclose((r2 - r) / 1e-7, np.einsum("nmi,ni->nm", J, J[:, 0, :]),
                               rtol=1e-4, atol=1e-6)
