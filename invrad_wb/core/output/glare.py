"""Discomfort glare: the unified glare rating of CIE 117 (formula method).

    UGR = 8 log10( 0.25 / Lb * sum_k L_k^2 omega_k / p_k^2 )

``L_k`` (cd/m^2) is luminaire k's luminance towards the eye (its intensity towards the eye
over its luminous area projected on that direction), ``omega_k`` (sr) that projected area
over the squared distance, ``p_k`` the Guth position index of its direction relative to the
line of sight, and ``Lb`` (cd/m^2) the background luminance: the indirect illuminance at the
eye (a vertical plane facing the view) over pi. Only luminaires above the eye and in front
of it (within the half space the observer faces) count; the Guth index uses the usual fit
(IESNA Lighting Handbook):

    ln p = (35.2 - 0.31889 tau - 1.22 exp(-2 tau / 9)) 1e-3 sigma
           + (21 + 0.26667 tau - 0.002963 tau^2) 1e-5 sigma^2

with ``tau`` the angle (degrees) between the vertical plane through the line of sight and
the plane through the line of sight and the source, ``sigma`` the angle between the line of
sight and the direction to the source. CIE 117 reports values below 10 as "< 10".
"""
import math

import numpy as np

from invrad_wb.core.model.luminaires import luminous_area
from invrad_wb.core.model.scene import plane_basis

#: seated observer's eye height (metres), CIE 117 / EN 12464-1
EYE_HEIGHT_M = 1.2


def guth_index(tau_deg, sigma_deg):
    """Guth position index p (>= 1) for angles in degrees (arrays broadcast)."""
    t = np.asarray(tau_deg, dtype=np.float64)
    s = np.asarray(sigma_deg, dtype=np.float64)
    ln_p = ((35.2 - 0.31889 * t - 1.22 * np.exp(-2.0 * t / 9.0)) * 1e-3 * s
            + (21.0 + 0.26667 * t - 0.002963 * t * t) * 1e-5 * s * s)
    return np.exp(ln_p)


def ugr(luminaires, eye, view, background_lux):
    """UGR of luminaires seen from ``eye`` (3,) looking along horizontal ``view`` (3,).

    Parameters
    ----------
    luminaires : list of Luminaire (a luminous area: a disk radius or a photometry file's
        luminous opening; a luminaire without one is skipped)
    background_lux : float, indirect illuminance at the eye on a plane facing the view (lx)

    Returns
    -------
    float or None: None when no luminaire is in view (no glare)
    """
    eye = np.asarray(eye, dtype=np.float64)
    v = np.asarray(view, dtype=np.float64)
    v = v / np.linalg.norm(v)
    total = 0.0
    for lum in luminaires:
        area = luminous_area(lum)
        d = lum.position - eye
        r = float(np.linalg.norm(d))
        if area is None or r < 1e-6 or d[2] <= 0 or d @ v <= 0:
            continue
        to_eye = -d / r
        cos_e = float(to_eye @ lum.normal)
        if cos_e <= 1e-6:
            continue                      # the eye is behind the luminous area
        if getattr(lum, "photometry", None) is not None:
            u, w = plane_basis(lum.normal)
            i_cd = lum.flux_lm * float(lum.photometry.intensity_per_lm(
                np.array([to_eye @ u, to_eye @ w, cos_e])))
        else:
            i_cd = lum.flux_lm / math.pi * cos_e
        a_proj = area * cos_e
        sigma = math.degrees(math.acos(min(1.0, float(d @ v) / r)))
        perp = d - (d @ v) * v
        tau = math.degrees(math.atan2(abs(float(np.cross(v, [0.0, 0.0, 1.0]) @ perp)),
                                      max(float(perp[2]), 1e-12)))
        p = float(guth_index(tau, sigma))
        luminance = i_cd / a_proj
        total += luminance ** 2 * (a_proj / r ** 2) / p ** 2
    if total <= 0:
        return None
    lb = max(background_lux, 1e-6) / math.pi
    return 8.0 * math.log10(0.25 / lb * total)


def observers(droom, eye_height=EYE_HEIGHT_M, inset_m=0.5):
    """CIE 117 observer positions of a room: the middle of each wall of its bounding
    rectangle (``inset_m`` inside), seated eye height, looking along the room's axes.
    Returns [(eye (3,), view (3,)), ...] (only eyes inside the room)."""
    (ls, lt), ax = droom.size, droom.axes
    z = droom.floor_z + eye_height
    out = []
    for st, view in (((inset_m, lt / 2), ax[0]), ((ls - inset_m, lt / 2), -ax[0]),
                     ((ls / 2, inset_m), ax[1]), ((ls / 2, lt - inset_m), -ax[1])):
        xy = droom.to_world(np.array([st]))[0]
        if droom.inside(xy[None])[0]:
            out.append((np.array([xy[0], xy[1], z]), np.array([view[0], view[1], 0.0])))
    return out
