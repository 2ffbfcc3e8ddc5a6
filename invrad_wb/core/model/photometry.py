"""Luminous intensity distributions of real luminaires (EULUMDAT .ldt, IES LM-63 .ies).

IES files are read with `photompy` (PyPI: type C/B/A, multipliers, symmetries; numpy and
matplotlib are its only dependencies, both already ours); EULUMDAT files with `eulumdat-py`
(module ``pyldt``, no dependencies), because photompy 0.3.1 misreads EULUMDAT's symmetric
files (with Isym 1 it reads one C angle where the format lists Mc of them, and takes the
rest as gamma angles: our ``tests/data/photometry/lambertian.ldt`` shows it). pyldt
accepts a truncated file silently, so its result is checked here (angles, table size,
finite non-negative values). invrad keeps one regular table per file: the intensity per lumen of
luminaire output, ``I(C, gamma) / F`` in cd/lm, on 1 degree steps of the C-plane angle
(0-360) and of gamma (0-180), bilinearly interpolated, where ``F`` is the luminaire flux
the file describes (its candela integrated over the sphere: the lamp flux times the LOR).
A luminaire of flux ``F'`` emits ``F' * table``: the file gives the shape, the catalogue or
``--flux`` the output (the file's own flux when none is given).

Frame (type C photometry, the usual for indoor luminaires): gamma is the angle from the
luminaire's facing direction (its ``normal``: nadir for a downlight), C = 0 lies along the
luminaire's local x axis, which is ``u`` of :func:`invrad_wb.core.model.scene.plane_basis`
(normal) unless the luminaire gives its own, C = 90 along ``v``. A lambertian emitter has
``I / F = cos(gamma) / pi``.
"""
import os

import numpy as np

from invrad_wb.errors import LuminaireError

#: table resolution (degrees)
STEP_DEG = 1.0


class Photometry:
    """A luminaire's intensity distribution per lumen.

    Attributes
    ----------
    table : (361, 181) float64, cd/lm at C = 0..360 (rows) and gamma = 0..180 (columns)
    flux_lm : float, the luminaire flux the file describes (lm)
    path : str or None, the file it came from
    name : str
    luminous_area_m2 : float or None, area of the luminous opening (for luminance / UGR)
    luminous_extent_m : (along C0, along C90) metres of a rectangular luminous opening, or
        None (round, or not given). The C0 axis is the luminaire's local x (the frame of
        :meth:`intensity_per_lm`). IES LM-63 gives length along the 0-180 degree axis and
        width across it; EULUMDAT gives length along the luminaire's longitudinal axis,
        the C90-C270 plane in the European convention, and width across it.
    """

    def __init__(self, cd, flux_lm=None, path=None, name=None, luminous_area_m2=None,
                 luminous_extent_m=None):
        cd = np.asarray(cd, dtype=np.float64)
        if cd.shape != (361, 181) or not np.all(np.isfinite(cd)) or np.any(cd < 0):
            raise LuminaireError(f"{path or name}: intensity table must be finite, >= 0"
                                 " and 361 x 181 (C x gamma, 1 degree)")
        total = integrate(cd)
        if not total > 0:
            raise LuminaireError(f"{path or name}: the luminaire emits no light (all"
                                 " intensities are 0)")
        self.table = cd / total
        self.flux_lm = float(total if flux_lm is None else flux_lm)
        self.path = path
        self.name = name or (os.path.basename(path) if path else "photometry")
        self.luminous_area_m2 = (float(luminous_area_m2) if luminous_area_m2
                                 and luminous_area_m2 > 0 else None)
        ext = None
        if luminous_extent_m is not None:
            ext = tuple(float(x) for x in luminous_extent_m)
            if len(ext) != 2 or not all(np.isfinite(x) and x > 0 for x in ext):
                ext = None
        self.luminous_extent_m = ext

    @classmethod
    def lambertian(cls):
        """``I / F = cos(gamma) / pi`` (the model used where no file is given)."""
        g = np.radians(np.arange(181) * STEP_DEG)
        return cls(np.tile(np.maximum(np.cos(g), 0.0) / np.pi, (361, 1)), 1.0,
                   name="lambertian")

    def intensity_per_lm(self, local):
        """cd/lm towards unit directions ``local (..., 3)`` in the luminaire's frame."""
        local = np.asarray(local, dtype=np.float64)
        z = np.clip(local[..., 2], -1.0, 1.0)
        gamma = np.degrees(np.arccos(z)) / STEP_DEG
        c = np.mod(np.degrees(np.arctan2(local[..., 1], local[..., 0])), 360.0) / STEP_DEG
        g0 = np.minimum(np.floor(gamma).astype(np.int64), 179)
        c0 = np.minimum(np.floor(c).astype(np.int64), 359)
        tg, tc = gamma - g0, c - c0
        t = self.table
        return ((1 - tc) * ((1 - tg) * t[c0, g0] + tg * t[c0, g0 + 1])
                + tc * ((1 - tg) * t[c0 + 1, g0] + tg * t[c0 + 1, g0 + 1]))

    def __repr__(self):
        return f"Photometry({self.name!r}, {self.flux_lm:.0f} lm)"


#: numpy 2 names it trapezoid (trapz is deprecated there); numpy 1.x has only trapz
_trapezoid = getattr(np, "trapezoid", None) or np.trapz


def integrate(cd):
    """Flux (lm) of a (361, 181) candela table: the integral of I over the sphere
    (trapezoids in gamma with sin(gamma), in C over the 360 degrees)."""
    g = np.radians(np.arange(181) * STEP_DEG)
    ring = _trapezoid(cd[:-1] * np.sin(g), g, axis=1)      # per C plane, 0..359
    return float(np.sum(ring) * np.radians(STEP_DEG))


_CACHE = {}


def read_photometry(path):
    """Read an EULUMDAT (.ldt) or IES (.ies) file (cached by path and modification time).

    Raises
    ------
    LuminaireError
        Missing file, unknown extension, a file that does not parse, a photometry type
        other than C, no light — naming the file.
    """
    path = os.fspath(path)
    try:
        key = (os.path.abspath(path), os.stat(path).st_mtime_ns)
    except OSError as exc:
        raise LuminaireError(f"{path}: cannot read photometry: {exc.strerror}")
    if key not in _CACHE:
        _CACHE[key] = _read(path)
    return _CACHE[key]


def _read(path):
    ext = os.path.splitext(path)[1].lower()
    if ext not in (".ldt", ".ies"):
        raise LuminaireError(f"{path}: photometry must be an EULUMDAT .ldt or IES .ies file")
    try:
        import photompy
    except ImportError:
        raise LuminaireError(f"{path}: reading photometry needs photompy"
                             " (pip install photompy, or make setup)")
    if ext == ".ldt":
        return _read_ldt(path)
    import warnings
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            f = photompy.IESFile.read(path)
            phot = f.photometry
            if int(phot.photometric_type) != int(photompy.PhotometricType.C):
                raise LuminaireError(f"{path}: photometry type {phot.photometric_type.name}"
                                     " is not supported (only type C, the indoor kind)")
            grid = phot.interpolated(181, 361)
    except LuminaireError:
        raise
    except Exception as exc:       # the library's own errors: one line naming the file
        raise LuminaireError(f"{path}: not a valid {ext[1:].upper()} file"
                             f" ({type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else 'no detail'})")
    cd = np.asarray(grid.values, dtype=np.float64)        # (361 phis, 181 thetas)
    h = f.header
    to_m = 0.3048 if int(getattr(h.units, "value", h.units)) == 1 else 1.0   # 1: feet
    width, length = float(h.width), float(h.length)
    area = abs(width * length) * to_m ** 2
    # LM-63: negative dimensions describe round and elliptical openings
    extent = (length * to_m, width * to_m) if width > 0 and length > 0 else None
    return Photometry(np.nan_to_num(cd), path=path, luminous_area_m2=area,
                      luminous_extent_m=extent)


def _read_ldt(path):
    try:
        from pyldt import LdtReader
    except ImportError:
        raise LuminaireError(f"{path}: reading EULUMDAT needs eulumdat-py"
                             " (pip install eulumdat-py, or make setup)")
    try:
        ldt = LdtReader.read(path)
    except Exception as exc:
        raise LuminaireError(f"{path}: not a valid EULUMDAT file ({type(exc).__name__}:"
                             f" {str(exc).splitlines()[0] if str(exc) else 'no detail'})")
    h = ldt.header
    c = np.asarray(h.c_angles, dtype=np.float64)
    g = np.asarray(h.g_angles, dtype=np.float64)
    try:
        v = np.asarray(ldt.intensities, dtype=np.float64)
    except ValueError:
        v = np.zeros(0)
    if (h.mc < 1 or h.ng < 2 or len(c) != h.mc or len(g) != h.ng or v.shape != (h.mc, h.ng)
            or not np.all(np.isfinite(v)) or np.any(v < 0)
            or np.any(np.diff(g) <= 0) or np.any(np.diff(c) <= 0)):
        raise LuminaireError(f"{path}: not a valid EULUMDAT file (truncated or"
                             f" inconsistent: {h.mc} C planes x {h.ng} gamma angles declared,"
                             f" {v.shape} values read)")
    lamp_lm = float(np.dot(h.lamp_flux, h.num_lamps)) if h.lamp_flux else 1000.0
    cd = resample(c, g, v * lamp_lm / 1000.0)       # cd/klm of lamp flux -> candela
    a, b = float(h.length_lum_area) / 1000.0, float(h.width_lum_area) / 1000.0   # mm
    area = a * b if b > 0 else np.pi * a * a / 4.0         # width 0: round, diameter a
    # length along the longitudinal axis (C90-C270), width along C0-C180
    extent = (b, a) if a > 0 and b > 0 else None
    return Photometry(cd, path=path, luminous_area_m2=area, luminous_extent_m=extent)


def resample(c_deg, g_deg, cd):
    """Bilinear resampling of an intensity table (C planes x gamma angles, C periodic over
    360 degrees, 0 beyond the last gamma) onto the 1 degree (361, 181) grid."""
    cq = np.arange(361) * STEP_DEG
    gq = np.arange(181) * STEP_DEG
    cc = np.concatenate([c_deg, [c_deg[0] + 360.0]])
    vv = np.concatenate([cd, cd[:1]], axis=0)
    if len(c_deg) == 1:
        cc, vv = np.array([0.0, 360.0]), np.concatenate([cd, cd], axis=0)
    rows = np.array([np.interp(gq, g_deg, row, right=0.0) for row in vv])
    return np.array([np.interp(np.mod(cq - cc[0], 360.0) + cc[0], cc, rows[:, j])
                     for j in range(len(gq))]).T
