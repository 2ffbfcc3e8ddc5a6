"""Discomfort glare: the unified glare rating of CIE 117 (formula method).

    UGR = 8 log10( 0.25 / Lb * sum_k L_k^2 omega_k / p_k^2 )

``L_k`` (cd/m^2) is luminaire k's luminance towards the eye (its intensity towards the eye
over its luminous area projected on that direction), ``omega_k`` (sr) that projected area
over the squared distance, ``p_k`` the Guth position index of its direction relative to the
line of sight, and ``Lb`` (cd/m^2) the background luminance: the indirect illuminance at the
eye (a vertical plane facing the view) over pi. Only luminaires above the eye and in front
of it (within the half space the observer faces) count, and of those only what the observer
sees: a caller that knows the room's walls and obstacles gives the seen share of each
luminous area (``seen``; :func:`invrad_wb.core.design.roomglare.seen_shares`). The Guth
index uses the usual fit
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
from invrad_wb.core.model.aiming import photometric_frame

#: seated observer's eye height (metres), CIE 117 / EN 12464-1
EYE_HEIGHT_M = 1.2
#: CIE 147 small source: projected luminous areas below this (m^2) count as this
SMALL_SOURCE_M2 = 0.005


def guth_index(tau_deg, sigma_deg):
    """Guth position index p (>= 1) for angles in degrees (arrays broadcast)."""
    t = np.asarray(tau_deg, dtype=np.float64)
    s = np.asarray(sigma_deg, dtype=np.float64)
    ln_p = ((35.2 - 0.31889 * t - 1.22 * np.exp(-2.0 * t / 9.0)) * 1e-3 * s
            + (21.0 + 0.26667 * t - 0.002963 * t * t) * 1e-5 * s * s)
    return np.exp(ln_p)


def is_small_source(lum):
    """True where UGR rates the luminaire by the CIE 147 small-source rule (no luminous
    area, or one below ``SMALL_SOURCE_M2``)."""
    area = luminous_area(lum)
    return area is None or area < SMALL_SOURCE_M2


def ugr(luminaires, eye, view, background_lux, seen=None):
    """UGR of luminaires seen from ``eye`` (3,) looking along horizontal ``view`` (3,).

    Parameters
    ----------
    luminaires : list of Luminaire (a luminous area: a disk radius or a photometry file's
        luminous opening; without one, or below ``SMALL_SOURCE_M2`` projected: the CIE 147
        small-source rule)
    background_lux : float, indirect illuminance at the eye on a plane facing the view (lx)
    seen : (L,) float or None, the share of each luminaire's luminous area the eye sees
        past walls and obstacles (0: hidden; None: all wholly seen, a convex room). CIE
        117's sum runs over what the observer sees: a luminaire partly hidden counts with
        its luminance and the seen share of its solid angle (its term times the share).

    Returns
    -------
    float or None: None when no luminaire is in view (no glare)
    """
    eye = np.asarray(eye, dtype=np.float64)
    v = np.asarray(view, dtype=np.float64)
    v = v / np.linalg.norm(v)
    total = 0.0
    for k, lum in enumerate(luminaires):
        share = 1.0 if seen is None else float(seen[k])
        if share <= 0.0:
            continue                      # hidden by a wall or an obstacle
        area = luminous_area(lum)
        d = lum.position - eye
        r = float(np.linalg.norm(d))
        if r < 1e-6 or d[2] <= 0 or d @ v <= 0:
            continue
        to_eye = -d / r
        cos_e = float(to_eye @ lum.normal)
        if cos_e <= 1e-6:
            continue                      # the eye is behind the luminous area
        if getattr(lum, "photometry", None) is not None:
            u, w = photometric_frame(lum.normal, getattr(lum, "c0", None))
            i_cd = lum.flux_lm * float(lum.photometry.intensity_per_lm(
                np.array([to_eye @ u, to_eye @ w, cos_e])))
        else:
            i_cd = lum.flux_lm / math.pi * cos_e
        a_proj = max(SMALL_SOURCE_M2 if area is None else area * cos_e, SMALL_SOURCE_M2)
        sigma = math.degrees(math.acos(min(1.0, float(d @ v) / r)))
        perp = d - (d @ v) * v
        tau = math.degrees(math.atan2(abs(float(np.cross(v, [0.0, 0.0, 1.0]) @ perp)),
                                      max(float(perp[2]), 1e-12)))
        p = float(guth_index(tau, sigma))
        luminance = i_cd / a_proj
        total += share * luminance ** 2 * (a_proj / r ** 2) / p ** 2
    if total <= 0:
        return None
    lb = max(background_lux, 1e-6) / math.pi
    return 8.0 * math.log10(0.25 / lb * total)


def unit_glare(eye, view, positions, normals, area_m2=None, photometry=None, c0=None,
               seen=None):
    """Vectorised glare terms of luminaires of one type at unit flux: ``(L,)`` values of
    ``L^2 omega / p^2`` per lm^2 (a luminaire of flux F adds ``F^2`` times its term to the
    sum of :func:`ugr`), 0 for those the observer does not see (behind, below the eye,
    facing away). Same rules as :func:`ugr` (which it is tested against).

    Parameters
    ----------
    eye, view : (3,) float64, eye position (m) and horizontal line of sight
    positions, normals : (L, 3) float64, luminaire centres (m) and facing directions
    area_m2 : float or None, luminous area (None: a small source)
    photometry : object with ``intensity_per_lm(local_dirs)`` or None (lambertian)
    c0 : (3,) float64 or None, the C = 0 direction of every luminaire (None: the frame of
        its normal, :func:`~invrad_wb.core.model.aiming.photometric_frame`)
    seen : (L,) float64 or None, the share of each luminous area the eye sees (:func:`ugr`)
    """
    share = None if seen is None else np.asarray(seen, dtype=np.float64).reshape(-1)
    eye = np.asarray(eye, dtype=np.float64)
    v = np.asarray(view, dtype=np.float64)
    v = v / np.linalg.norm(v)
    P = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    N = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    out = np.zeros(len(P))
    d = P - eye
    r = np.linalg.norm(d, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        to_eye = -d / r[:, None]
        cos_e = np.einsum("ij,ij->i", to_eye, N)
        seen = (r > 1e-6) & (d[:, 2] > 0) & (d @ v > 0) & (cos_e > 1e-6)
    if not seen.any():
        return out
    d, r, to_eye, cos_e, N = d[seen], r[seen], to_eye[seen], cos_e[seen], N[seen]
    if photometry is not None:
        i_lm = np.zeros(len(d))
        for key in np.unique(np.round(N, 9), axis=0):
            rows = np.flatnonzero(np.all(np.abs(N - key) < 1e-8, axis=1))
            u, w = photometric_frame(N[rows[0]], c0)
            local = np.stack([to_eye[rows] @ u, to_eye[rows] @ w, cos_e[rows]], -1)
            i_lm[rows] = photometry.intensity_per_lm(local)
    else:
        i_lm = cos_e / math.pi
    a_proj = np.maximum(SMALL_SOURCE_M2 if area_m2 is None else area_m2 * cos_e,
                        SMALL_SOURCE_M2)
    sigma = np.degrees(np.arccos(np.clip((d @ v) / r, -1.0, 1.0)))
    perp = d - np.outer(d @ v, v)
    side = np.abs(perp @ np.cross(v, [0.0, 0.0, 1.0]))
    tau = np.degrees(np.arctan2(side, np.maximum(perp[:, 2], 1e-12)))
    p = guth_index(tau, sigma)
    luminance = i_lm / a_proj
    out[seen] = luminance ** 2 * (a_proj / r ** 2) / p ** 2
    return out if share is None else out * share


def ugr_from_sum(total, background_lux):
    """UGR from the sum of ``L^2 omega / p^2`` and the background illuminance (lx)
    (arrays broadcast; NaN where nothing is in view)."""
    total = np.asarray(total, dtype=np.float64)
    lb = np.maximum(np.asarray(background_lux, dtype=np.float64), 1e-6) / math.pi
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(total > 0, 8.0 * np.log10(0.25 / lb * np.maximum(total, 1e-300)),
                        np.nan)


def observers(droom, eye_height=EYE_HEIGHT_M, inset_m=0.5):
    """CIE 117 observer positions of a room: the middle of each wall of its bounding
    rectangle (``inset_m`` inside), seated eye height, looking along the room's axes.

    In a room that is not a rectangle (an L) the middle of a side of the bounding
    rectangle may fall outside the floor or on a wall of the inner corner (an eye in the
    wall, which sees half the room). Such an eye moves along its line, ``inset_m`` from
    its side, to the middle of the longest stretch of that line that keeps ``inset_m``
    from every wall: the middle of the wall that is really there. Returns
    [(eye (3,), view (3,)), ...] (sides with no such stretch give no observer)."""
    (ls, lt), ax = droom.size, droom.axes
    z = droom.floor_z + eye_height
    out = []
    for (s0, t0), along, view in (((inset_m, lt / 2), 1, ax[0]),
                                  ((ls - inset_m, lt / 2), 1, -ax[0]),
                                  ((ls / 2, inset_m), 0, ax[1]),
                                  ((ls / 2, lt - inset_m), 0, -ax[1])):
        st = np.array([s0, t0], dtype=np.float64)
        xy = droom.to_world(st[None])[0]
        if droom.wall_distance(xy[None])[0] < inset_m - 1e-6:
            xy = _clear_middle(droom, st, along, inset_m)
            if xy is None:
                continue
        out.append((np.array([xy[0], xy[1], z]), np.array([view[0], view[1], 0.0])))
    return out


#: spacing (metres) at which an observer's line is searched for its clear stretches
_OBSERVER_STEP_M = 0.02


def _clear_middle(droom, st, along, inset_m):
    """World XY of the middle of the longest stretch of the plan line through ``st``
    along axis ``along`` (0: s, 1: t) that keeps ``inset_m`` from every wall; None."""
    length = float(droom.size[along])
    n = max(int(np.ceil(length / _OBSERVER_STEP_M)), 2) + 1
    u = np.linspace(0.0, length, n)
    pts = np.tile(st, (n, 1))
    pts[:, along] = u
    xy = droom.to_world(pts)
    clear = droom.wall_distance(xy) >= inset_m - 1e-6
    if not clear.any():
        return None
    # runs of clear samples: (start, end) indices, the longest kept
    edges = np.diff(np.r_[0, clear.astype(np.int8), 0])
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    k = int(np.argmax(u[ends] - u[starts]))
    mid = pts[0].copy()
    mid[along] = 0.5 * (u[starts[k]] + u[ends[k]])
    return droom.to_world(mid[None])[0]
