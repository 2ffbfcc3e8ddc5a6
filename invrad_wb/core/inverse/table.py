"""The precomputed voting table (thesis 4.1.1.2): loading, checking and looking up votes.

One vote = a voting point at distance ``h`` in front of a luminaire plane, with an angle
``alpha`` between its normal ``m`` and the plane's normal ``n`` and a per-lumen illuminance
``e = E / F`` (lx/lm). Its answer is the set of luminaire positions on the plane that give
``e``: a deformed ellipse around the maximum of the distribution. Conventions (the plane
frame ``w``, ``v = n x w``, the foot point, ``beta``) are those of
:mod:`invrad_wb.core.inverse.formfactor`.

What is stored (``tables/voting_table.npz``, made by ``tables/make_voting_table.py``)
-------------------------------------------------------------------------------------
The table is stored at unit distance ``h = 1`` only: the distribution obeys
``e(h, alpha, x, y) = e(1, alpha, x/h, y/h) / h^2`` exactly, so the thesis' distance axis
(0.1-10 m) is a multiplication and there is no distance limit.

* Angle axis, ``A`` entries: ``angles[i] = (i + 1) * angle_step`` (rad), ``i = 0..A-1``; with
  the default step of 1 degree ``angles = 1, 2, ..., 180`` degrees. Below the first angle
  the maximum lies more than 57 h away on the plane and the vote is declined.
* Level axis, ``L`` entries: ``lam[j] = j * lam_step``, ``q[j] = exp(-lam[j]^2)`` where
  ``q = e / e_max`` is the level as a fraction of the maximum. ``q[0] = 1`` (the contour
  is the maximum itself: all parameters 0) down to ``q[L-1] = q_min`` (default 1e-4). The
  coordinate ``lam = sqrt(ln(1/q))`` is used because ``a, b`` grow like ``sqrt(1 - q)`` near
  the maximum (linear in ``lam``) and like ``q^(-1/4)`` far from it (smooth in ``lam``), so
  linear interpolation is accurate at both ends; the spacing is finer than the thesis'
  250 steps everywhere.
* Per angle (float64 ``(A,)``; float32 ``angle_info (A, 4)`` = these four columns):
  ``e_max`` (lx/lm at h = 1), ``x_max`` (in units of h), ``rotation`` (rad), ``r_max =
  sqrt(1 + x_max^2)`` (distance from the voting point to the maximum, units of h). All have
  closed forms (:func:`invrad_wb.core.inverse.formfactor.maximum_closed_form`); :meth:`lookup`
  evaluates them exactly rather than interpolating.
* ``params`` float32 ``(A, L, 5)``, C order: ``params[i, j, :] = (a, b, d, x_m, y_m)`` with
  lengths in units of ``h * r_max[i]``; flat index ``(i * L + j) * 5 + p``. Scaling by the
  distance to the maximum (not by ``h``) keeps the entries smooth as ``alpha -> 0``,
  where all lengths grow like ``1/alpha``.
* ``fit_error`` float32 ``(A, L)``: largest distance between the stored ellipse and the
  true contour, relative to the contour's equivalent radius ``sqrt(area/pi)`` (see
  :func:`invrad_wb.core.inverse.tablefit.geometric_error`); ``fit_error_mean`` the mean;
  ``r_eq`` float32 ``(A, L)`` that radius in units of ``h * r_max``. ``fit_error[:, 0] = 0``.

Lookup (what the vote kernel must reproduce; :meth:`VotingTable.lookup` is its numpy twin)
--------------------------------------------------------------------------------------------
Declined (invalid): ``h <= 0``, ``e <= 0``, ``alpha < angles[0]``, ``alpha > pi``,
``e > e_max(h, alpha) (1 + 1e-9)``, ``q < q_min``, non-finite input. Otherwise::

    X = x_max_unit(alpha)                      # closed form, formfactor module docstring
    e_max = h^-2 (X sin(alpha) - cos(alpha)) / (pi (1 + X^2)^2)
    q = min(e / e_max, 1)                      # q_min <= q <= 1
    u = (alpha - angles[0]) / angle_step;  i = min(floor(u), A - 2);  fu = u - i
    v = sqrt(-ln q) / lam_step;            j = min(floor(v), L - 2);  fv = v - j
    P = (1-fu)(1-fv) params[i,j] + fu (1-fv) params[i+1,j]
        + (1-fu) fv params[i,j+1] + fu fv params[i+1,j+1]          # 5 numbers
    a, b, x_m, y_m = P[0], P[1], P[3], P[4] times h * sqrt(1 + X^2);  d = P[2]
    x_max = h X;  rotation = pi - atan(X) - alpha

The ellipse in space: with ``w``/``v`` from the formfactor module (for ``alpha = pi`` any
in-plane ``w``), foot point ``a0 = s - h n``, maximum ``M = a0 + x_max w`` (equivalently the
ray from ``s`` along ``m`` rotated by ``rotation`` about ``v``, hit with the plane),
``C = M + x_m w + y_m v`` and ``P(t) = C + b (cos t + d cos 2t) w + a sin t v``.
"""
import hashlib
import json
import os
import threading

import numpy as np

from invrad_wb import constants as C
from invrad_wb.errors import InvradError
from invrad_wb.core.inverse.formfactor import _g1, _x_max_unit

#: npz layout this module reads (``format`` in the npz and the json).
FORMAT = 1
TABLE_NAME = "voting_table"
#: A level up to this fraction above the maximum counts as the maximum (rounding).
Q_TOL = 1e-9
REGENERATE = "regenerate it with `python tables/make_voting_table.py` (about 3 minutes on 2 cores)"

_cache = {}
_lock = threading.Lock()


class VotingTable:
    """The loaded voting table; arrays are read-only.

    Attributes
    ----------
    angles : (A,) float64, rad. ``angle_step``, ``angle0 = angles[0]`` : float.
    lam : (L,) float64; ``q`` : (L,) float64 (``q = exp(-lam^2)``); ``lam_step`` : float;
    q_min : float
    e_max, x_max, rotation, r_max : (A,) float64 at unit distance (lx/lm, h, rad, h).
    params : (A, L, 5) float32, C-contiguous; ``(a, b, d, x_m, y_m)``, lengths in units of
        ``h * r_max``.
    angle_info : (A, 4) float32, C-contiguous; columns ``e_max, x_max, rotation, r_max``.
    fit_error, fit_error_mean, r_eq : (A, L) float32.
    meta : dict, the json written by the generator. ``path`` : str, the npz.
    """

    def __init__(self, arrays, meta, path):
        self.path = path
        self.meta = meta
        self.angles = np.asarray(arrays["angles"], dtype=np.float64)
        self.lam = np.asarray(arrays["lam"], dtype=np.float64)
        self.q = np.asarray(arrays["q"], dtype=np.float64)
        self.e_max = np.asarray(arrays["e_max"], dtype=np.float64)
        self.x_max = np.asarray(arrays["x_max"], dtype=np.float64)
        self.rotation = np.asarray(arrays["rotation"], dtype=np.float64)
        self.r_max = np.asarray(arrays["r_max"], dtype=np.float64)
        self.params = np.ascontiguousarray(arrays["params"], dtype=np.float32)
        self.fit_error = np.ascontiguousarray(arrays["fit_error"], dtype=np.float32)
        self.fit_error_mean = np.ascontiguousarray(arrays["fit_error_mean"], dtype=np.float32)
        self.r_eq = np.ascontiguousarray(arrays["r_eq"], dtype=np.float32)
        self.angle_info = np.ascontiguousarray(
            np.stack([self.e_max, self.x_max, self.rotation, self.r_max], axis=1),
            dtype=np.float32)
        A, L = len(self.angles), len(self.lam)
        if self.params.shape != (A, L, 5) or self.fit_error.shape != (A, L) or A < 2 or L < 2:
            raise InvradError(f"voting table {path} has inconsistent array shapes; {REGENERATE}")
        self.angle0 = float(self.angles[0])
        self.angle_step = float(self.angles[1] - self.angles[0])
        self.lam_step = float(self.lam[1] - self.lam[0])
        self.q_min = float(self.q[-1])
        for a in (self.angles, self.lam, self.q, self.e_max, self.x_max, self.rotation,
                  self.r_max, self.params, self.fit_error, self.fit_error_mean, self.r_eq,
                  self.angle_info):
            a.flags.writeable = False

    @property
    def shape(self):
        """``(A, L)``: number of angles and of levels."""
        return self.params.shape[:2]

    def lookup(self, h, alpha, e_per_lumen, return_error=False):
        """Deformed ellipse of one or many votes, in metres at distance ``h``.

        Bilinear interpolation in ``(alpha, lam = sqrt(ln(e_max / e)))`` of the float32
        ``params``, exactly as in the module docstring; ``x_max`` and ``rotation`` are exact.

        Parameters
        ----------
        h : array, metres. Distance of the voting point in front of the plane.
        alpha : array, rad. Angle between the voting point's normal and the plane normal.
        e_per_lumen : array, lx/lm. Illuminance at the voting point divided by the flux.
        return_error : bool
            Also return the interpolated ``fit_error`` (relative, see the module docstring).

        Returns
        -------
        valid : bool array (broadcast shape)
        x_max : metres; rotation : rad; a, b : metres; d : 1; x_m, y_m : metres
            float64 arrays, 0 where not valid.
        fit_error : float64 array, only with ``return_error``.
        """
        h, alpha, e = np.broadcast_arrays(np.asarray(h, np.float64),
                                          np.asarray(alpha, np.float64),
                                          np.asarray(e_per_lumen, np.float64))
        A, L = self.shape
        with np.errstate(all="ignore"):
            ok = np.isfinite(h) & np.isfinite(alpha) & np.isfinite(e)
            ok &= (h > 0) & (e > 0) & (alpha >= self.angle0 * (1 - 1e-12)) & (alpha <= np.pi)
            hh = np.where(ok, h, 1.0)
            al = np.where(ok, alpha, np.pi)
            X = _x_max_unit(al)
            c, s = np.cos(al), np.sin(al)
            emax = _g1(c, s, X, 0.0) / (hh * hh)
            q = np.where(ok, e, 0.5 * emax) / emax
            ok &= (q <= 1.0 + Q_TOL) & (q >= self.q_min * (1 - 1e-12))
            q = np.where(ok, np.minimum(q, 1.0), 0.5)
            u = np.clip((al - self.angle0) / self.angle_step, 0.0, A - 1)
            v = np.clip(np.sqrt(np.maximum(-np.log(q), 0.0)) / self.lam_step, 0.0, L - 1)
        i = np.minimum(np.floor(u).astype(np.int64), A - 2)
        j = np.minimum(np.floor(v).astype(np.int64), L - 2)
        fu = (u - i)[..., None]
        fv = (v - j)[..., None]
        T = self.params
        P = ((1 - fu) * (1 - fv) * T[i, j] + fu * (1 - fv) * T[i + 1, j]
             + (1 - fu) * fv * T[i, j + 1] + fu * fv * T[i + 1, j + 1])
        scale = hh * np.sqrt(1.0 + X * X)
        z = np.zeros(ok.shape)
        a = np.where(ok, P[..., 0] * scale, z)
        b = np.where(ok, P[..., 1] * scale, z)
        d = np.where(ok, P[..., 2], z)
        xm = np.where(ok, P[..., 3] * scale, z)
        ym = np.where(ok, P[..., 4] * scale, z)
        x_max = np.where(ok, X * hh, z)
        rot = np.where(ok, np.pi - np.arctan(X) - al, z)
        out = (ok, x_max, rot, a, b, d, xm, ym)
        if return_error:
            F = self.fit_error.astype(np.float64)
            fu, fv = fu[..., 0], fv[..., 0]
            err = ((1 - fu) * (1 - fv) * F[i, j] + fu * (1 - fv) * F[i + 1, j]
                   + (1 - fu) * fv * F[i, j + 1] + fu * fv * F[i + 1, j + 1])
            out = out + (np.where(ok, err, z),)
        return out


def table_paths(folder=None):
    """``(npz, json)`` paths of the voting table in ``folder`` (default: ``TABLES_DIR``)."""
    folder = C.TABLES_DIR if folder is None else os.fspath(folder)
    return (os.path.join(folder, TABLE_NAME + ".npz"), os.path.join(folder, TABLE_NAME + ".json"))


def sha256(path):
    """Hex sha256 of a file (the checksum recorded next to generated tables)."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def load_voting_table(folder=None, verify=True, reload=False):
    """Load the voting table once per folder (module-level cache) and verify its checksum.

    Parameters
    ----------
    folder : path, optional
        Folder holding ``voting_table.npz`` and ``voting_table.json``; ``TABLES_DIR`` if
        omitted.
    verify : bool
        Compare the npz's sha256 with the one recorded in the json.
    reload : bool
        Ignore the cache.

    Returns
    -------
    VotingTable

    Raises
    ------
    InvradError
        The files are missing, unreadable, of another format, or the checksum differs;
        the message names the file and tells how to regenerate it.
    """
    npz, js = table_paths(folder)
    key = os.path.realpath(npz)
    with _lock:
        if not reload and key in _cache:
            return _cache[key]
        for path in (npz, js):
            if not os.path.isfile(path):
                raise InvradError(f"voting table file {path} is missing; {REGENERATE}")
        try:
            with open(js, encoding="utf-8") as fh:
                meta = json.load(fh)
        except (OSError, ValueError) as exc:
            raise InvradError(f"voting table metadata {js} is unreadable ({exc}); "
                              f"{REGENERATE}") from exc
        if meta.get("format") != FORMAT or "sha256" not in meta:
            raise InvradError(f"voting table {js} has format {meta.get('format')!r}, "
                              f"this invrad reads format {FORMAT}; {REGENERATE}")
        if verify and sha256(npz) != meta["sha256"]:
            raise InvradError(f"voting table {npz} is corrupt: its sha256 does not match "
                              f"{js}; {REGENERATE}")
        try:
            with np.load(npz, allow_pickle=False) as z:
                arrays = {name: z[name] for name in z.files}
        except Exception as exc:  # zipfile/ValueError/OSError: any unreadable npz
            raise InvradError(f"voting table {npz} is unreadable ({exc}); {REGENERATE}") \
                from exc
        missing = {"angles", "lam", "q", "e_max", "x_max", "rotation", "r_max", "params",
                   "fit_error", "fit_error_mean", "r_eq"} - set(arrays)
        if missing:
            raise InvradError(f"voting table {npz} lacks {sorted(missing)}; {REGENERATE}")
        table = VotingTable(arrays, meta, npz)
        _cache[key] = table
        return table
