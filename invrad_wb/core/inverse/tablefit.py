"""Fitting the deformed ellipses of the voting table (thesis 3.2.4), offline.

``tables/make_voting_table.py`` calls :func:`table_entries`; nothing here runs while
locating (the votes read the stored table, :mod:`invrad_wb.core.inverse.table`, and the
model in :mod:`invrad_wb.core.inverse.formfactor`, whose docstring fixes the geometry and the
ellipse parameters ``(a, b, d, x_m, y_m)``).

Pipeline of one fit: the maximum (closed form; :func:`maximum_newton` and
:func:`maximum_es` are the thesis' numerical searches, kept to compare),
:func:`~invrad_wb.core.inverse.formfactor.contour_samples` (binary search along ``k = 20``
rays from the maximum), :func:`start_params`, then :func:`fit_lm` (Levenberg-Marquardt on
eq. 3.30) or :func:`fit_es` ((1+1)-ES on eq. 3.30); :func:`fit_deformed_ellipse` does all of
it, and its ``"orthogonal"`` method adds :func:`fit_orthogonal` (geometric distance), which
the voting table stores. :func:`geometric_error` measures a fit against the true contour;
:func:`compare_methods` times the methods against each other. The optimisers are those of
:mod:`invrad_wb.core.inverse.optim`.

Array conventions: lengths in metres, levels ``e`` in lx/lm (1/m^2), angles in radians.
"""
import math
import time
from collections import namedtuple

import numpy as np

from invrad_wb.errors import SettingsError
from invrad_wb.core.inverse import optim
from invrad_wb.core.inverse.formfactor import (
    DEFAULT_SAMPLES, Maximum, _check_h, _g1, _g1_derivatives, _levels, contour_radius,
    contour_samples,
    ellipse_points, illuminance_per_lumen, maximum_closed_form, ray_angles, rotation_angle)

EllipseFit = namedtuple(
    "EllipseFit",
    "params samples x_max e_max rotation mse iterations evaluations method")
EllipseFit.__doc__ = """One batch of deformed-ellipse fits (see :func:`fit_deformed_ellipse`).

params : (..., 5) float64. ``(a, b, d, x_m, y_m)``; lengths in metres.
samples : (..., k, 2) float64, metres. The contour samples the fit used (plane coords).
x_max, e_max, rotation : (...) float64. The maximum (metres, lx/lm, rad).
mse : (...) float64. ``"lm"``/``"es"``: thesis eq. 3.30 at the solution (mean of squared
    eq. 3.24), m^4; ``"orthogonal"``: root mean squared distance of the samples, metres.
iterations, evaluations : (...) int. LM trial steps / ES generations, and residual
    evaluations.
method : str. ``"lm"``, ``"es"`` or ``"orthogonal"``.
"""


# --------------------------------------------------------------------------- maximum

def _unit_problems(h, alpha):
    """Flat cos/sin of the batch and its shape (the searches work at unit distance)."""
    h = _check_h(h)
    h, alpha = np.broadcast_arrays(h, np.asarray(alpha, dtype=np.float64))
    return h, alpha, np.cos(alpha).reshape(-1), np.sin(alpha).reshape(-1)


def _maximum_at(h, alpha, xy):
    """Maximum of the batch from unit-distance positions ``xy`` (N, 2) and a result."""
    xm = xy.x[:, 0].reshape(alpha.shape) * h
    e = illuminance_per_lumen(h, alpha, xm, xy.x[:, 1].reshape(alpha.shape) * h)
    return Maximum(xm, e, rotation_angle(h, alpha, xm), xy.iterations.reshape(alpha.shape),
                   xy.evaluations.reshape(alpha.shape))


def maximum_newton(h, alpha, tol=1e-13, max_iter=100):
    """Maximum by Newton's method with Levenberg-Marquardt damping and a line search.

    Thesis 3.1.2.1 / 3.2.4: :func:`invrad_wb.core.inverse.optim.newton` minimises ``-e``
    over the plane ``(x, y)`` from the foot point ``(0, 0)`` with the analytic gradient and
    Hessian. The objective is the unclipped ``h (x sin(alpha) - h cos(alpha)) / (pi r^4)``,
    which has the same maximiser as ``e`` but is not flat where the point cannot see the
    plane (for ``alpha < pi/2`` the foot point itself is such a place).

    Parameters
    ----------
    h : float or array, metres (> 0)
    alpha : float or array, rad, in (0, pi]
    tol : float
        Stop when the step is below ``tol * (1 + |x|/h)``.
    max_iter : int

    Returns
    -------
    Maximum
    """
    h, alpha, c, s = _unit_problems(h, alpha)

    def fun(xy):
        g, (gx, gy), (gxx, gxy, gyy) = _g1_derivatives(c, s, xy[:, 0], xy[:, 1])
        H = -np.stack([np.stack([gxx, gxy], -1), np.stack([gxy, gyy], -1)], -2)
        return -g, -np.stack([gx, gy], -1), H

    res = optim.newton(fun, np.zeros((len(c), 2)), lambda xy: -_g1(c, s, xy[:, 0], xy[:, 1]),
                       tol=tol, max_iter=max_iter)
    return _maximum_at(h, alpha, res)


def maximum_es(h, alpha, rng=None, sigma0=0.5, tol=1e-9, max_evals=20000, adapt_every=10):
    """Maximum by the (1+1) evolution strategy with the 1/5 success rule (thesis 3.1.2.2).

    :func:`invrad_wb.core.inverse.optim.evolution_strategy` from the foot point on the
    unclipped objective (see :func:`maximum_newton`), at unit distance (``sigma`` in units
    of ``h``), until ``sigma < tol (1 + |x|/h)``; the result is scaled by ``h``.

    Parameters
    ----------
    h : float or array, metres (> 0)
    alpha : float or array, rad
    rng : numpy.random.Generator or int seed, optional
    sigma0 : float
        Initial step size in units of ``h``.
    tol : float
    max_evals : int
    adapt_every : int

    Returns
    -------
    Maximum
    """
    h, alpha, c, s = _unit_problems(h, alpha)
    res = optim.evolution_strategy(lambda xy: -_g1(c, s, xy[:, 0], xy[:, 1]),
                                   np.zeros((len(c), 2)), sigma0, rng=rng,
                                   max_generations=max_evals, adapt_every=adapt_every,
                                   xtol=tol, relative=True)
    return _maximum_at(h, alpha, res)


# --------------------------------------------------------------------------- fits

def centred_samples(h, alpha, e, samples, k, x_max):
    """``k`` contour points along rays from the midpoint of the two minor-axis samples.

    ``samples`` are thesis samples (rays from the maximum, ``k0`` divisible by 2); their
    rays 0 and pi give the minor apices, whose midpoint lies inside the (convex) contour.
    Seen from there the points are spread far more evenly along the curve than seen from
    the maximum, which for low levels lies near one end. Used by :func:`fit_orthogonal`.

    Returns
    -------
    (S..., k, 2) float64, metres
    """
    k0 = samples.shape[-2]
    x0 = 0.5 * (samples[..., 0, 0] + samples[..., k0 // 2, 0])
    return contour_samples(h, alpha, e, k=k, x_max=x0)



def _resid_jac(p, X, Yd):
    """Residual (N, k) and Jacobian (N, k, 5) of the implicit residual, centred coordinates.

    ``X``: x relative to the maximum; ``Yd``: y. Parameters ``p`` (N, 5).
    """
    a, b, d, xm, ym = (p[:, i, None] for i in range(5))
    Xc = X - xm
    dy = Yd - ym
    Y = dy * dy / (a * a)
    w = 1.0 - 2.0 * Y
    u = Xc - b * d * w
    r = u * u - b * b * (1.0 - Y)
    dRdY = 4.0 * u * b * d + b * b
    J = np.empty(r.shape + (5,))
    J[..., 0] = dRdY * (-2.0 * Y / a)
    J[..., 1] = -2.0 * u * d * w - 2.0 * b * (1.0 - Y)
    J[..., 2] = -2.0 * u * b * w
    J[..., 3] = -2.0 * u
    J[..., 4] = dRdY * (-2.0 * dy / (a * a))
    return r, J


def _resid(p, X, Yd):
    a, b, d, xm, ym = (p[:, i, None] for i in range(5))
    Y = (Yd - ym) ** 2 / (a * a)
    u = X - xm - b * d * (1.0 - 2.0 * Y)
    return u * u - b * b * (1.0 - Y)


def _canonical(p):
    """Fold the sign symmetries of the implicit form: a > 0, b > 0."""
    p = p.copy()
    p[..., 0] = np.abs(p[..., 0])
    neg = p[..., 1] < 0
    p[..., 1] = np.where(neg, -p[..., 1], p[..., 1])
    p[..., 2] = np.where(neg, -p[..., 2], p[..., 2])
    return p


def start_params(samples, x_max):
    """Thesis starting values from contour samples taken with :func:`contour_samples`.

    ``b`` = half the distance between the two minor-axis samples (rays 0 and pi), ``a`` = the
    distance from the maximum to the major-axis sample (ray pi/2), ``d = 0``, centre at the
    maximum (``x_m = y_m = 0``). Needs ``k`` divisible by 4.

    Parameters
    ----------
    samples : (..., k, 2) array, metres
    x_max : (...) array, metres

    Returns
    -------
    (..., 5) float64
    """
    samples = np.asarray(samples, dtype=np.float64)
    k = samples.shape[-2]
    if k % 4:
        raise SettingsError(f"thesis starting values need k divisible by 4, got k={k}")
    xr = samples[..., 0] - np.asarray(x_max, np.float64)[..., None]
    b = 0.5 * (xr[..., 0] - xr[..., k // 2])
    a = samples[..., k // 4, 1]
    z = np.zeros_like(a)
    return np.stack([a, b, z, z, z], axis=-1)



def _normalised(samples, x_max, start):
    """Scale-free problem: samples relative to the maximum and lengths in units of the
    starting ``b``. Returns ``X, Y (N, k)``, start parameters ``(N, 5)`` and ``L (N, 1)``."""
    samples = np.asarray(samples, dtype=np.float64)
    L = np.abs(np.asarray(start, np.float64)[:, 1]).copy()
    L = np.where(L > 0, L, 1.0)[:, None]
    X = (samples[..., 0] - np.asarray(x_max, np.float64)[:, None]) / L
    Y = samples[..., 1] / L
    p = np.asarray(start, dtype=np.float64).copy()
    p[:, [0, 1, 3, 4]] /= L
    return X, Y, p, L


def _in_metres(p, L):
    p = _canonical(p)
    p[:, [0, 1, 3, 4]] *= L
    return p


def fit_lm(samples, x_max, start, max_iter=200, tol=1e-14):
    """Levenberg-Marquardt fit of the deformed ellipse to contour samples (batched).

    Minimises the thesis' mean squared implicit residual (eq. 3.30) over
    ``(a, b, d, x_m, y_m)`` with the analytic Jacobian of eq. 3.24 (the gradient of eq. 3.31)
    by :func:`invrad_wb.core.inverse.optim.levenberg_marquardt`. Coordinates are normalised
    by the starting ``b`` so that the problem is scale-free.

    Parameters
    ----------
    samples : (N, k, 2) array, metres
    x_max : (N,) array, metres
    start : (N, 5) array
    max_iter : int
    tol : float
        Stop a problem when its relative cost decrease or its step is below ``tol``.

    Returns
    -------
    params : (N, 5) float64; mse : (N,) float64, m^4; iterations : (N,) int;
    evaluations : (N,) int
    """
    X, Y, p, L = _normalised(samples, x_max, start)

    def fun(p, idx, jac):
        return _resid_jac(p, X[idx], Y[idx]) if jac else _resid(p, X[idx], Y[idx])

    res = optim.levenberg_marquardt(fun, p, max_iter=max_iter, ftol=tol, xtol=tol)
    return (_in_metres(res.x, L), res.cost / X.shape[1] * L[:, 0] ** 4, res.iterations,
            res.evaluations)


def fit_es(samples, x_max, start, rng=None, sigma0=0.05, tol=1e-9, max_evals=20000,
           adapt_every=10):
    """(1+1) evolution-strategy fit of the deformed ellipse (thesis 3.1.2.2, batched).

    Same objective and normalisation as :func:`fit_lm`;
    :func:`invrad_wb.core.inverse.optim.evolution_strategy` mutates all five parameters;
    it stops when ``sigma < tol`` or after ``max_evals`` generations.

    Returns
    -------
    params : (N, 5); mse : (N,), m^4; generations : (N,) int; evaluations : (N,) int
    """
    X, Y, p, L = _normalised(samples, x_max, start)
    res = optim.evolution_strategy(lambda q: optim.sum_of_squares(_resid(q, X, Y)), p,
                                   sigma0, rng=rng, max_generations=max_evals,
                                   adapt_every=adapt_every, xtol=tol)
    return (_in_metres(res.x, L), res.cost / X.shape[1] * L[:, 0] ** 4, res.iterations,
            res.evaluations)


def _orthogonal_residuals(X, Y):
    """Residuals ``(N, 2k)`` (x then y distances of the curve points ``P(t_i)`` from the
    samples) in the parameters ``(a, b, d, x_m, y_m, t_1..t_k)`` and their Jacobian as
    ``(J_x, J_y (N, k, 5), t_x, t_y (N, k))``: the derivatives of the x and y residuals by
    the five ellipse parameters and by each sample's own ``t_i`` (see :func:`_schur_step`)."""
    def fun(q, idx, jac):
        a, b, d, xm, ym = (q[:, i, None] for i in range(5))
        t = q[:, 5:]
        ct, st, c2 = np.cos(t), np.sin(t), np.cos(2.0 * t)
        r = np.concatenate([xm + b * (ct + d * c2) - X[idx], ym + a * st - Y[idx]], axis=1)
        if not jac:
            return r
        Jx = np.zeros(t.shape + (5,))
        Jy = np.zeros(t.shape + (5,))
        Jx[..., 1] = ct + d * c2
        Jx[..., 2] = b * c2
        Jx[..., 3] = 1.0
        Jy[..., 0] = st
        Jy[..., 4] = 1.0
        return r, (Jx, Jy, -b * (st + 2.0 * d * np.sin(2.0 * t)), a * ct)
    return fun


def _schur_step(J, r, lam):
    """Marquardt step of the orthogonal fit with the ``t_i`` eliminated: their block of the
    normal matrix is diagonal, so only a 5 x 5 Schur complement is solved per problem."""
    Jx, Jy, tx, ty = J
    k = tx.shape[1]
    rx, ry = r[:, :k], r[:, k:]
    A = np.einsum("nki,nkj->nij", Jx, Jx) + np.einsum("nki,nkj->nij", Jy, Jy)
    B = Jx * tx[..., None] + Jy * ty[..., None]
    gp = np.einsum("nki,nk->ni", Jx, rx) + np.einsum("nki,nk->ni", Jy, ry)
    gt = tx * rx + ty * ry
    Dl = (tx * tx + ty * ty) * (1.0 + lam[:, None]) + 1e-12
    eye = np.eye(5)
    Ad = A + (lam[:, None] * np.maximum(np.einsum("nii->ni", A), 1e-12))[:, :, None] * eye
    S = Ad - np.einsum("nki,nk,nkj->nij", B, 1.0 / Dl, B) + 1e-15 * eye
    dp = np.linalg.solve(S, -(gp - np.einsum("nki,nk->ni", B, gt / Dl))[..., None])[..., 0]
    dt = -(gt + np.einsum("nki,ni->nk", B, dp)) / Dl
    return np.concatenate([dp, dt], axis=1), np.ones(len(lam), bool)


def fit_orthogonal(samples, x_max, start, max_iter=100, tol=1e-12):
    """Orthogonal-distance (geometric) least-squares fit of the deformed ellipse, batched.

    Minimises ``sum_i |P(t_i) - s_i|^2`` over ``(a, b, d, x_m, y_m)`` and one curve
    parameter ``t_i`` per sample (orthogonal distance regression) by
    :func:`invrad_wb.core.inverse.optim.levenberg_marquardt` (5 + k parameters per problem;
    :func:`_schur_step` eliminates the ``t_i``).
    The implicit residual of the thesis weighs the samples unevenly (it is not a distance);
    this fit minimises the distances that matter when votes are drawn. Start from
    :func:`fit_lm`'s result; parameters as there.

    Returns
    -------
    params : (N, 5) float64; rms : (N,) float64, metres (root mean squared distance);
    iterations : (N,) int
    """
    X, Y, p, L = _normalised(samples, x_max, start)
    p = _canonical(p)
    # starting t_i: nearest point of the start curve, then the fit refines them
    tt = 2.0 * np.pi * np.arange(360) / 360
    cur = ellipse_points(p, tt)
    d2 = (cur[:, None, :, 0] - X[:, :, None]) ** 2 + (cur[:, None, :, 1] - Y[:, :, None]) ** 2
    q = np.concatenate([p, tt[np.argmin(d2, axis=-1)]], axis=1)
    res = optim.levenberg_marquardt(_orthogonal_residuals(X, Y), q, step=_schur_step,
                                    max_iter=max_iter, ftol=tol, xtol=1e3 * tol)
    return (_in_metres(res.x[:, :5], L), np.sqrt(res.cost / X.shape[1]) * L[:, 0],
            res.iterations)


def _refine(h, alpha, e, samples, x_max, p_lm, k_orth, n_check=128):
    """Orthogonal refinement of thesis fits; keep the geometrically better one (flat arrays).

    Returns params (N, 5), rms (N,), iterations (N,), geometric errors of the kept fit
    ``(mean, max, r_eq)`` and the largest geometric error of the thesis fit (N,).
    """
    cs = centred_samples(h, alpha, e, samples, k_orth, x_max)
    p_or, rms, it = fit_orthogonal(cs, x_max, p_lm)
    g_or = geometric_error(h, alpha, e, p_or, x_max, n=n_check)
    g_lm = geometric_error(h, alpha, e, p_lm, x_max, n=n_check)
    use_lm = g_lm[1] < g_or[1]
    p = np.where(use_lm[:, None], p_lm, p_or)
    g = (np.where(use_lm, g_lm[0], g_or[0]), np.where(use_lm, g_lm[1], g_or[1]), g_or[2])
    return p, rms, it, g, g_lm[1]


def fit_deformed_ellipse(h, alpha, e, method="lm", k=DEFAULT_SAMPLES, rng=None, start=None,
                         k_orth=32, **options):
    """Fit the deformed ellipse of the contour ``e`` (thesis 3.2.4), batched.

    Maximum (closed form), ``k`` contour samples by binary search along rays from it,
    thesis starting values (or ``start``), then the fit.

    Parameters
    ----------
    h, alpha, e : arrays broadcastable to a common shape ``S``
        metres (> 0), rad in (0, pi], lx/lm with ``0 < e < e_max``.
    method : {"lm", "es", "orthogonal"}
        ``"lm"``: :func:`fit_lm` (thesis objective, deterministic); ``"es"``: :func:`fit_es`
        (thesis objective, (1+1)-ES); ``"orthogonal"``: ``"lm"`` followed by
        :func:`fit_orthogonal` on ``k_orth`` :func:`centred_samples`, keeping whichever of
        the two has the smaller largest :func:`geometric_error` (what the voting table
        stores); its ``mse`` field is then the root mean squared distance (metres) of
        the orthogonal fit.
    k : int
        Number of thesis contour samples (divisible by 4).
    rng : numpy.random.Generator or int, optional (``"es"`` only)
    start : (S..., 5) array, optional
        Starting parameters (e.g. a warm start from a neighbouring level).
    **options
        Passed to the fitter (``max_iter``, ``tol``, ``sigma0``, ``max_evals`` ...).

    Returns
    -------
    EllipseFit
    """
    if method not in ("lm", "es", "orthogonal"):
        raise SettingsError(f"unknown fit method {method!r}; use 'lm', 'es' or 'orthogonal'")
    h = _check_h(h)
    h, alpha, e = np.broadcast_arrays(h, np.asarray(alpha, np.float64),
                                      np.asarray(e, np.float64))
    shape = h.shape
    if np.any(~((alpha > 0) & (alpha <= np.pi))):
        raise SettingsError("angle alpha between the normals must be in (0, pi]")
    mx = maximum_closed_form(h, alpha)
    if np.any(~(e > 0)) or np.any(~(e < mx.e)):
        raise SettingsError("contour level must satisfy 0 < e < e_max for every fit")
    smp = contour_samples(h, alpha, e, k=k, x_max=mx.x)
    sflat = smp.reshape(-1, k, 2)
    xflat = mx.x.reshape(-1)
    p0 = start_params(sflat, xflat) if start is None \
        else np.asarray(start, np.float64).reshape(-1, 5)
    if method == "es":
        p, err, it, nev = fit_es(sflat, xflat, p0, rng=rng, **options)
    else:
        p, err, it, nev = fit_lm(sflat, xflat, p0, **options)
    if method == "orthogonal":
        p, err, it2, _, _ = _refine(h.reshape(-1), alpha.reshape(-1), e.reshape(-1), sflat,
                                    xflat, p, k_orth)
        it = it + it2
        nev = nev + it2
    return EllipseFit(p.reshape(shape + (5,)), smp, mx.x, mx.e, mx.rotation,
                      err.reshape(shape), it.reshape(shape), nev.reshape(shape), method)


# --------------------------------------------------------------------------- accuracy

def geometric_error(h, alpha, e, params, x_max=None, n=128):
    """How far a fitted curve lies from the true contour ``e`` (first-order distance).

    ``n`` points of the fitted curve (equally spaced ``t``) are seen from the maximum; for
    each, the true contour point on the same ray is found by binary search. The radial gap
    ``|rho_fit - rho_true|`` is projected on the true contour's normal (the gradient of the
    distribution there), which is the distance to the contour to first order (rays from the
    maximum meet the contour obliquely near its ends). Both curves are star-shaped around the
    maximum (contours are convex), so this measures the whole curve. The error is relative
    to the contour's equivalent radius ``r_eq = sqrt(area / pi)``.

    Parameters
    ----------
    h, alpha, e : arrays broadcastable to ``S``; params : (S..., 5); x_max : (S...), optional
    n : int

    Returns
    -------
    mean_rel, max_rel : (S...) float64
        Mean and largest distance divided by ``r_eq``; ``inf`` where the maximum does not lie
        inside the fitted curve (a useless fit).
    r_eq : (S...) float64, metres
    """
    h, alpha, e, x_max = _levels(h, alpha, e, x_max)
    t = 2.0 * np.pi * (np.arange(n) + 0.5) / n
    pts = ellipse_points(params, t, x_max)
    dx = pts[..., 0] - x_max[..., None]
    dy = pts[..., 1]
    rho_f = np.hypot(dx, dy)
    th = np.arctan2(dy, dx)
    ex = (slice(None),) * h.ndim + (None,)
    rho_t = contour_radius(h[ex], alpha[ex], e[ex], x_max[ex], th)
    ct, st = np.cos(th), np.sin(th)
    # gradient of the (unit-distance) distribution at the true contour point
    X = (x_max[ex] + rho_t * ct) / h[ex]
    Y = rho_t * st / h[ex]
    _, (gx, gy), _ = _g1_derivatives(np.cos(alpha)[ex], np.sin(alpha)[ex], X, Y)
    cosn = np.abs(gx * ct + gy * st) / np.maximum(np.hypot(gx, gy), 1e-300)
    rho_u = contour_radius(h[ex], alpha[ex], e[ex], x_max[ex], ray_angles(n))
    r_eq = np.sqrt(np.mean(rho_u ** 2, axis=-1))
    dev = np.abs(rho_f - rho_t) * cosn / r_eq[..., None]
    # the maximum must be inside the fitted curve: winding number of the fitted points
    dth = np.diff(np.concatenate([th, th[..., :1]], axis=-1), axis=-1)
    dth = (dth + np.pi) % (2.0 * np.pi) - np.pi
    winding = np.abs(np.round(dth.sum(axis=-1) / (2.0 * np.pi)))
    bad = winding != 1
    mean_rel = np.where(bad, np.inf, dev.mean(axis=-1))
    max_rel = np.where(bad, np.inf, dev.max(axis=-1))
    return mean_rel, max_rel, r_eq


def table_entries(alpha, q, k=DEFAULT_SAMPLES, k_orth=32, start=None, n_check=128):
    """Voting-table entries at unit distance: maximum, thesis fit, orthogonal refinement.

    For each ``(alpha, q)`` (level ``e = q e_max``, ``0 < q < 1``): the closed-form maximum,
    ``k`` thesis contour samples (rays from the maximum), the thesis' LM fit of eq. 3.30 from
    the thesis' starting values (or ``start``), then :func:`fit_orthogonal` on ``k_orth``
    samples seen from the minor-axis midpoint (:func:`centred_samples`), and the geometric
    errors of both fits (:func:`geometric_error` with ``n_check`` points).

    Parameters
    ----------
    alpha, q : arrays broadcastable to ``S``
    start : (S..., 5) array, optional. Unit-distance starting parameters for the LM fit.

    Returns
    -------
    dict of arrays: ``params`` (S..., 5) (unit distance; the orthogonal fit, or the thesis
    fit where that has the smaller largest geometric error), ``params_lm`` (S..., 5) (thesis
    fit), ``err_max``/``err_mean`` (S...) of ``params``, ``err_max_lm``
    (S...), ``r_eq`` (S...), ``x_max``, ``e_max``, ``rotation`` (S...).
    """
    alpha, q = np.broadcast_arrays(np.asarray(alpha, np.float64), np.asarray(q, np.float64))
    shape = alpha.shape
    al = alpha.reshape(-1)
    mx = maximum_closed_form(1.0, al)
    e = q.reshape(-1) * mx.e
    smp = contour_samples(1.0, al, e, k=k, x_max=mx.x)
    p0 = start_params(smp, mx.x) if start is None else np.asarray(start, np.float64).reshape(-1, 5)
    p_lm, _, _, _ = fit_lm(smp, mx.x, p0)
    one = np.ones_like(al)
    p, _, _, g, g_lm_max = _refine(one, al, e, smp, mx.x, p_lm, k_orth, n_check)
    out = {"params": p, "params_lm": p_lm, "err_max": g[1], "err_mean": g[0],
           "err_max_lm": g_lm_max, "r_eq": g[2],
           "x_max": mx.x, "e_max": mx.e, "rotation": mx.rotation}
    return {key: val.reshape(shape + val.shape[1:]) for key, val in out.items()}


# --------------------------------------------------------------------------- comparison

def compare_methods(alphas_deg=(45.0, 90.0, 135.0, 180.0), qs=(0.9, 0.5, 0.1, 0.01), h=1.0,
                    k=DEFAULT_SAMPLES, seed=1):
    """Newton/LM versus the (1+1) evolution strategy, one problem at a time (thesis 3.2.4).

    For the maximum and for the ellipse fit at each ``(alpha, q = e / e_max)``: seconds per
    problem, accuracy (maximum: error against the closed form in units of ``h``; fit: eq.
    3.30 and :func:`geometric_error`).

    Returns
    -------
    list of dict, one per ``(alpha, q)``.
    """
    rng = np.random.default_rng(seed)
    rows = []
    for ad in alphas_deg:
        al = math.radians(ad)
        exact = maximum_closed_form(h, al)
        t0 = time.perf_counter()
        mn = maximum_newton(h, al)
        t_mn = time.perf_counter() - t0
        t0 = time.perf_counter()
        me = maximum_es(h, al, rng=rng)
        t_me = time.perf_counter() - t0
        for q in qs:
            e = q * float(exact.e)
            row = {"alpha_deg": ad, "q": q,
                   "max_newton_err": abs(float(mn.x - exact.x)) / h, "max_newton_s": t_mn,
                   "max_newton_iter": int(mn.iterations),
                   "max_es_err": abs(float(me.x - exact.x)) / h, "max_es_s": t_me,
                   "max_es_gen": int(me.iterations)}
            for method in ("lm", "es"):
                t0 = time.perf_counter()
                fit = fit_deformed_ellipse(h, al, e, method=method, k=k, rng=rng)
                dt = time.perf_counter() - t0
                gm, gx, _ = geometric_error(h, al, e, fit.params, fit.x_max)
                row.update({f"{method}_s": dt, f"{method}_mse": float(fit.mse),
                            f"{method}_geo_mean": float(gm), f"{method}_geo_max": float(gx),
                            f"{method}_iter": int(fit.iterations),
                            f"{method}_params": [float(v) for v in fit.params]})
            rows.append(row)
    return rows
