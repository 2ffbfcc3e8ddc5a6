"""Luminous openings in the design's light: a luminaire's opening as point emitters, and the
surfaces behind it (the ceiling a panel covers is luminaire, not ceiling: it reflects as
the opening does and is no receiver of a calculation grid)."""
import math
from dataclasses import replace

import numpy as np

from invrad_wb.core.model.aiming import photometric_frame


#: Gauss-Legendre abscissa of the 2-point rule on [-1/2, 1/2]
_GAUSS2 = 0.5 / math.sqrt(3.0)


def opening_quadrature(photometry):
    """Points (q, 2) metres along (C0, C90) and weights (q,) summing to 1 over the luminous
    opening of a photometry file: the 2 x 2 Gauss-Legendre rule on its rectangle (a round
    opening, given by its area only: on the square of that area); one point at the centre
    where the file gives no opening.

    Radiance (ies2rad) and DIALux emit a photometry file's light from its luminous opening,
    each part with the file's intensity distribution scaled by its share of the area; a
    point source at the centre overstates the light straight below a 0.6 m panel by 3 % at
    2 m (9 % at 1 m), and the rule leaves 0.03 % (0.4 % at 1 m)."""
    ext = getattr(photometry, "luminous_extent_m", None) if photometry is not None else None
    if not ext:
        area = getattr(photometry, "luminous_area_m2", None) if photometry is not None else None
        if not area:
            return np.zeros((1, 2)), np.ones(1)
        ext = (math.sqrt(area), math.sqrt(area))
    a, b = _GAUSS2 * ext[0], _GAUSS2 * ext[1]
    return np.array([[-a, -b], [a, -b], [-a, b], [a, b]]), np.full(4, 0.25)


def luminous_samples(luminaires):
    """The luminaires as point emitters for direct light: a photometric luminaire with a
    luminous opening becomes the points of :func:`opening_quadrature` (same photometry and
    C0, its flux shared by the weights); the others are kept as they are (a disk is
    integrated by the direct-light code itself)."""
    out = []
    for lum in luminaires:
        ph = getattr(lum, "photometry", None)
        qp, qw = (np.zeros((1, 2)), np.ones(1)) if lum.radius_m > 0 or ph is None \
            else opening_quadrature(ph)
        if len(qw) == 1:
            out.append(lum)
            continue
        u, v = photometric_frame(lum.normal, lum.c0)
        out += [replace(lum, position=lum.position + q[0] * u + q[1] * v,
                        flux_lm=lum.flux_lm * w, c0=u) for q, w in zip(qp, qw)]
    return out


#: reflectance of a luminaire's luminous opening in the interreflection: light falling on
#: it enters the luminaire (diffuser, louvre, optic) rather than being reflected like the
#: ceiling around it (Radiance's light polygons reflect nothing either)
OPENING_REFLECTANCE = 0.0
#: a surface within this distance of an opening's plane, facing the same way, lies behind it
_BEHIND_M = 0.05
#: sample points per mesh triangle for the share of it an opening covers
_COVER_SAMPLES = np.array([[1 / 3, 1 / 3, 1 / 3], [2 / 3, 1 / 6, 1 / 6], [1 / 6, 2 / 3, 1 / 6],
                           [1 / 6, 1 / 6, 2 / 3], [0.5, 0.5, 0.0], [0.0, 0.5, 0.5],
                           [0.5, 0.0, 0.5]])


def opening_half_sides(lum):
    """(half along C0, half along C90) metres of a luminaire's luminous opening, or None
    (a point source: no opening; a disk as the square of its area)."""
    return half_sides(lum.radius_m, getattr(lum, "photometry", None))


def half_sides(radius_m, ph):
    """:func:`opening_half_sides` of a disk of ``radius_m`` (> 0) or of a photometry."""
    if radius_m > 0:
        h = 0.5 * math.sqrt(math.pi) * radius_m
        return h, h
    ext = getattr(ph, "luminous_extent_m", None) if ph is not None else None
    if ext:
        return 0.5 * ext[0], 0.5 * ext[1]
    area = getattr(ph, "luminous_area_m2", None) if ph is not None else None
    return (0.5 * math.sqrt(area),) * 2 if area else None


def covered_share(triangles, normals, luminaires, reach=None):
    """(T,) share of each triangle (T, 3, 3) that lies behind a luminous opening (within
    ``_BEHIND_M`` of its plane, facing the way it faces, inside its rectangle).
    ``reach``: :func:`triangle_reach` of ``triangles`` where the caller keeps it."""
    out = np.zeros(len(triangles))
    if len(triangles) == 0:
        return out
    # only triangles that can reach the opening are tested (same answer: a sample inside
    # the opening's box lies within the triangle's radius of its centroid)
    cen, reach = triangle_reach(triangles) if reach is None else reach
    for lum in luminaires:
        half = opening_half_sides(lum)
        if half is None:
            continue
        u, v = photometric_frame(lum.normal, lum.c0)
        lim = math.hypot(half[0], half[1], _BEHIND_M) + 1e-9
        off = cen - lum.position
        sel = np.flatnonzero((np.einsum("ti,ti->t", off, off) <= (lim + reach) ** 2)
                             & (normals @ lum.normal > 0.9))
        if len(sel) == 0:
            continue
        d = np.einsum("sj,tjk->tsk", _COVER_SAMPLES, triangles[sel]) - lum.position
        near = ((np.abs(d @ lum.normal) < _BEHIND_M)
                & (np.abs(d @ u) <= half[0]) & (np.abs(d @ v) <= half[1]))
        out[sel] = np.maximum(out[sel], near.mean(axis=1))
    return out


def triangle_reach(triangles):
    """(centroids (T, 3), radii (T,)) of triangles (T, 3, 3): each corner's farthest."""
    cen = triangles.mean(axis=1)
    return cen, np.sqrt(np.max(np.sum((triangles - cen[:, None]) ** 2, axis=2), axis=1))


def behind_openings(points, normals, luminaires):
    """(k,) bool: receivers that lie behind a luminous opening (within ``_BEHIND_M`` of its
    plane, facing the way it faces, inside its rectangle): a spot of the ceiling there is
    the luminaire, not ceiling (a calculation grid of the ceiling leaves it out, as
    Radiance's opaque light polygon does)."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    normals = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    out = np.zeros(len(points), dtype=bool)
    for lum in luminaires:
        half = opening_half_sides(lum)
        if half is None:
            continue
        u, v = photometric_frame(lum.normal, lum.c0)
        d = points - lum.position
        out |= ((normals @ lum.normal > 0.9) & (np.abs(d @ lum.normal) < _BEHIND_M)
                & (np.abs(d @ u) <= half[0] + 1e-9) & (np.abs(d @ v) <= half[1] + 1e-9))
    return out
