"""Form-factor distribution of one vote, its maximum, its contours and the deformed ellipse.

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
  Newton's method and the (1+1) evolution strategy (thesis 3.1.2) are implemented too
  (:mod:`invrad_wb.core.inverse.tablefit`) and tested against it.
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
  the major apices); :func:`invrad_wb.core.inverse.tablefit.geometric_error` measures
  what matters for voting.

This module is the model the votes use at run time (with the voting table,
:mod:`invrad_wb.core.inverse.table`): the distribution, its maximum, contours and the deformed
ellipse. Fitting the ellipses (thesis 3.2.4: :func:`contour_samples` along ``k = 20`` rays
from the maximum, starting values, Levenberg-Marquardt or (1+1)-ES on eq. 3.30, the
orthogonal refinement the table stores, their accuracy) is offline work, in
:mod:`invrad_wb.core.inverse.tablefit`, used by ``tables/make_voting_table.py``.

Array conventions: lengths in metres, levels ``e`` in lx/lm (1/m^2), angles in radians;
functions broadcast their arguments with numpy rules unless a shape is stated.
"""
import math
from collections import namedtuple

import numpy as np

from invrad_wb.errors import SettingsError

#: Number of contour samples per fit (thesis 3.2.4: 20 are enough, figure 3.8).
DEFAULT_SAMPLES = 20
#: Bisection steps for a contour radius; 64 halvings exhaust float64.
BISECTION_STEPS = 64

Maximum = namedtuple("Maximum", "x e rotation iterations evaluations")
Maximum.__doc__ = """Maximum of the distribution on the plane.

x : float64 array, metres. Position of the maximum on the x (minor) axis; ``y = 0``.
e : float64 array, lx/lm. The maximum value ``e_max``.
rotation : float64 array, rad. The rotation angle ``beta`` (module docstring).
iterations : int array. Newton iterations or ES generations used (0 for the closed form).
evaluations : int array. Function evaluations used.
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


def _levels(h, alpha, e, x_max=None):
    """``h, alpha, e`` broadcast to one shape ``S`` and ``x_max`` (S), the closed-form
    maximum where omitted."""
    h = _check_h(h)
    h, alpha, e = np.broadcast_arrays(h, np.asarray(alpha, np.float64),
                                      np.asarray(e, np.float64))
    if x_max is None:
        x_max = maximum_closed_form(h, alpha).x
    return h, alpha, e, np.broadcast_to(np.asarray(x_max, np.float64), h.shape)


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
    h, alpha, e, x_max = _levels(h, alpha, e, x_max)
    th = ray_angles(k)
    rho = contour_radius(h[..., None], alpha[..., None], e[..., None], x_max[..., None], th)
    return np.stack([x_max[..., None] + rho * np.cos(th), rho * np.sin(th)], axis=-1)


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
