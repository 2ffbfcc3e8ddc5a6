"""Luminaires: lambertian point and disk emitters with a flux in lumens.

A lambertian luminaire of flux ``F`` (lm) facing ``n`` has the intensity
``I(theta) = (F / pi) * cos(theta)`` (cd) and gives the illuminance
``E = F * cos(theta_l) * cos(theta_s) / (pi * r^2)`` (lx) at a point at distance ``r``.
A disk luminaire of radius ``R`` is a lambertian disk of uniform luminance; it is integrated
with a fixed quadrature (Gauss-Legendre rings in ``r^2`` times equally spaced angles).

JSON form (``LUMS.json``, also the ``luminaires`` list of a locate result)::

    {"luminaires": [{"position": [x, y, z], "normal": [x, y, z],
                     "flux_lm": F, "radius_m": r, "photometry": "dl.ldt"}]}

``photometry`` (optional, relative to the JSON file's folder): an EULUMDAT or IES file whose
intensity distribution replaces the lambertian one (the flux still scales it).
"""
from dataclasses import dataclass, field
import functools
import json
import math
import os

import numpy as np

from invrad_wb import constants as C
from invrad_wb.errors import LuminaireError


@dataclass
class Luminaire:
    """One lambertian luminaire.

    Attributes
    ----------
    position : (3,) float64, metres
    normal : (3,) float64, unit facing direction
    flux_lm : float, lumens
    radius_m : float, metres (0 = point emitter)
    room : int or None
    score : float or None
        How much this luminaire lowers the locate cost (locate results only).
    photometry : Photometry or None
        Its intensity distribution (:mod:`invrad_wb.core.model.photometry`); None:
        lambertian. The flux scales the distribution.
    c0 : (3,) float64 or None
        The C = 0 axis of its photometry (an aimed luminaire: its mounted C = 0 carried by
        the tilt, :mod:`invrad_wb.core.model.aiming`); None: ``plane_basis(normal)``.
    """

    position: np.ndarray
    normal: np.ndarray
    flux_lm: float
    radius_m: float = 0.0
    room: int = None
    score: float = None
    extra: dict = field(default_factory=dict)
    photometry: object = None
    c0: object = None

    def __post_init__(self):
        self.position = np.asarray(self.position, dtype=np.float64).reshape(3)
        n = np.asarray(self.normal, dtype=np.float64).reshape(3)
        self.normal = n / np.linalg.norm(n)
        if self.c0 is not None:
            self.c0 = np.asarray(self.c0, dtype=np.float64).reshape(3)

    def to_dict(self):
        d = {"position": [round(float(x), 6) for x in self.position],
             "normal": [round(float(x), 6) for x in self.normal],
             "flux_lm": float(self.flux_lm), "radius_m": float(self.radius_m)}
        if self.room is not None:
            d["room"] = int(self.room)
        if self.score is not None:
            d["score"] = float(self.score)
        if self.c0 is not None:
            d["c0"] = [round(float(x), 6) for x in self.c0]
        d.update(self.extra)
        if self.photometry is not None and getattr(self.photometry, "path", None):
            d["photometry"] = self.photometry.path
        return d


def _vec3(value, what):
    try:
        a = np.asarray(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise LuminaireError(f"{what} must be three numbers, got {value!r}")
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise LuminaireError(f"{what} must be three finite numbers, got {value!r}")
    return a


def luminaire_from_dict(d, where="luminaire", base_dir=None):
    """Build and check a :class:`Luminaire` from its JSON dict."""
    if not isinstance(d, dict):
        raise LuminaireError(f"{where} must be an object, got {d!r}")
    for key in ("position", "flux_lm"):
        if key not in d:
            raise LuminaireError(f"{where} has no '{key}'")
    pos = _vec3(d["position"], f"{where}.position")
    nrm = _vec3(d.get("normal", [0, 0, -1]), f"{where}.normal")
    if np.linalg.norm(nrm) < 1e-9:
        raise LuminaireError(f"{where}.normal is the zero vector")
    for key in ("flux_lm", "radius_m"):
        if isinstance(d.get(key), bool):      # float(True) is 1.0: never what was meant
            raise LuminaireError(f"{where}.{key} is {str(d[key]).lower()}: must be a number")
    try:
        flux = float(d["flux_lm"])
        radius = float(d.get("radius_m", 0.0))
    except (TypeError, ValueError):
        raise LuminaireError(f"{where}: flux_lm and radius_m must be numbers")
    if not np.isfinite(flux) or flux <= 0:
        raise LuminaireError(f"{where}.flux_lm is {d['flux_lm']!r}: must be a positive number"
                             " of lumens")
    if not np.isfinite(radius) or radius < 0:
        raise LuminaireError(f"{where}.radius_m is {d.get('radius_m')!r}: must be >= 0 metres")
    c0 = None
    if d.get("c0") is not None:
        c0 = _vec3(d["c0"], f"{where}.c0")
        if np.linalg.norm(np.cross(c0, nrm)) < 1e-6 * np.linalg.norm(nrm) * max(
                np.linalg.norm(c0), 1e-300):
            raise LuminaireError(f"{where}.c0 must not be parallel to its normal (it is the"
                                 " photometry's C = 0 axis)")
    known = {"position", "normal", "flux_lm", "radius_m", "room", "score", "photometry",
             "c0"}
    extra = {k: v for k, v in d.items() if k not in known}
    phot = None
    if d.get("photometry") is not None:
        from invrad_wb.core.model.photometry import read_photometry
        f = d["photometry"]
        if not isinstance(f, str):
            raise LuminaireError(f"{where}.photometry must be a file name, got {f!r}")
        phot = read_photometry(f if os.path.isabs(f) or base_dir is None
                               else os.path.join(base_dir, f))
    return Luminaire(pos, nrm, flux, radius, room=d.get("room"), score=d.get("score"),
                     extra=extra, photometry=phot, c0=c0)


def _space_of(scene, real, room):
    """(faces mask, name) of the space a luminaire of ``room`` is in: its room's faces,
    else (no room, an unknown one) the scene's."""
    if room is not None and not isinstance(room, bool):
        try:
            in_room = real & (scene.face_room == int(room))
            if in_room.any():
                return in_room, f"room {room}"
        except (TypeError, ValueError):
            pass
    return real, "the scene"


def _support_points(pts):
    """The points that can be the farthest along any direction: the convex hull's vertices
    (all points where the hull is flat or degenerate)."""
    if len(pts) > 16:
        try:
            from scipy.spatial import ConvexHull
            return pts[ConvexHull(pts).vertices]
        except Exception:        # coplanar or too few points (QhullError): keep them all
            pass
    return pts


#: bytes of one block of the support-point x luminaire products in placement_problems
_PLACEMENT_BLOCK_BYTES = 32 << 20


def placement_problems(scene, luminaires, names=None):
    """What is physically wrong with luminaires placed in a scene.

    Luminaires are checked per space (room or scene) in blocks: the cost grows with
    luminaires x hull vertices, not luminaires x mesh vertices (100,000 luminaires in a
    room take about a second).

    Returns
    -------
    errors : list of str
        A disk larger than the space it is in (its room, else the scene).
    warnings : list of str
        A luminaire outside the box of its room (of the scene when it names no room), or
        facing away from every surface of it (it lights nothing there).
    """
    names = names or [f"luminaires[{i}]" for i in range(len(luminaires))]
    errors, warnings = [], []
    if not len(luminaires):
        return errors, warnings
    real = ~np.asarray(getattr(scene, "face_virtual", np.zeros(len(scene.faces), bool)))
    groups = {}
    for i, lum in enumerate(luminaires):
        key = lum.room if lum.room is None or isinstance(lum.room, (bool, int, np.integer)) \
            else repr(lum.room)
        groups.setdefault(key, []).append(i)
    tol = 0.02
    for key, idx in groups.items():
        sel, where = _space_of(scene, real, luminaires[idx[0]].room)
        pts = scene.vertices[np.unique(scene.faces[sel])]
        if not len(pts):
            continue
        lo, hi = pts.min(0), pts.max(0)
        across = float(np.max(hi - lo))
        support = _support_points(pts)
        idx = np.asarray(idx)
        P = np.array([luminaires[i].position for i in idx], dtype=np.float64).reshape(-1, 3)
        N = np.array([luminaires[i].normal for i in idx], dtype=np.float64).reshape(-1, 3)
        N = N / np.linalg.norm(N, axis=1, keepdims=True)
        R = np.array([luminaires[i].radius_m for i in idx], dtype=np.float64)
        outside = np.any(P < lo - tol, axis=1) | np.any(P > hi + tol, axis=1)
        away = np.zeros(len(idx), bool)
        block = max(1, _PLACEMENT_BLOCK_BYTES // (8 * len(support)))
        for a in range(0, len(idx), block):
            far = (support @ N[a:a + block].T).max(axis=0)       # farthest surface along n
            away[a:a + block] = far - np.einsum("ij,ij->i", P[a:a + block],
                                                N[a:a + block]) <= 1e-3
        for j in np.flatnonzero(R > across):
            errors.append((idx[j], f"{names[idx[j]]}.radius_m {R[j]:g} m is larger than"
                                   f" {where} ({across:.2f} m across)"))
        for j in np.flatnonzero(outside | away):
            p, name = P[j], names[idx[j]]
            if outside[j]:
                warnings.append((idx[j], f"{name} at ({p[0]:.2f}, {p[1]:.2f}, {p[2]:.2f}) is"
                                         f" outside {where} ({lo[0]:.2f}..{hi[0]:.2f},"
                                         f" {lo[1]:.2f}..{hi[1]:.2f}, {lo[2]:.2f}..{hi[2]:.2f}"
                                         " m): check its position and units"))
            else:
                warnings.append((idx[j], f"{name} at ({p[0]:.2f}, {p[1]:.2f}, {p[2]:.2f})"
                                         f" faces away from every surface of {where} (normal"
                                         f" {N[j].round(3).tolist()}): it lights nothing"
                                         " there"))
    return ([m for _, m in sorted(errors, key=lambda t: t[0])],
            [m for _, m in sorted(warnings, key=lambda t: t[0])])


def load_luminaires(path):
    """Read ``{"luminaires": [...]}`` from a JSON file; errors name the file and entry."""
    try:
        with open(path, "r", encoding="utf-8") as fh:
            data = json.load(fh)
    except OSError as exc:
        raise LuminaireError(f"{path}: cannot read: {exc.strerror}")
    except json.JSONDecodeError as exc:
        raise LuminaireError(f"{path}: not valid JSON: {exc}")
    except UnicodeDecodeError as exc:
        raise LuminaireError(f"{path}: not UTF-8 text (byte {exc.start}): not a JSON file")
    except RecursionError:
        raise LuminaireError(f"{path}: JSON nested too deeply")
    if isinstance(data, dict):
        items = data.get("luminaires")
    else:
        items = data
    if not isinstance(items, list):
        raise LuminaireError(f"{path}: expected {{\"luminaires\": [...]}}")
    try:
        base = os.path.dirname(os.path.abspath(path))
        return [luminaire_from_dict(d, f"luminaires[{i}]", base) for i, d in enumerate(items)]
    except LuminaireError as exc:
        raise LuminaireError(f"{path}: {exc}")


def disk_quadrature(rings=C.DISK_RINGS, angles=C.DISK_ANGLES):
    """Unit-disk quadrature: points (k, 2) and weights (k,) summing to 1.

    Gauss-Legendre in ``s = r^2`` (area-uniform) times equally spaced, ring-staggered angles:
    exact for polynomials in ``r^2`` of degree ``2*rings-1`` times trigonometric polynomials
    of degree ``angles-1``. Computed once per (rings, angles): read-only arrays (it was
    3.5 s of a 1000-luminaire render, called twice per luminaire).
    """
    return _disk_quadrature(int(rings), int(angles))


@functools.lru_cache(maxsize=8)
def _disk_quadrature(rings, angles):
    x, w = np.polynomial.legendre.leggauss(rings)
    s = 0.5 * (x + 1.0)
    r = np.sqrt(s)
    pts, wts = [], []
    for i in range(rings):
        phi = 2 * np.pi * (np.arange(angles) + 0.5 * (i % 2)) / angles
        pts.append(np.stack([r[i] * np.cos(phi), r[i] * np.sin(phi)], axis=1))
        wts.append(np.full(angles, 0.5 * w[i] / angles))
    pts, wts = np.concatenate(pts), np.concatenate(wts)
    pts.flags.writeable = False
    wts.flags.writeable = False
    return pts, wts


def emitter_samples(luminaires):
    """Point emitters that together represent the luminaires.

    Returns
    -------
    positions : (k, 3) float64, metres
    normals : (k, 3) float64
    flux : (k,) float64, lumens of each sample (sums to each luminaire's flux)
    owner : (k,) int64, index of the luminaire of each sample
    """
    pos, nrm, flux, owner = [], [], [], []
    qp, qw = disk_quadrature()
    for i, lum in enumerate(luminaires):
        if lum.radius_m > 0:
            from invrad_wb.core.model.scene import plane_basis
            u, v = plane_basis(lum.normal)
            p = lum.position + lum.radius_m * (qp[:, :1] * u + qp[:, 1:] * v)
            pos.append(p)
            nrm.append(np.repeat(lum.normal[None], len(p), 0))
            flux.append(lum.flux_lm * qw)
            owner.append(np.full(len(p), i))
        else:
            pos.append(lum.position[None])
            nrm.append(lum.normal[None])
            flux.append(np.array([lum.flux_lm]))
            owner.append(np.array([i]))
    if not pos:
        return (np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0), np.zeros(0, dtype=np.int64))
    return (np.concatenate(pos), np.concatenate(nrm), np.concatenate(flux),
            np.concatenate(owner).astype(np.int64))


def luminous_area(lum):
    """The luminous area (m^2) of a luminaire: its disk's, else its photometry file's
    luminous opening; None when it has neither (a point source: no glare figure)."""
    if lum.radius_m > 0:
        return math.pi * lum.radius_m ** 2
    phot = getattr(lum, "photometry", None)
    return getattr(phot, "luminous_area_m2", None) if phot is not None else None
