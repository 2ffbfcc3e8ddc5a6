"""Form-factor distribution of one vote, its maximum, its contours and deformed-ellipse fits.

This is the math behind the voting table (thesis "Inverted Radiosity", 3.2.2-3.2.4, 4.1.1.2).
A voting point ``s`` with unit normal ``m`` sees a plane with unit normal ``n``; it asks
where on that plane a lambertian luminaire of flux ``F`` would have to sit to produce the
illuminance ``E`` observed at ``s``. All functions work *per lumen*: ``e = E / F``
(lx/lm = 1/m^2), the thesis' form factor (eq. 3.28) with ``A`` -> flux.

Geometry and conventions (used throughout invrad, also by the vote kernel)
---------------------------------------------------------------------------
* ``n``: unit normal of the luminaire plane, facing into the room; a luminaire on the plane
  faces along ``n``.
* ``h > 0``: distance of ``s`` in front of the plane, ``h = n . (s - p0)`` for any plane
  point ``p0``. The foot point is ``a = s - h n``.
* ``alpha`` in (0, pi]: the angle between ``m`` and ``n``, ``cos(alpha) = m . n``.
  ``alpha = pi`` means ``m = -n`` (the point faces the plane squarely: circular contours);
  ``alpha -> 0`` means the plane is behind the point's horizon (nothing can be seen).
* Plane coordinates ``(x, y)``, origin at the foot point ``a``:

  - ``w`` (x axis, the *minor axis* direction) = the normalised component of ``m`` in the
    plane, ``w = (m - (m.n) n) / |m - (m.n) n|``: the direction the voting point faces,
    projected on the plane. For ``alpha = pi`` it is undefined and any in-plane unit
    vector may be used (the distribution is rotationally symmetric).
  - ``v`` (y axis, the *major axis* direction) = ``n x w``. This equals
    ``(n x m) / |n x m|``, the thesis' major axis (its listing 4.5), and ``w = v x n``.
  - ``(w, v, n)`` is a right-handed frame; a plane point is ``c = a + x w + y v``.

  With ``m = cos(alpha) n + sin(alpha) w`` the per-lumen illuminance at ``s`` from a
  luminaire at ``c`` is (``r^2 = h^2 + x^2 + y^2``)::

      e(h, alpha, x, y) = h * max(0, x sin(alpha) - h cos(alpha)) / (pi r^4)

  It is even in ``y``; its maximum lies on the x axis at ``x_max >= 0``. Its contours are
  explicit: ``e`` is reached where ``y^2 = sqrt(h (x sin(alpha) - h cos(alpha)) / (pi e))
  - h^2 - x^2``; the sets ``{e >= level}`` are convex.
* Scale invariance (exact): ``e(h, alpha, x, y) = e(1, alpha, x/h, y/h) / h^2``. Every
  length below scales with ``h`` and every level with ``1/h^2``; the voting table is
  therefore stored at unit distance only (see :mod:`invrad_wb.core.inverse.table`).
* The maximum has a closed form (derived here, not in the thesis): on ``y = 0``
  ``d/dx [(x s - c) / (1 + x^2)^2] = 0`` gives ``3 s x^2 - 4 c x - s = 0``, so at ``h = 1``
  ``x_max = (2c + sqrt(4c^2 + 3s^2)) / (3s) = s / (sqrt(4c^2 + 3s^2) - 2c)``
  (``c = cos(alpha)``, ``s = sin(alpha)``; the second form is used for ``c < 0``).
  Newton/Levenberg-Marquardt and the (1+1) evolution strategy (thesis 3.1.2) are
  implemented too and tested against it.
* Rotation angle ``beta`` (thesis 4.1.1.2): the direction from ``s`` to the maximum is
  ``m`` rotated by ``beta`` about the major axis ``v`` (right-hand rule)::

      beta = pi - atan(x_max / h) - alpha

  In the ``(w, n)`` half-plane a unit vector ``sin(phi) w + cos(phi) n`` is rotated about
  ``v`` by ``beta`` to angle ``phi + beta``; ``m`` has ``phi = alpha``, the direction to the
  maximum has ``phi = pi - atan(x_max / h)``. ``beta = 0`` at ``alpha = pi``; ``beta`` is in
  ``[0, pi/2)``.
* Deformed ellipse (thesis eq. 3.20) with parameters ``(a, b, d, x_m, y_m)``::

      x = x_max + x_m + b (cos t + d cos 2t),     y = y_m + a sin t

  ``a``: half-length along the major axis ``v``; ``b``: half-length along the minor axis
  ``w``; ``d``: deformation; ``(x_m, y_m)``: centre offset from the maximum (thesis eq. 4.1).
  ``y_m = 0`` by symmetry. The minor apices are ``x_max + x_m + b d +- b``. Its implicit
  form (eq. 3.22-3.24) in the centred coordinates ``X = x - x_max - x_m``,
  ``Y = (y - y_m)^2 / a^2`` is ``R = (X - b d (1 - 2Y))^2 - b^2 (1 - Y) = 0``; ``R`` is the
  expanded polynomial of eq. 3.24 (checked in the tests) and its zero set is exactly the
  parametric curve. ``R`` is not a distance (it has units m^2 and its gradient vanishes at
  the major apices); :func:`geometric_error` measures what matters for voting.

Pipeline of one vote (thesis 3.2.4): :func:`maximum_closed_form` (or :func:`maximum_newton`,
:func:`maximum_es`), :func:`contour_samples` (binary search along ``k = 20`` rays from the
maximum), :func:`start_params`, then :func:`fit_lm` (Levenberg-Marquardt on eq. 3.30) or
:func:`fit_es` ((1+1)-ES on eq. 3.30); :func:`fit_deformed_ellipse` does all of it, and its
``"orthogonal"`` method adds :func:`fit_orthogonal` (geometric distance), which the voting
table uses. :func:`geometric_error` measures a fit against the true contour.

Array conventions: lengths in metres, levels ``e`` in lx/lm (1/m^2), angles in radians;
functions broadcast their arguments with numpy rules unless a shape is stated.
"""
import math
import time
from collections import namedtuple

import numpy as np

from invrad_wb.errors import SettingsError

#: Number of contour samples per fit (thesis 3.2.4: 20 are enough, figure 3.8).
DEFAULT_SAMPLES = 20
#: Bisection steps for a contour radius; 64 halvings exhaust float64.
BISECTION_STEPS = 64
#: (1+1) evolution strategy: step-size factor and success-rate target (Rechenberg).
ES_FACTOR = 0.85
ES_SUCCESS = 0.2

Maximum = namedtuple("Maximum", "x e rotation iterations evaluations")
Maximum.__doc__ = """Maximum of the distribution on the plane.

x : float64 array, metres. Position of the maximum on the x (minor) axis; ``y = 0``.
e : float64 array, lx/lm. The maximum value ``e_max``.
rotation : float64 array, rad. The rotation angle ``beta`` (module docstring).
iterations : int array. Newton iterations or ES generations used (0 for the closed form).
evaluations : int array. Function evaluations used.
"""

EllipseFit = namedtuple(
    "EllipseFit",
    "params samples x_max e_max rotation mse iterations evaluations method")
EllipseFit.__doc__ = """One batch of deformed-ellipse fits (see :func:`fit_deformed_ellipse`).

params : (..., 5) float64. ``(a, b, d, x_m, y_m)``; lengths in metres.
samples : (..., k, 2) float64, metres. The contour samples the fit used (plane coords).
x_max, e_max, rotation : (...) float64. The maximum (metres, lx/lm, rad).
mse : (...) float64. ``"lm"``/``"es"``: thesis eq. 3.30 at the solution (mean of squared
    eq. 3.24), m^4; ``"orthogonal"``: root mean squared distance of the samples, metres.
iterations, evaluations : (...) int. LM iterations / ES generations, and residual evaluations.
method : str. ``"lm"``, ``"es"`` or ``"orthogonal"``.
"""


# --------------------------------------------------------------------------- distribution

def _check_h(h):
    h = np.asarray(h, dtype=np.float64)
    if np.any(~(h > 0)):
        raise SettingsError("distance h to the luminaire plane must be > 0 (metres)")
    return h


def illuminance_per_lumen(h, alpha, x, y):
    """Per-lumen illuminance at the voting point from a luminaire at plane point ``(x, y)``.

    Thesis eq. 3.28 with ``A`` -> flux: ``e = cos(theta_l) cos(theta_s) / (pi r^2)``.

    Parameters
    ----------
    h : float or array, metres (> 0)
        Distance of the voting point in front of the luminaire plane.
    alpha : float or array, rad
        Angle between the voting point's normal ``m`` and the plane normal ``n``.
    x, y : float or array, metres
        Luminaire position in plane coordinates (module docstring).

    Returns
    -------
    float64 array (broadcast shape), lx/lm
    """
    h = _check_h(h)
    alpha = np.asarray(alpha, dtype=np.float64)
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    r2 = h * h + x * x + y * y
    num = x * np.sin(alpha) - h * np.cos(alpha)
    return h * np.maximum(num, 0.0) / (np.pi * r2 * r2)


def _g1(c, s, x, y):
    """Unclipped per-lumen illuminance at unit distance (smooth; same maximiser)."""
    q = 1.0 + x * x + y * y
    return (x * s - c) / (np.pi * q * q)


def _g1_derivatives(c, s, x, y):
    """Value, gradient (2 arrays) and Hessian (3 arrays xx, xy, yy) of :func:`_g1`."""
    q = 1.0 + x * x + y * y
    nn = x * s - c
    p = s * q - 4.0 * x * nn
    pq3 = np.pi * q ** 3
    pq4 = pq3 * q
    g = nn / (np.pi * q * q)
    gx = p / pq3
    gy = -4.0 * y * nn / pq3
    gxx = ((-2.0 * x * s - 4.0 * nn) * q - 6.0 * x * p) / pq4
    gxy = (2.0 * y * s * q - 6.0 * y * p) / pq4
    gyy = (-4.0 * nn * q + 24.0 * y * y * nn) / pq4
    return g, (gx, gy), (gxx, gxy, gyy)


def _x_max_unit(alpha):
    """Closed-form position of the maximum at unit distance (module docstring)."""
    alpha = np.asarray(alpha, dtype=np.float64)
    c, s = np.cos(alpha), np.sin(alpha)
    root = np.sqrt(4.0 * c * c + 3.0 * s * s)
    with np.errstate(divide="ignore", invalid="ignore"):
        pos = (2.0 * c + root) / (3.0 * s)
        neg = s / (root - 2.0 * c)
    return np.where(c >= 0.0, pos, neg)


def rotation_angle(h, alpha, x_max):
    """Rotation angle ``beta = pi - atan(x_max / h) - alpha`` (rad), see the module docstring.

    Rotating the voting point's normal ``m`` by ``beta`` about the major axis ``v = n x w``
    (right-hand rule) gives the direction from the voting point to the maximum.
    """
    return np.pi - np.arctan2(np.asarray(x_max, dtype=np.float64),
                              np.asarray(h, dtype=np.float64)) \
        - np.asarray(alpha, dtype=np.float64)


def maximum_closed_form(h, alpha):
    """Exact maximum of the distribution (closed form, module docstring).

    Parameters
    ----------
    h : float or array, metres (> 0)
    alpha : float or array, rad, in (0, pi]

    Returns
    -------
    Maximum
        ``x`` (metres), ``e`` (lx/lm), ``rotation`` (rad); iterations and evaluations 0.
    """
    h = _check_h(h)
    alpha = np.asarray(alpha, dtype=np.float64)
    xu = _x_max_unit(alpha)
    e = _g1(np.cos(alpha), np.sin(alpha), xu, 0.0) / (h * h)
    x = xu * h
    zero = np.zeros(np.broadcast(h, alpha).shape, dtype=np.int64)
    return Maximum(x, e, rotation_angle(h, alpha, x), zero, zero)


def maximum_newton(h, alpha, tol=1e-13, max_iter=100):
    """Maximum by Newton's method with Levenberg-Marquardt damping and a line search.

    Thesis 3.1.2.1 / 3.2.4: minimises ``-e`` over the plane ``(x, y)`` from the foot point
    ``(0, 0)`` with the analytic gradient and Hessian. Where the Hessian of ``-e`` is not
    positive definite a multiple of the identity is added (eq. 3.10); the step is then
    limited to ``1 + |x|`` (in units of ``h``) and halved until the Armijo condition holds.
    The objective is the unclipped ``h (x sin(alpha) - h cos(alpha)) / (pi r^4)``, which has
    the same maximiser as ``e`` but is not flat where the point cannot see the plane (for
    ``alpha < pi/2`` the foot point itself is such a place).

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
    h = _check_h(h)
    alpha = np.asarray(alpha, dtype=np.float64)
    h, alpha = np.broadcast_arrays(h, alpha)
    c, s = np.cos(alpha), np.sin(alpha)
    x = np.zeros(alpha.shape)
    y = np.zeros(alpha.shape)
    it = np.zeros(alpha.shape, dtype=np.int64)
    nev = np.zeros(alpha.shape, dtype=np.int64)
    active = np.ones(alpha.shape, dtype=bool)
    for _ in range(max_iter):
        if not active.any():
            break
        g, (gx, gy), (gxx, gxy, gyy) = _g1_derivatives(c, s, x, y)
        nev += active
        # minimise phi = -g: gradient G, Hessian H
        Gx, Gy, Hxx, Hxy, Hyy = -gx, -gy, -gxx, -gxy, -gyy
        tr, det = Hxx + Hyy, Hxx * Hyy - Hxy * Hxy
        disc = np.sqrt(np.maximum(0.25 * tr * tr - det, 0.0))
        lo, hi = 0.5 * tr - disc, 0.5 * tr + disc
        scale = np.abs(lo) + np.abs(hi) + 1e-300
        lam = np.where(lo > 1e-8 * scale, 0.0, -lo + 1e-3 * scale)
        a11, a22 = Hxx + lam, Hyy + lam
        dd = a11 * a22 - Hxy * Hxy
        px = -(a22 * Gx - Hxy * Gy) / dd
        py = -(a11 * Gy - Hxy * Gx) / dd
        plen = np.hypot(px, py)
        cap = 1.0 + np.abs(x)
        f = np.where(plen > cap, cap / np.maximum(plen, 1e-300), 1.0)
        px, py = px * f, py * f
        slope = Gx * px + Gy * py  # < 0: descent direction
        step = np.ones(alpha.shape)
        # a full, undamped Newton step that changes -e by no more than rounding is taken:
        # near the optimum values stop resolving progress, the gradient still does
        pure = (lam == 0.0) & (f == 1.0)
        for _ls in range(60):
            gn = _g1(c, s, x + step * px, y + step * py)
            nev += active
            ok = -gn <= -g + 1e-4 * step * slope
            ok |= pure & (step == 1.0) & (gn >= g - 1e-14 * np.abs(g))
            if np.all(ok | ~active):
                break
            step = np.where(ok, step, 0.5 * step)
        dx, dy = step * px, step * py
        x = np.where(active, x + dx, x)
        y = np.where(active, y + dy, y)
        it += active
        active &= np.hypot(dx, dy) > tol * (1.0 + np.abs(x))
    xm = x * h
    e = illuminance_per_lumen(h, alpha, xm, y * h)
    return Maximum(xm, e, rotation_angle(h, alpha, xm), it, nev)


def _rng(rng):
    if rng is None or isinstance(rng, (int, np.integer)):
        return np.random.default_rng(rng)
    return rng


def maximum_es(h, alpha, rng=None, sigma0=0.5, tol=1e-9, max_evals=20000, adapt_every=10):
    """Maximum by the (1+1) evolution strategy with the 1/5 success rule (thesis 3.1.2.2).

    Starts at the foot point; a descendant ``x + sigma * N(0, I)`` replaces the parent when
    it is at least as good; every ``adapt_every`` generations ``sigma`` is multiplied by
    0.85 when fewer than 1/5 of the mutations succeeded and divided by 0.85 otherwise.
    Maximises the unclipped objective (see :func:`maximum_newton`). Works at unit distance
    (``sigma`` in units of ``h``) and scales the result by ``h``.

    Parameters
    ----------
    h : float or array, metres (> 0)
    alpha : float or array, rad
    rng : numpy.random.Generator or int seed, optional
    sigma0 : float
        Initial step size in units of ``h``.
    tol : float
        Stop when ``sigma < tol * (1 + |x|/h)``.
    max_evals : int
    adapt_every : int

    Returns
    -------
    Maximum
    """
    h = _check_h(h)
    alpha = np.asarray(alpha, dtype=np.float64)
    h, alpha = np.broadcast_arrays(h, alpha)
    rng = _rng(rng)
    c, s = np.cos(alpha), np.sin(alpha)
    shape = alpha.shape
    x = np.zeros(shape)
    y = np.zeros(shape)
    fx = _g1(c, s, x, y)
    sigma = np.full(shape, float(sigma0))
    succ = np.zeros(shape, dtype=np.int64)
    gen = np.zeros(shape, dtype=np.int64)
    active = np.ones(shape, dtype=bool)
    for i in range(1, max_evals + 1):
        z = rng.standard_normal((2,) + shape)
        xn, yn = x + sigma * z[0], y + sigma * z[1]
        fn = _g1(c, s, xn, yn)
        better = active & (fn > fx)
        keep = active & (fn >= fx)  # ties are accepted but are no success
        x, y, fx = np.where(keep, xn, x), np.where(keep, yn, y), np.where(keep, fn, fx)
        succ += better
        gen += active
        if i % adapt_every == 0:
            rate = succ / adapt_every
            sigma = np.where(active, np.where(rate < ES_SUCCESS, sigma * ES_FACTOR,
                                              sigma / ES_FACTOR), sigma)
            succ = np.zeros_like(succ)
            active &= sigma >= tol * (1.0 + np.abs(x))
            if not active.any():
                break
    xm = x * h
    e = illuminance_per_lumen(h, alpha, xm, y * h)
    return Maximum(xm, e, rotation_angle(h, alpha, xm), gen, gen + 1)


# --------------------------------------------------------------------------- contours

def contour_radius(h, alpha, e, x0, theta, steps=BISECTION_STEPS):
    """Distance from the plane point ``(x0, 0)`` to the contour ``e`` along direction ``theta``.

    Binary search (thesis 3.2.4). Superlevel sets of the distribution are convex (the set
    ``pi e r^4 <= h (x sin(alpha) - h cos(alpha))`` is convex in ``(x, y)``), so along any ray
    from a point inside the contour the distribution falls monotonically through ``e``
    exactly once.

    Parameters
    ----------
    h, alpha, e : arrays broadcastable to each other and to ``theta``
        metres, rad, lx/lm. ``e`` must be > 0.
    x0 : array, metres
        Ray origin on the x axis; must satisfy ``e(x0, 0) >= e`` (e.g. the maximum).
    theta : array, rad
        Ray direction ``(cos theta, sin theta)`` in plane coordinates.
    steps : int
        Bisection steps.

    Returns
    -------
    float64 array, metres (``0`` where ``e`` is not below the value at ``x0``).
    """
    h = _check_h(h)
    alpha = np.asarray(alpha, dtype=np.float64)
    e = np.asarray(e, dtype=np.float64)
    x0 = np.asarray(x0, dtype=np.float64)
    theta = np.asarray(theta, dtype=np.float64)
    h, alpha, e, x0, theta = np.broadcast_arrays(h, alpha, e, x0, theta)
    # Work at unit distance: e1 = e h^2, lengths / h.
    c, s = np.cos(alpha), np.sin(alpha)
    e1 = e * h * h
    X0 = x0 / h
    ct, st = np.cos(theta), np.sin(theta)
    # Upper bound: x s - c <= sqrt(2) sqrt(1 + r^2), so e1 < e wherever
    # (1 + r^2)^(3/2) > sqrt(2) / (pi e1).
    with np.errstate(divide="ignore"):
        rb = np.sqrt(np.maximum((math.sqrt(2.0) / (np.pi * e1)) ** (2.0 / 3.0) - 1.0, 0.0))
    lo = np.zeros(e.shape)
    hi = rb + np.abs(X0) + 1.0
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        above = _g1(c, s, X0 + mid * ct, mid * st) >= e1
        lo = np.where(above, mid, lo)
        hi = np.where(above, hi, mid)
    return 0.5 * (lo + hi) * h


def ray_angles(k):
    """The ``k`` ray directions ``2 pi j / k`` (rad) used for contour samples."""
    return 2.0 * np.pi * np.arange(k) / k


def contour_samples(h, alpha, e, k=DEFAULT_SAMPLES, x_max=None):
    """``k`` points of the contour ``e`` by binary search along rays from a point inside.

    Parameters
    ----------
    h, alpha, e : arrays broadcastable to a common shape ``S``
        metres, rad, lx/lm; ``0 < e < e_max``.
    k : int
        Number of rays, at angles ``2 pi j / k`` from the +x (minor axis) direction.
    x_max : array of shape ``S``, metres, optional
        Ray origin ``(x_max, 0)``: the maximum (thesis) or any point of the x axis inside the
        contour; the closed-form maximum when omitted.

    Returns
    -------
    (S..., k, 2) float64, metres. Plane coordinates ``(x, y)``.
    """
    if k < 3:
        raise SettingsError(f"need at least 3 contour samples, got {k}")
    h = _check_h(h)
    h, alpha, e = np.broadcast_arrays(h, np.asarray(alpha, np.float64),
                                      np.asarray(e, np.float64))
    if x_max is None:
        x_max = maximum_closed_form(h, alpha).x
    x_max = np.broadcast_to(np.asarray(x_max, np.float64), h.shape)
    th = ray_angles(k)
    rho = contour_radius(h[..., None], alpha[..., None], e[..., None], x_max[..., None], th)
    return np.stack([x_max[..., None] + rho * np.cos(th), rho * np.sin(th)], axis=-1)


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


# --------------------------------------------------------------------------- deformed ellipse

def ellipse_points(params, t, x_max=0.0):
    """Points of the deformed ellipse (thesis eq. 3.20) in plane coordinates.

    Parameters
    ----------
    params : (..., 5) array
        ``(a, b, d, x_m, y_m)``; lengths in metres.
    t : (T,) array, rad
        Curve parameter.
    x_max : array of shape ``(...)``, metres
        Position of the maximum on the x axis; the centre is ``(x_max + x_m, y_m)``.

    Returns
    -------
    (..., T, 2) float64, metres
    """
    p = np.asarray(params, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)
    a, b, d, xm, ym = (p[..., i, None] for i in range(5))
    xc = np.asarray(x_max, dtype=np.float64)[..., None] + xm
    x = xc + b * (np.cos(t) + d * np.cos(2.0 * t))
    y = ym + a * np.sin(t)
    return np.stack(np.broadcast_arrays(x, y), axis=-1)


def implicit_residual(params, x, y, x_max=0.0):
    """Implicit deformed-ellipse residual ``R`` (thesis eq. 3.24), m^2.

    ``R = (X - b d (1 - 2Y))^2 - b^2 (1 - Y)`` with ``X = x - x_max - x_m`` and
    ``Y = (y - y_m)^2 / a^2``; zero exactly on the curve of :func:`ellipse_points`.

    Parameters
    ----------
    params : (..., 5) array; x, y : arrays broadcastable to ``(..., k)``; x_max : ``(...)``.

    Returns
    -------
    (..., k) float64
    """
    p = np.asarray(params, dtype=np.float64)
    a, b, d, xm, ym = (p[..., i, None] for i in range(5))
    X = np.asarray(x, np.float64) - np.asarray(x_max, np.float64)[..., None] - xm
    Y = (np.asarray(y, np.float64) - ym) ** 2 / (a * a)
    u = X - b * d * (1.0 - 2.0 * Y)
    return u * u - b * b * (1.0 - Y)


def squared_error(params, x, y, x_max=0.0):
    """Thesis eq. 3.29: the squared implicit residual, m^4."""
    return implicit_residual(params, x, y, x_max) ** 2


def mse(params, samples, x_max=0.0):
    """Thesis eq. 3.30: mean of eq. 3.29 over the samples ``(..., k, 2)``; m^4."""
    samples = np.asarray(samples, dtype=np.float64)
    return squared_error(params, samples[..., 0], samples[..., 1], x_max).mean(axis=-1)


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


def fit_lm(samples, x_max, start, max_iter=200, tol=1e-14):
    """Levenberg-Marquardt fit of the deformed ellipse to contour samples (batched).

    Minimises the thesis' mean squared implicit residual (eq. 3.30) over
    ``(a, b, d, x_m, y_m)`` with the analytic Jacobian of eq. 3.24 (the gradient of eq. 3.31),
    Gauss-Newton steps damped by ``lambda * diag(J^T J)`` (Marquardt). Coordinates are
    normalised by the starting ``b`` so that the problem is scale-free.

    Parameters
    ----------
    samples : (N, k, 2) array, metres
    x_max : (N,) array, metres
    start : (N, 5) array
    max_iter : int
    tol : float
        Stop a problem when its relative cost decrease and step are below ``tol``.

    Returns
    -------
    params : (N, 5) float64; mse : (N,) float64, m^4; iterations : (N,) int;
    evaluations : (N,) int
    """
    samples = np.asarray(samples, dtype=np.float64)
    N = samples.shape[0]
    L = np.abs(np.asarray(start, np.float64)[:, 1]).copy()
    L = np.where(L > 0, L, 1.0)[:, None]
    X = (samples[..., 0] - np.asarray(x_max, np.float64)[:, None]) / L
    Yd = samples[..., 1] / L
    p = np.asarray(start, dtype=np.float64).copy()
    p[:, [0, 1, 3, 4]] /= L
    r, J = _resid_jac(p, X, Yd)
    cost = np.einsum("nk,nk->n", r, r)
    lam = np.full(N, 1e-3)
    it = np.zeros(N, dtype=np.int64)
    nev = np.ones(N, dtype=np.int64)
    active = np.ones(N, dtype=bool)
    eye = np.eye(5)
    for _ in range(max_iter):
        if not active.any():
            break
        idx = np.flatnonzero(active)
        Ji, ri = J[idx], r[idx]
        A = np.einsum("nki,nkj->nij", Ji, Ji)
        g = np.einsum("nki,nk->ni", Ji, ri)
        diag = np.einsum("nii->ni", A)
        A = A + (lam[idx, None] * np.maximum(diag, 1e-12))[:, :, None] * eye \
            + 1e-15 * eye
        step = -np.linalg.solve(A, g[..., None])[..., 0]
        pn = p[idx] + step
        rn, Jn = _resid_jac(pn, X[idx], Yd[idx])
        cn = np.einsum("nk,nk->n", rn, rn)
        nev[idx] += 1
        it[idx] += 1
        ok = np.isfinite(cn) & (cn <= cost[idx])
        acc = idx[ok]
        rel = (cost[idx] - np.where(ok, cn, cost[idx])) / np.maximum(cost[idx], 1e-300)
        small = np.linalg.norm(step, axis=1) <= tol * (1.0 + np.linalg.norm(p[idx], axis=1))
        p[acc], r[acc], J[acc], cost[acc] = pn[ok], rn[ok], Jn[ok], cn[ok]
        lam[idx] = np.where(ok, np.maximum(lam[idx] / 3.0, 1e-12), lam[idx] * 4.0)
        done = (ok & (rel < tol) & small) | (cost[idx] < 1e-30) | (lam[idx] > 1e12)
        active[idx[done]] = False
    p = _canonical(p)
    p[:, [0, 1, 3, 4]] *= L
    L1 = L[:, 0]
    return p, cost / samples.shape[1] * L1 ** 4, it, nev


def fit_es(samples, x_max, start, rng=None, sigma0=0.05, tol=1e-9, max_evals=20000,
           adapt_every=10):
    """(1+1) evolution-strategy fit of the deformed ellipse (thesis 3.1.2.2, batched).

    Same objective and normalisation as :func:`fit_lm`; mutation ``sigma * N(0, I)`` of all
    five parameters; 1/5 success rule with factor 0.85 every ``adapt_every`` generations;
    stops when ``sigma < tol`` or after ``max_evals`` generations.

    Returns
    -------
    params : (N, 5); mse : (N,), m^4; generations : (N,) int; evaluations : (N,) int
    """
    rng = _rng(rng)
    samples = np.asarray(samples, dtype=np.float64)
    N = samples.shape[0]
    L = np.abs(np.asarray(start, np.float64)[:, 1]).copy()
    L = np.where(L > 0, L, 1.0)[:, None]
    X = (samples[..., 0] - np.asarray(x_max, np.float64)[:, None]) / L
    Yd = samples[..., 1] / L
    p = np.asarray(start, dtype=np.float64).copy()
    p[:, [0, 1, 3, 4]] /= L
    r = _resid(p, X, Yd)
    cost = np.einsum("nk,nk->n", r, r)
    sigma = np.full(N, float(sigma0))
    succ = np.zeros(N, dtype=np.int64)
    gen = np.zeros(N, dtype=np.int64)
    active = np.ones(N, dtype=bool)
    for i in range(1, max_evals + 1):
        pn = p + sigma[:, None] * rng.standard_normal(p.shape)
        with np.errstate(divide="ignore", invalid="ignore"):
            rn = _resid(pn, X, Yd)
            cn = np.einsum("nk,nk->n", rn, rn)
        keep = active & np.isfinite(cn) & (cn <= cost)
        better = keep & (cn < cost)  # ties are accepted but are no success
        p[keep], cost[keep] = pn[keep], cn[keep]
        succ += better
        gen += active
        if i % adapt_every == 0:
            rate = succ / adapt_every
            sigma = np.where(active, np.where(rate < ES_SUCCESS, sigma * ES_FACTOR,
                                              sigma / ES_FACTOR), sigma)
            succ = np.zeros_like(succ)
            active &= sigma >= tol
            if not active.any():
                break
    p = _canonical(p)
    p[:, [0, 1, 3, 4]] *= L
    L1 = L[:, 0]
    return p, cost / samples.shape[1] * L1 ** 4, gen, gen + 1


def fit_orthogonal(samples, x_max, start, max_iter=100, tol=1e-12):
    """Orthogonal-distance (geometric) least-squares fit of the deformed ellipse, batched.

    Minimises ``sum_i |P(t_i) - s_i|^2`` over ``(a, b, d, x_m, y_m)`` and one curve
    parameter ``t_i`` per sample (orthogonal distance regression), by Levenberg-Marquardt
    with the ``t_i`` eliminated through the Schur complement (their normal matrix is
    diagonal). The implicit residual of the thesis weighs the samples unevenly (it is not a
    distance); this fit minimises the distances that matter when votes are drawn. Start
    from :func:`fit_lm`'s result.

    Parameters
    ----------
    samples : (N, k, 2) array, metres
    x_max : (N,) array, metres
    start : (N, 5) array
    max_iter : int
    tol : float

    Returns
    -------
    params : (N, 5) float64; rms : (N,) float64, metres (root mean squared distance);
    iterations : (N,) int
    """
    samples = np.asarray(samples, dtype=np.float64)
    N, k, _ = samples.shape
    L = np.abs(np.asarray(start, np.float64)[:, 1]).copy()
    L = np.where(L > 0, L, 1.0)[:, None]
    X = (samples[..., 0] - np.asarray(x_max, np.float64)[:, None]) / L
    Yd = samples[..., 1] / L
    p = _canonical(np.asarray(start, dtype=np.float64))
    p[:, [0, 1, 3, 4]] /= L
    # starting t_i: nearest point of the start curve, then the fit refines them
    tt = 2.0 * np.pi * np.arange(360) / 360
    cur = ellipse_points(p, tt)
    d2 = (cur[:, None, :, 0] - X[:, :, None]) ** 2 + (cur[:, None, :, 1] - Yd[:, :, None]) ** 2
    t = tt[np.argmin(d2, axis=-1)]

    def resid(p, t, X, Yd):
        a, b, d, xm, ym = (p[:, i, None] for i in range(5))
        return (xm + b * (np.cos(t) + d * np.cos(2.0 * t)) - X, ym + a * np.sin(t) - Yd)

    rx, ry = resid(p, t, X, Yd)
    cost = np.einsum("nk,nk->n", rx, rx) + np.einsum("nk,nk->n", ry, ry)
    lam = np.full(N, 1e-3)
    it = np.zeros(N, dtype=np.int64)
    active = np.ones(N, dtype=bool)
    eye = np.eye(5)
    for _ in range(max_iter):
        if not active.any():
            break
        ix = np.flatnonzero(active)
        pi_, ti = p[ix], t[ix]
        a, b, d = (pi_[:, i, None] for i in range(3))
        ct, st = np.cos(ti), np.sin(ti)
        c2, s2 = np.cos(2.0 * ti), np.sin(2.0 * ti)
        n, kk = len(ix), k
        Jx = np.zeros((n, kk, 5))
        Jy = np.zeros((n, kk, 5))
        Jx[..., 1] = ct + d * c2
        Jx[..., 2] = b * c2
        Jx[..., 3] = 1.0
        Jy[..., 0] = st
        Jy[..., 4] = 1.0
        tx = -b * (st + 2.0 * d * s2)
        ty = a * ct
        rxi, ryi = rx[ix], ry[ix]
        A = np.einsum("nki,nkj->nij", Jx, Jx) + np.einsum("nki,nkj->nij", Jy, Jy)
        B = Jx * tx[..., None] + Jy * ty[..., None]
        Dt = tx * tx + ty * ty
        gp = np.einsum("nki,nk->ni", Jx, rxi) + np.einsum("nki,nk->ni", Jy, ryi)
        gt = tx * rxi + ty * ryi
        lm = lam[ix]
        Ad = A + (lm[:, None] * np.maximum(np.einsum("nii->ni", A), 1e-12))[:, :, None] * eye
        Dl = Dt * (1.0 + lm[:, None]) + 1e-12
        S = Ad - np.einsum("nki,nk,nkj->nij", B, 1.0 / Dl, B) + 1e-15 * eye
        rhs = -(gp - np.einsum("nki,nk->ni", B, gt / Dl))
        dp = np.linalg.solve(S, rhs[..., None])[..., 0]
        dt = -(gt + np.einsum("nki,ni->nk", B, dp)) / Dl
        pn, tn = pi_ + dp, ti + dt
        rxn, ryn = resid(pn, tn, X[ix], Yd[ix])
        cn = np.einsum("nk,nk->n", rxn, rxn) + np.einsum("nk,nk->n", ryn, ryn)
        ok = np.isfinite(cn) & (cn <= cost[ix])
        rel = (cost[ix] - np.where(ok, cn, cost[ix])) / np.maximum(cost[ix], 1e-300)
        acc = ix[ok]
        p[acc], t[acc], cost[acc] = pn[ok], tn[ok], cn[ok]
        rx[acc], ry[acc] = rxn[ok], ryn[ok]
        it[ix] += 1
        lam[ix] = np.where(ok, np.maximum(lm / 3.0, 1e-12), lm * 4.0)
        step = np.linalg.norm(dp, axis=1)
        done = (ok & (rel < tol) & (step < 1e3 * tol)) | (cost[ix] < 1e-30) | (lam[ix] > 1e12)
        active[ix[done]] = False
    p = _canonical(p)
    p[:, [0, 1, 3, 4]] *= L
    return p, np.sqrt(cost / k) * L[:, 0], it


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
    h = _check_h(h)
    h, alpha, e = np.broadcast_arrays(h, np.asarray(alpha, np.float64),
                                      np.asarray(e, np.float64))
    if x_max is None:
        x_max = maximum_closed_form(h, alpha).x
    x_max = np.broadcast_to(np.asarray(x_max, np.float64), h.shape)
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
