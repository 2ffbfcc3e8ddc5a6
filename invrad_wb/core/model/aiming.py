"""Aimed luminaires: the photometric frame of a luminaire whose axis is tilted.

A luminaire's ``normal`` is its photometric axis (gamma = 0, where the light goes). An
adjustable spot is mounted on a surface (its *mount normal*, e.g. straight down from a
ceiling) and aimed elsewhere: tilt = the angle between aim and mount normal, pan = the
direction of the tilt around the mount normal.

The C = 0 axis of a tilted luminaire is the mounted, untilted luminaire's C = 0 axis
(``u`` of :func:`invrad_wb.core.model.scene.plane_basis` of the mount normal) carried by
the smallest rotation that takes the mount normal onto the aim (a gimbal tilting the
luminaire towards its target). ``plane_basis`` of the aim itself would not do: it
switches its reference axis at 25.8 degrees off vertical, so a rotationally asymmetric
distribution would turn by up to 90 degrees when a spot is tilted a little further.

Pan (degrees) is measured in the mount plane from the mount basis' ``u`` towards ``v``;
for a ceiling (mount normal -z) ``u`` is +x and ``v`` is -y.
"""
import numpy as np


def rotation_between(a, b):
    """(3, 3) the smallest rotation taking unit ``a`` onto unit ``b`` (Rodrigues); for
    opposite vectors a half turn about an axis perpendicular to ``a``."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    v = np.cross(a, b)
    c = float(a @ b)
    if c < -1.0 + 1e-12:
        from invrad_wb.core.model.scene import plane_basis
        u, _ = plane_basis(a)
        return 2.0 * np.outer(u, u) - np.eye(3)
    K = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    return np.eye(3) + K + K @ K / (1.0 + c)


def photometric_frame(normal, c0=None):
    """(u, v): the luminaire's C = 0 and C = 90 axes for the photometric axis ``normal``.

    ``c0``: a C = 0 direction the luminaire carries (made perpendicular to ``normal``);
    None: ``plane_basis(normal)`` (a luminaire facing along its mount normal)."""
    from invrad_wb.core.model.scene import plane_basis
    n = np.asarray(normal, dtype=np.float64)
    if c0 is None:
        return plane_basis(n)
    u = np.asarray(c0, dtype=np.float64) - n * (n @ np.asarray(c0, dtype=np.float64))
    norm = np.linalg.norm(u)
    if norm < 1e-9:
        return plane_basis(n)
    u = u / norm
    return u, np.cross(n, u)


def aimed_c0(mount_normal, aim):
    """(3,) the C = 0 axis of a luminaire mounted facing ``mount_normal`` and aimed
    along ``aim`` (the mounted frame's C = 0 carried by the tilt)."""
    from invrad_wb.core.model.scene import plane_basis
    m = np.asarray(mount_normal, dtype=np.float64)
    u, _ = plane_basis(m)
    return rotation_between(m, np.asarray(aim, dtype=np.float64)) @ u


def aim_from_tilt_pan(mount_normal, tilt_deg, pan_deg):
    """(3,) unit aim tilted ``tilt_deg`` from ``mount_normal`` towards pan ``pan_deg``."""
    from invrad_wb.core.model.scene import plane_basis
    m = np.asarray(mount_normal, dtype=np.float64)
    u, v = plane_basis(m)
    t, p = np.radians(tilt_deg), np.radians(pan_deg)
    return np.cos(t) * m + np.sin(t) * (np.cos(p) * u + np.sin(p) * v)


def tilt_pan(aim, mount_normal):
    """(tilt, pan) in degrees of ``aim`` relative to ``mount_normal`` (pan 0 when the
    tilt is 0)."""
    from invrad_wb.core.model.scene import plane_basis
    m = np.asarray(mount_normal, dtype=np.float64)
    a = np.asarray(aim, dtype=np.float64)
    a = a / np.linalg.norm(a)
    u, v = plane_basis(m)
    tilt = float(np.degrees(np.arccos(np.clip(a @ m, -1.0, 1.0))))
    if tilt < 1e-6:
        return 0.0, 0.0
    pan = float(np.degrees(np.arctan2(a @ v, a @ u))) % 360.0
    return tilt, pan


def aim_offset(mount_normal, aim):
    """(2,) the aim as gnomonic coordinates in the mount plane: ``aim`` is proportional
    to ``m + a u + b v``, tilt = atan(|(a, b)|) (smooth through zero tilt)."""
    m = np.asarray(mount_normal, dtype=np.float64)
    u, v = _basis(m)
    a = np.asarray(aim, dtype=np.float64)
    c = max(float(a @ m), 1e-6)
    return np.array([a @ u, a @ v]) / c


def aim_of_offset(mount_normal, ab, max_tilt_deg=None):
    """(3,) unit aim of gnomonic coordinates ``ab`` (:func:`aim_offset`); the tilt is
    clamped to ``max_tilt_deg`` when given."""
    m = np.asarray(mount_normal, dtype=np.float64)
    u, v = _basis(m)
    ab = np.asarray(ab, dtype=np.float64)
    if max_tilt_deg is not None:
        lim = max_offset(max_tilt_deg)
        r = float(np.hypot(ab[0], ab[1]))
        if r > lim:
            ab = ab * (lim / r)
    a = m + ab[0] * u + ab[1] * v
    return a / np.linalg.norm(a)


_MAX_OFFSETS = {}


def max_offset(max_tilt_deg):
    """``tan(max_tilt_deg)``: the largest gnomonic offset length (:func:`aim_offset`) of a
    tilt, remembered per tilt (the refinement asks for the same one at every step)."""
    lim = _MAX_OFFSETS.get(max_tilt_deg)
    if lim is None:
        if len(_MAX_OFFSETS) > 64:
            _MAX_OFFSETS.clear()
        lim = _MAX_OFFSETS[max_tilt_deg] = np.tan(np.radians(max_tilt_deg))
    return lim


def aim_of_offset_jacobian(mount_normal, ab):
    """(2, 3) d aim / d ``ab`` of :func:`aim_of_offset` (without its clamp)."""
    m = np.asarray(mount_normal, dtype=np.float64)
    u, v = _basis(m)
    q = m + ab[0] * u + ab[1] * v
    nq = np.linalg.norm(q)
    a = q / nq
    return np.stack([u - a * (a @ u), v - a * (a @ v)]) / nq


_BASES = {}


def _basis(m):
    """``plane_basis(m)``, remembered per mount normal (the refinement asks for the same
    few mounts thousands of times: 31 s of 158 on bench_aim's gallery)."""
    key = m.tobytes()
    uv = _BASES.get(key)
    if uv is None:
        from invrad_wb.core.model.scene import plane_basis
        if len(_BASES) > 4096:
            _BASES.clear()
        uv = _BASES[key] = plane_basis(m)
    return uv
