"""Verification report: how far the achieved illuminance is from the targets, per room.

Values live on the mesh vertices and vary linearly over each triangle; the metrics
integrate that field over the faces exactly (EN 12464-1 vocabulary):

* a face *has a target* when all three corners have one (NaN = no target); it is a *shade*
  face when all three targets are 0 lx ("must stay dark"), a *lit* face when all three are
  above 0, else a *transition* face (the edge between lit and shade);
* ``target_em`` / ``em``: area-weighted mean target / achieved illuminance over the lit
  faces (lux); ``target_emin``/``emin``, ``target_emax``/``emax``: extremes over their
  corners (the target points); uniformity ``u0 = emin / em``; ``emin_*``: where the
  darkest achieved target point is;
* deviations are taken over lit and transition faces: ``rmse_lux`` = sqrt(mean over the
  area of (E - T)^2), ``rmse_pct`` = it in % of ``target_em``; ``mae_lux`` / ``mae_pct``
  the mean absolute deviation likewise; ``bias_pct`` = (em - target_em) / target_em;
* ``within_tol_pct``: % of that area where |E - T| <= tolerance x T (default 20 %);
* ``max_dev_*``: the target point (T > 0) with the largest |E - T| in lux (signed: > 0
  too bright), in % of its target, and where: 3-D point, plane, words
  ("floor at (2.10, 1.35) m"); ``max_rel_dev_*``: the point with the largest relative
  deviation among points whose target is at least 10 % of ``target_em``;
* shade: ``shade_area_m2``, ``shade_max_lux`` (brightest achieved point on shade faces)
  and where, ``shade_mean_lux``.

:func:`room_metrics` computes them over any set of faces (a room, a work plane, one plane).
:func:`build_report` writes one self-contained ``index.html`` (CSS and images inlined),
``rooms.csv`` (one row per room, all its targets), ``surfaces.csv`` (per room: work plane,
surfaces, each plane, custom groups), ``luminaires.csv``, ``metrics.json`` and the images
as PNG (per room: target, achieved, deviation unfolded; plan views achieved and deviation
with the luminaires) plus their raw values as EXR. All files are written to a staging
folder first and moved into place only when everything succeeded, ``index.html`` last:
a failed run leaves the previous report untouched.

Deviation images show ``(E - T) / T``; on shade targets (T = 0) the achieved light in % of
the room's mean target. Illuminance images share one linear scale for the whole report:
0 to :func:`~invrad_wb.core.output.images.nice_max` of the larger of the highest target and the
99th percentile of the achieved illuminance on target points (``lux_range`` overrides).
"""
from dataclasses import dataclass, field
import base64
import csv
import html
import io
import json
import os
import shutil
import tempfile

import numpy as np

from invrad_wb import constants as C
from invrad_wb.errors import SceneError
from invrad_wb.core.output import images as im
from invrad_wb.core.output.images import describe_plane, room_floor_z  # noqa: F401 - part of this API

#: colour scale of the deviation images: -50 % .. +50 %
DEVIATION_LIMIT = im.DEVIATION_LIMIT
#: default tolerance of ``within_tol_pct``
TOLERANCE = 0.2
#: points whose target is below this fraction of the target mean are not candidates for
#: the largest *relative* deviation (soft edges of a target would always win)
REL_DEV_MIN_TARGET = 0.1

_NAN = float("nan")


# ---------------------------------------------------------------------------- words
def describe_point(scene, plane, point, floor_z=None):
    """Where a point is, in words: 'floor at (2.10, 1.35) m', 'wall x = 0.00 m (facing +x)
    at y = 1.20 m, 1.50 m above the floor'.

    Parameters
    ----------
    scene : Scene
    plane : Plane or int (plane index)
    point : (3,) float64, metres
    floor_z : float, the room's floor height (default: from the scene)
    """
    if not hasattr(plane, "normal"):
        plane = scene.planes[int(plane)]
    if floor_z is None:
        floor_z = room_floor_z(scene, plane.room)
    what = describe_plane(plane, floor_z)
    x, y, z = (float(c) for c in point)
    if abs(plane.normal[2]) > 0.9:
        return f"{what} at ({x:.2f}, {y:.2f}) m"
    h = f"{z - floor_z:.2f} m above the floor"
    if what.startswith("wall x ="):
        return f"{what} at y = {y:.2f} m, {h}"
    if what.startswith("wall y ="):
        return f"{what} at x = {x:.2f} m, {h}"
    return f"{what} at ({x:.2f}, {y:.2f}) m, {h}"


# ---------------------------------------------------------------------------- metrics
def _abs_integral(d, area):
    """Exact integral of |f| over triangles where f is linear with corner values d (k, 3)."""
    total = d.sum(axis=1) / 3.0
    out = np.abs(total) * area
    pos = d > 0
    neg = d < 0
    mixed = pos.any(axis=1) & neg.any(axis=1)
    if mixed.any():
        dm = d[mixed]
        pm = dm > 0
        # the corner whose sign is alone: positive if exactly one positive corner
        lone_pos = pm.sum(axis=1) == 1
        lone = np.where(lone_pos, np.argmax(pm, axis=1), np.argmax(dm < 0, axis=1))
        k = np.arange(len(dm))
        p = dm[k, lone]
        q = dm[k, (lone + 1) % 3]
        r = dm[k, (lone + 2) % 3]
        # sub-triangle at the lone corner, cut where f = 0 on its two edges
        with np.errstate(divide="ignore", invalid="ignore"):
            t1 = np.where(q != p, p / (p - q), 0.0)
            t2 = np.where(r != p, p / (p - r), 0.0)
        i_sub = t1 * t2 * p / 3.0          # integral over the sub-triangle / face area
        i_all = (p + q + r) / 3.0
        out[mixed] = np.sign(p) * (2.0 * i_sub - i_all) * area[mixed]
    return out


def _sub_barycentric(k=4):
    """Centroids of the k^2 equal sub-triangles of a triangle: (k^2, 3) barycentric."""
    pts = []
    for i in range(k):
        for j in range(k - i):
            pts.append(((i + 1 / 3) / k, (j + 1 / 3) / k))          # upward sub-triangle
            if i + j < k - 1:
                pts.append(((i + 2 / 3) / k, (j + 2 / 3) / k))      # downward one
    a = np.array(pts)
    return np.stack([a[:, 0], a[:, 1], 1 - a[:, 0] - a[:, 1]], axis=1)


def _empty_metrics():
    m = {k: _NAN for k in (
        "target_em", "em", "target_emin", "emin", "target_emax", "emax", "target_u0", "u0",
        "rmse_lux", "rmse_pct", "mae_lux", "mae_pct", "bias_pct", "within_tol_pct",
        "max_dev_lux", "max_dev_pct", "max_rel_dev_lux", "max_rel_dev_pct",
        "shade_max_lux", "shade_mean_lux")}
    for k in ("max_dev", "max_rel_dev", "emin", "shade_max"):
        m[f"{k}_point"] = [_NAN, _NAN, _NAN]
        m[f"{k}_plane"] = -1
        m[f"{k}_where"] = ""
    return m


def room_metrics(scene, target_vertex_lux, achieved_vertex_lux, faces=None,
                 tolerance=TOLERANCE):
    """Target vs achieved metrics over a set of faces (see the module docstring).

    Parameters
    ----------
    scene : Scene
    target_vertex_lux : (n,) float64, lux per scene vertex; NaN = no target, 0 = shade
    achieved_vertex_lux : (n,) float64, lux per scene vertex
    faces : (k,) int, optional
        The faces to evaluate (a room, a work plane, a plane); default all faces.
    tolerance : float, fraction for ``within_tol_pct``

    Returns
    -------
    dict of floats (NaN where undefined, e.g. the lit metrics of a shade-only set), points
    as [x, y, z] lists (metres), plane indices and descriptions; counts ``n_faces``
    (faces with a target), ``n_lit_faces``, ``n_transition_faces``, ``n_shade_faces``,
    ``n_points`` (target points > 0 lx) and areas ``area_m2``, ``lit_area_m2``,
    ``shade_area_m2``.

    Raises
    ------
    SceneError
        Arrays of the wrong length, or an achieved value that is NaN/negative where
        there is a target.
    """
    n = len(scene.vertices)
    tv = np.asarray(target_vertex_lux, dtype=np.float64).reshape(-1)
    ev = np.asarray(achieved_vertex_lux, dtype=np.float64).reshape(-1)
    if len(tv) != n or len(ev) != n:
        raise SceneError(f"report: {len(tv)} target and {len(ev)} achieved values for"
                         f" {n} scene vertices", scene.source)
    faces = (np.arange(len(scene.faces)) if faces is None
             else np.asarray(faces, dtype=np.int64).reshape(-1))
    corners = scene.faces[faces]
    T, E = tv[corners], ev[corners]
    has = np.all(np.isfinite(T), axis=1)
    bad = has[:, None] & ~np.isfinite(E)
    if bad.any():
        v = int(corners[bad][0])
        raise SceneError(f"report: achieved illuminance at vertex {v} is {ev[v]} where"
                         " there is a target", scene.source)
    shade = has & np.all(T == 0, axis=1)
    lit = has & np.all(T > 0, axis=1)
    err = has & ~shade                       # lit and transition (lit/shade edge) faces
    area = scene.face_areas[faces]
    out = _empty_metrics()
    out.update(n_faces=int(has.sum()), n_lit_faces=int(lit.sum()),
               n_transition_faces=int((err & ~lit).sum()), n_shade_faces=int(shade.sum()),
               area_m2=float(area[has].sum()), lit_area_m2=float(area[lit].sum()),
               shade_area_m2=float(area[shade].sum()), n_points=0,
               tolerance_pct=100.0 * tolerance)
    fz = {}

    def where(v):
        pl = int(scene.vertex_plane[v])
        room = scene.planes[pl].room
        if room not in fz:
            fz[room] = room_floor_z(scene, room)
        p = scene.vertices[v]
        return [float(x) for x in p], pl, describe_point(scene, pl, p, fz[room])

    if err.any():
        # Em, Emin, Emax, U0 over the lit faces (the task area proper; transition faces
        # only if there is nothing else), deviations over lit and transition faces
        core = lit if lit.any() else err
        Ac = area[core]
        t_em = float((Ac * T[core].mean(axis=1)).sum() / Ac.sum())
        e_em = float((Ac * E[core].mean(axis=1)).sum() / Ac.sum())
        vc = np.unique(corners[core].reshape(-1))
        vc = vc[tv[vc] > 0]
        out.update(target_em=t_em, em=e_em, target_emin=float(tv[vc].min()),
                   target_emax=float(tv[vc].max()), emin=float(ev[vc].min()),
                   emax=float(ev[vc].max()))
        out["target_u0"] = out["target_emin"] / t_em if t_em > 0 else _NAN
        out["u0"] = out["emin"] / e_em if e_em > 0 else _NAN
        j = vc[int(np.argmin(ev[vc]))]
        out["emin_point"], out["emin_plane"], out["emin_where"] = where(j)

        Tl, El, Al = T[err], E[err], area[err]
        A = float(Al.sum())
        d = El - Tl
        sq = (d ** 2).sum(axis=1) + d[:, 0] * d[:, 1] + d[:, 1] * d[:, 2] + d[:, 2] * d[:, 0]
        rmse = float(np.sqrt(max((Al * sq / 6.0).sum() / A, 0.0)))
        mae = float(_abs_integral(d, Al).sum() / A)
        out.update(rmse_lux=rmse, mae_lux=mae)
        if t_em > 0:
            out["rmse_pct"] = 100.0 * rmse / t_em
            out["mae_pct"] = 100.0 * mae / t_em
            out["bias_pct"] = 100.0 * (e_em - t_em) / t_em
        verts = np.unique(corners[err].reshape(-1))
        verts = verts[tv[verts] > 0]
        tp, ep = tv[verts], ev[verts]
        out["n_points"] = int(len(verts))
        dev = ep - tp
        i = int(np.argmax(np.abs(dev)))
        out["max_dev_lux"] = float(dev[i])
        out["max_dev_pct"] = float(100.0 * dev[i] / tp[i])
        exact = dev[i] == 0                   # no deviation anywhere: no place to name
        if not exact:
            out["max_dev_point"], out["max_dev_plane"], out["max_dev_where"] = \
                where(verts[i])
        cand = np.flatnonzero(tp >= REL_DEV_MIN_TARGET * t_em)
        if len(cand) and not exact:
            j = cand[int(np.argmax(np.abs(dev[cand]) / tp[cand]))]
            out["max_rel_dev_lux"] = float(dev[j])
            out["max_rel_dev_pct"] = float(100.0 * dev[j] / tp[j])
            (out["max_rel_dev_point"], out["max_rel_dev_plane"],
             out["max_rel_dev_where"]) = where(verts[j])
        # area within tolerance: sampled at the centroids of 16 sub-triangles per face;
        # where the target is 0 (transition faces) "within" means E <= tolerance x Em
        B = _sub_barycentric(4)
        ts, es = Tl @ B.T, El @ B.T
        ok = np.abs(es - ts) <= tolerance * np.where(ts > 0, ts, t_em) + 1e-12
        out["within_tol_pct"] = float(100.0 * (Al * ok.mean(axis=1)).sum() / A)
    if shade.any():
        As = area[shade]
        out["shade_mean_lux"] = float((As * E[shade].mean(axis=1)).sum() / As.sum())
        verts = np.unique(corners[shade].reshape(-1))
        j = verts[int(np.argmax(ev[verts]))]
        out["shade_max_lux"] = float(ev[j])
        out["shade_max_point"], out["shade_max_plane"], out["shade_max_where"] = where(j)
    return out


def relative_deviation(target_vertex_lux, achieved_vertex_lux, reference_lux):
    """Per-vertex deviation as a fraction: (E - T) / T; on shade (T = 0) E / reference.

    Parameters
    ----------
    reference_lux : float or (n,) float64, the mean target used for shade points
        (NaN: shade points get NaN)

    Returns
    -------
    (n,) float64, NaN where there is no target.
    """
    t = np.asarray(target_vertex_lux, dtype=np.float64)
    e = np.asarray(achieved_vertex_lux, dtype=np.float64)
    ref = np.broadcast_to(np.asarray(reference_lux, dtype=np.float64), t.shape)
    out = np.full(t.shape, np.nan)
    lit = np.isfinite(t) & (t > 0)
    out[lit] = (e[lit] - t[lit]) / t[lit]
    sh = np.isfinite(t) & (t == 0) & np.isfinite(ref) & (ref > 0)
    out[sh] = e[sh] / ref[sh]
    return out


# ---------------------------------------------------------------------------- report
@dataclass
class ReportPaths:
    """What :func:`build_report` wrote (absolute paths) and computed.

    ``rooms`` is a list of dicts, one per room: ``room`` (id), ``name``, ``metrics`` (all
    targets of the room), ``parts`` (list of dicts ``part``, ``kind``, ``metrics``),
    ``luminaires`` (indices into the luminaire list), ``images`` (kind -> file name).
    ``metrics`` maps room id -> the room's all-target metrics.
    """
    html: str
    rooms_csv: str
    luminaires_csv: str
    surfaces_csv: str = ""
    metrics_json: str = ""
    out_dir: str = ""
    images: list = field(default_factory=list)
    exr: list = field(default_factory=list)
    rooms: list = field(default_factory=list)
    metrics: dict = field(default_factory=dict)
    scale: dict = field(default_factory=dict)

    @property
    def index_html(self):
        return self.html


def _room_name(room_names, r):
    if room_names is None:
        return f"room {r}"
    try:
        name = room_names[r]
    except (KeyError, IndexError, TypeError):
        return f"room {r}"
    return f"room {r}" if name is None else str(name)


def luminaire_rooms(scene, luminaires):
    """Room id of each luminaire: its ``room``, else the room of the nearest face centroid
    (one k-d tree query for all: 100,000 luminaires took minutes one by one)."""
    out = [None if l.room is None else int(l.room) for l in luminaires]
    free = [i for i, r in enumerate(out) if r is None]
    if not free:
        return out
    pos = np.array([luminaires[i].position for i in free], dtype=np.float64).reshape(-1, 3)
    try:
        from scipy.spatial import cKDTree
        nearest = cKDTree(scene.face_centroids).query(pos)[1]
    except ImportError:
        nearest = [int(np.argmin(np.linalg.norm(scene.face_centroids - p, axis=1)))
                   for p in pos]
    for i, k in zip(free, np.atleast_1d(nearest)):
        out[i] = int(scene.face_room[int(k)])
    return out


def fmt_lux(v):
    """Lux for people: 3 significant figures at most, no decimals from 100 lx."""
    if v is None or not np.isfinite(v):
        return "–"
    a = abs(v)
    if a >= 100 or a == 0:
        return f"{v:.0f}"
    if a >= 10:
        return f"{v:.1f}"
    return f"{v:.2f}"


def signed(v, digits):
    """``+1.5`` style text of ``v`` with ``digits`` decimals; a value that rounds to zero
    prints as ``+0`` (never ``-0``)."""
    return f"{round(float(v), digits) + 0.0:+.{digits}f}"


def fmt_pct(v, signed_=False):
    if v is None or not np.isfinite(v):
        return "–"
    return f"{signed(v, 1)} %" if signed_ else f"{v:.1f} %"


def _signed_lux(v):
    return "–" if v is None or not np.isfinite(v) else f"{signed(v, 0)} lx"


def fmt_ratio(v):
    return "–" if v is None or not np.isfinite(v) else f"{v:.2f}"


def _csv_value(v):
    if v is None:
        return ""
    if isinstance(v, (bool, np.bool_)):
        return str(bool(v)).lower()
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        return repr(float(v)) if np.isfinite(v) else ""
    return str(v)


#: columns of rooms.csv / surfaces.csv after the identifying ones (metric keys; points are
#: split into _x, _y, _z)
METRIC_COLUMNS = [
    "n_faces", "n_lit_faces", "n_transition_faces", "n_shade_faces", "n_points", "area_m2",
    "lit_area_m2",
    "target_em", "em", "target_emin", "emin", "target_emax", "emax", "target_u0", "u0",
    "rmse_lux", "rmse_pct", "mae_lux", "mae_pct", "bias_pct", "tolerance_pct",
    "within_tol_pct",
    "max_dev_lux", "max_dev_pct", "max_dev_point", "max_dev_plane", "max_dev_where",
    "max_rel_dev_lux", "max_rel_dev_pct", "max_rel_dev_point", "max_rel_dev_plane",
    "max_rel_dev_where", "emin_point", "emin_plane", "emin_where",
    "shade_area_m2", "shade_mean_lux", "shade_max_lux", "shade_max_point",
    "shade_max_plane", "shade_max_where"]


def _metric_header():
    cols = []
    for k in METRIC_COLUMNS:
        if k.endswith("_point"):
            cols += [f"{k[:-6]}_{a}_m" for a in "xyz"]
        else:
            cols.append(k)
    return cols


def _metric_cells(m):
    cells = []
    for k in METRIC_COLUMNS:
        v = m.get(k)
        if k.endswith("_point"):
            cells += [_csv_value(x) for x in (v if v is not None else [None] * 3)]
        else:
            cells.append(_csv_value(v))
    return cells


def _csv_text(header, rows):
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(header)
    w.writerows(rows)
    return buf.getvalue()


def _json_default(o):
    from invrad_wb.core.io.jsonout import jsonable
    return jsonable(o)


def _json_clean(o):
    """NaN -> None so that metrics.json is strict JSON."""
    if isinstance(o, dict):
        return {str(k): _json_clean(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [_json_clean(v) for v in o]
    if isinstance(o, (float, np.floating)):
        return float(o) if np.isfinite(o) else None
    return o


def _umask():
    try:
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    return 0o022


class _Staging:
    """Write a report's files into a private folder, then move them into ``out_dir``."""

    def __init__(self, out_dir):
        self.out_dir = os.path.abspath(out_dir)
        os.makedirs(self.out_dir, exist_ok=True)
        from invrad_wb.core.io.atomic import remove_stale, temp_prefix
        remove_stale(self.out_dir)          # what a killed run left here
        self.dir = tempfile.mkdtemp(prefix=temp_prefix(), dir=self.out_dir)
        self.names = []

    def path(self, name):
        self.names.append(name)
        return os.path.join(self.dir, name)

    def text(self, name, text):
        with open(self.path(name), "w", encoding="utf-8", newline="") as fh:
            fh.write(text)

    def commit(self, last="index.html"):
        mode = 0o666 & ~_umask()
        order = [n for n in self.names if n != last] + [n for n in self.names if n == last]
        for n in order:
            src = os.path.join(self.dir, n)
            os.chmod(src, mode)
            os.replace(src, os.path.join(self.out_dir, n))
        return [os.path.join(self.out_dir, n) for n in self.names]

    def cleanup(self):
        shutil.rmtree(self.dir, ignore_errors=True)


def _lux_scale(scene, target, achieved, rooms):
    sel = np.isin(scene.face_room, rooms)
    verts = np.unique(scene.faces[sel].reshape(-1))
    t = target[verts]
    has = np.isfinite(t)
    tmax = float(t[has].max()) if has.any() else 0.0
    a = achieved[verts][has & np.isfinite(achieved[verts])]
    if not len(a):
        a = achieved[verts][np.isfinite(achieved[verts])]
    p99 = float(np.percentile(a, 99)) if len(a) else 0.0
    return im.nice_max(max(tmax, p99, 1e-3))


def _png_data_uri(path):
    with open(path, "rb") as fh:
        return "data:image/png;base64," + base64.b64encode(fh.read()).decode("ascii")


def _load_css():
    path = os.path.join(C.RESOURCES_DIR, "report.css")
    try:
        with open(path, encoding="utf-8") as fh:
            return fh.read()
    except OSError:
        return _FALLBACK_CSS


_FALLBACK_CSS = """body{font-family:sans-serif;margin:24px;color:#222;max-width:1200px}
table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:3px 8px}"""


def build_report(scene, target_vertex_lux, achieved_vertex_lux, luminaires, out_dir,
                 room_names=None, title="invrad verification report", extra=None,
                 groups=None, lux_range=None, deviation_limit=DEVIATION_LIMIT,
                 metres_per_pixel=None, tolerance=TOLERANCE, embed_images=True,
                 write_exr=True, rooms=None):
    """Write the report of a forward solve against the targets.

    Parameters
    ----------
    scene : Scene
    target_vertex_lux, achieved_vertex_lux : (n,) float64, lux per scene vertex
        (``scene.vertex_targets()`` and :func:`invrad_wb.core.forward.render.render`)
    luminaires : list of Luminaire (``room`` groups them; None = room of the nearest face)
    out_dir : folder (created); files are replaced atomically, ``index.html`` last
    room_names : sequence or dict, room id -> name (default 'room <id>')
    title : str
    extra : dict, run information shown under the title and stored in metrics.json
        (e.g. ``{"interreflection": True, "backend": "opencl"}``)
    groups : list of (room, name, faces), optional
        Extra face sets to evaluate, e.g. a task area; rows in the room's surface table.
    lux_range : (vmin, vmax) lux of the illuminance images (default: see module docstring)
    deviation_limit : fraction drawn in the end colours of deviation images (0.5 = 50 %)
    metres_per_pixel : float, pixel size of the unfolded images (default: per room, so
        that the image is at most about 800 pixels)
    tolerance : float, for ``within_tol_pct``
    embed_images : bool, inline the PNGs into index.html (self-contained page); else link
    write_exr : bool, also write the values of the images as half-float EXR, channels
        ``target``, ``achieved`` (lux) and ``deviation`` (fraction), NaN off the faces
    rooms : list of room ids to report (default all)

    Returns
    -------
    :class:`ReportPaths`
    """
    target = np.asarray(target_vertex_lux, dtype=np.float64).reshape(-1)
    achieved = np.asarray(achieved_vertex_lux, dtype=np.float64).reshape(-1)
    if len(target) != len(scene.vertices) or len(achieved) != len(scene.vertices):
        raise SceneError(f"report: {len(target)} target and {len(achieved)} achieved values"
                         f" for {len(scene.vertices)} scene vertices", scene.source)
    rooms = [int(r) for r in (scene.rooms if rooms is None else rooms)]
    lum_room = luminaire_rooms(scene, luminaires)
    if lux_range is None:
        lux_range = (0.0, _lux_scale(scene, target, achieved, rooms))
    vmin, vmax = float(lux_range[0]), float(lux_range[1])
    if not vmax > vmin:
        raise ValueError(f"lux_range {lux_range}: the top must be above the bottom")
    limit = float(deviation_limit)
    if not limit > 0:
        raise ValueError(f"deviation_limit {deviation_limit}: must be > 0")
    groups = list(groups or [])

    stage = _Staging(out_dir)
    try:
        room_reports = []
        for r in rooms:
            room_reports.append(_room_report(
                stage, scene, r, _room_name(room_names, r), target, achieved, luminaires,
                lum_room, groups, (vmin, vmax), limit, metres_per_pixel, tolerance,
                write_exr))
        # colour bars on their own, for reuse (e.g. a legend in the workbench)
        im.save_png(stage.path("colourbar_lux.png"),
                    im.colour_bar(vmin, vmax, "lux", over=True))
        im.save_png(stage.path("colourbar_deviation.png"),
                    im.colour_bar(-limit, limit, "deviation"))
        # CSV
        head = ["room", "name", "luminaires", "flux_lm"] + _metric_header()
        rows = [[rr["room"], rr["name"], len(rr["luminaires"]), _csv_value(rr["flux_lm"])]
                + _metric_cells(rr["metrics"]) for rr in room_reports]
        stage.text("rooms.csv", _csv_text(head, rows))
        head = ["room", "name", "part", "kind"] + _metric_header()
        rows = [[rr["room"], rr["name"], p["part"], p["kind"]] + _metric_cells(p["metrics"])
                for rr in room_reports for p in rr["parts"]]
        stage.text("surfaces.csv", _csv_text(head, rows))
        extra_keys = []
        for l in luminaires:
            for k, v in l.extra.items():
                if k not in extra_keys and isinstance(v, (str, int, float, bool)):
                    extra_keys.append(k)
        head = ["luminaire", "room", "room_name", "x_m", "y_m", "z_m", "nx", "ny", "nz",
                "flux_lm", "radius_m", "score"] + extra_keys
        rows = []
        for i, l in enumerate(luminaires):
            rows.append([i + 1, lum_room[i], _room_name(room_names, lum_room[i])]
                        + [_csv_value(x) for x in l.position]
                        + [_csv_value(x) for x in l.normal]
                        + [_csv_value(l.flux_lm), _csv_value(l.radius_m),
                           _csv_value(l.score)]
                        + [_csv_value(l.extra.get(k)) for k in extra_keys])
        stage.text("luminaires.csv", _csv_text(head, rows))
        scale = {"lux_min": vmin, "lux_max": vmax, "deviation_limit": limit,
                 "colour_map": "viridis", "deviation_map": "RdBu (blue too dark, red too"
                 " bright)"}
        data = {"title": title, "extra": extra or {}, "scale": scale,
                "rooms": [{k: v for k, v in rr.items() if k != "html"}
                          for rr in room_reports],
                "luminaires": [dict(l.to_dict(), room=lum_room[i])
                               for i, l in enumerate(luminaires)]}
        stage.text("metrics.json", json.dumps(_json_clean(data), indent=1,
                                              default=_json_default) + "\n")
        page = _page(title, extra, room_reports, luminaires, lum_room, room_names, scale,
                     stage, embed_images, extra_keys)
        stage.text("index.html", page)
        written = stage.commit("index.html")
    finally:
        stage.cleanup()
    out = os.path.abspath(out_dir)
    j = lambda n: os.path.join(out, n)  # noqa: E731
    return ReportPaths(
        html=j("index.html"), rooms_csv=j("rooms.csv"), luminaires_csv=j("luminaires.csv"),
        surfaces_csv=j("surfaces.csv"), metrics_json=j("metrics.json"), out_dir=out,
        images=[p for p in written if p.endswith(".png")],
        exr=[p for p in written if p.endswith(".exr")],
        rooms=[{k: v for k, v in rr.items() if k != "html"} for rr in room_reports],
        metrics={rr["room"]: rr["metrics"] for rr in room_reports}, scale=scale)


def _room_report(stage, scene, r, name, target, achieved, luminaires, lum_room, groups,
                 lux_range, limit, mpp, tolerance, write_exr):
    vmin, vmax = lux_range
    rf = np.flatnonzero(scene.face_room == r)
    floor_z = room_floor_z(scene, r)
    m_all = room_metrics(scene, target, achieved, rf, tolerance)
    parts = []
    virt = rf[scene.face_virtual[rf]]
    if len(virt):
        for part, kind, faces in (("work plane", "work plane", virt),
                                  ("surfaces", "surfaces", rf[~scene.face_virtual[rf]])):
            m = room_metrics(scene, target, achieved, faces, tolerance)
            if m["n_faces"]:
                parts.append({"part": part, "kind": kind, "metrics": m})
    for g_room, g_name, g_faces in groups:
        if int(g_room) == r:
            m = room_metrics(scene, target, achieved, g_faces, tolerance)
            parts.append({"part": str(g_name), "kind": "group", "metrics": m})
    for p in scene.planes:
        if p.room != r:
            continue
        m = room_metrics(scene, target, achieved, p.faces, tolerance)
        if m["n_faces"]:
            parts.append({"part": f"{describe_plane(p, floor_z)}, plane {p.index}",
                          "kind": "plane", "plane": p.index, "metrics": m})
    lums = [i for i in range(len(luminaires)) if lum_room[i] == r]
    ref = m_all["target_em"]
    if not np.isfinite(ref):
        lit = np.isfinite(target) & (target > 0)
        ref = float(target[lit].mean()) if lit.any() else _NAN
    dev = relative_deviation(target, achieved, ref)
    images = {}
    stem = f"room{r}"
    lux_fn = lambda v: im.false_colour(v, vmin, vmax)  # noqa: E731
    tgt_fn = lambda v: im.false_colour(v, vmin, vmax, shade=True)  # noqa: E731
    dev_fn = lambda v: im.diverging(v, limit)  # noqa: E731
    has_nan = bool(np.any(~np.isfinite(target[scene.faces[rf]])))
    has_shade = bool(np.any(target[scene.faces[rf]] == 0))
    sw_nan = [(im.NAN_GREY, "no target")] if has_nan else []
    lux_bar = im.colour_bar(vmin, vmax, "lux", over=True)
    tgt_bar = im.colour_bar(vmin, vmax, "lux", over=True, swatches=sw_nan + (
        [(im.SHADE_BLACK, "shade target (0 lx), dashed outline")] if has_shade else []))
    dev_bar = im.colour_bar(-limit, limit, "deviation", swatches=sw_nan)

    # unfolded planes
    ras = im.unfolded_raster(scene, r, mpp)
    T, E, D = ras.sample(target), ras.sample(achieved), ras.sample(dev)
    marks = _unfolded_marks(scene, ras, luminaires, lums)
    how = ("box net, seen from inside: floor in plan, walls folded out around it,"
           " ceiling beyond the top wall; other planes to the right"
           if ras.layout == "box net" else "planes seen from their front, packed in rows")
    sub = f"{how}; {ras.metres_per_pixel * 100:g} cm per pixel"
    if has_shade:
        sub += "; dashed outline: shade targets"
    for kind, vals, fn, bar, what in (
            ("target", T, tgt_fn, tgt_bar, "target illuminance"),
            ("achieved", E, lux_fn, lux_bar, "achieved illuminance"),
            ("deviation", D, dev_fn, dev_bar, "deviation from target")):
        img = im.paint(ras, vals, fn)
        if has_shade:
            im.outline_mask(img, T == 0)
        img = im.label_planes(img, ras)
        if kind != "target" and marks:
            img = im.mark_luminaires(img, marks)
        img = im.scale_bar(img, ras)
        img = im.compose(f"{name}: {what}", [img, bar], sub)
        fname = f"{stem}_{kind}.png"
        im.save_png(stage.path(fname), img)
        images[kind] = fname
    if write_exr:
        fname = f"{stem}_unfolded.exr"
        im.save_exr(stage.path(fname), np.stack([T, E, D], axis=2),
                    ["target", "achieved", "deviation"], half=True)
        images["unfolded_exr"] = fname
    # plan view
    plan = im.plan_raster(scene, r)
    if plan is not None:
        Ep, Dp, Tp = plan.sample(achieved), plan.sample(dev), plan.sample(target)
        pmarks = []
        for k, i in enumerate(lums):
            l = luminaires[i]
            c = (l.position[0] - plan.x0) / plan.metres_per_pixel
            rr = (plan.y1 - l.position[1]) / plan.metres_per_pixel
            pmarks.append((c, rr, l.radius_m / plan.metres_per_pixel, f"L{i + 1}"))
        ups = [p for p in scene.planes if p.room == r and p.normal[2] > 0.9]
        what = ("work plane where there is one, else floor"
                if any(p.is_virtual for p in ups) else "floor")
        plan_shade = bool(np.any(Tp == 0))
        ticks = im.lux_ticks(vmin, vmax)
        step = (ticks[1] - ticks[0]) / 2 if len(ticks) > 1 else (vmax - vmin) / 8
        for kind, vals, fn, bar, cap in (
                ("plan_achieved", Ep, lux_fn, lux_bar, "achieved illuminance, from above"),
                ("plan_deviation", Dp, dev_fn, dev_bar, "deviation from target, from above")):
            img = im.paint(plan, vals, fn)
            if plan_shade:
                im.outline_mask(img, Tp == 0)
            if kind == "plan_achieved":
                im.contours(img, plan, vals, step)
            img = im.plan_axes(img, plan)
            img = im.mark_luminaires(img, pmarks)
            extra_sub = (f"; iso-lux lines every {im._fmt_tick(step)} lx"
                         if kind == "plan_achieved" else "")
            img = im.compose(f"{name}: {cap}", [img, bar],
                             f"{what}; luminaires as rings (L = luminaire table number)"
                             f"{extra_sub}"
                             f"{'; dashed outline: shade targets' if plan_shade else ''}")
            fname = f"{stem}_{kind}.png"
            im.save_png(stage.path(fname), img)
            images[kind] = fname
        if write_exr:
            fname = f"{stem}_plan.exr"
            im.save_exr(stage.path(fname), np.stack([Tp, Ep, Dp], axis=2),
                        ["target", "achieved", "deviation"], half=True)
            images["plan_exr"] = fname
    return {"room": r, "name": name, "metrics": m_all, "parts": parts, "luminaires": lums,
            "flux_lm": float(sum(luminaires[i].flux_lm for i in lums)), "images": images,
            "floor_z": floor_z, "layout": ras.layout,
            "metres_per_pixel": ras.metres_per_pixel}


def _unfolded_marks(scene, ras, luminaires, lums, max_dist=0.35):
    """Rings on the unfolded planes for luminaires mounted on (close to) one of them."""
    marks = []
    for i in lums:
        l = luminaires[i]
        best = None
        for k in ras.transforms:
            p = scene.planes[k]
            if p.is_virtual:
                continue
            d = float(p.signed_distance(l.position[None])[0])
            if -0.01 <= d <= max_dist and (best is None or d < best[0]):
                foot = l.position - d * p.normal
                uv = p.to_plane_coords(foot[None])[0]
                if np.all(uv >= -1e-6) and np.all(uv <= p.size + 1e-6):
                    best = (d, k, foot)
        if best is None:
            continue
        c, rr = ras.pixel_of(best[2][None], best[1])[0]
        if ras.face[min(max(int(rr), 0), ras.shape[0] - 1),
                    min(max(int(c), 0), ras.shape[1] - 1)] < 0:
            continue
        marks.append((c, rr, l.radius_m / ras.metres_per_pixel, f"L{i + 1}"))
    return marks


# ---------------------------------------------------------------------------- HTML
def _e(s):
    return html.escape(str(s), quote=True)


def _img_src(stage, fname, embed):
    return _png_data_uri(os.path.join(stage.dir, fname)) if embed else _e(fname)


def _metric_table(m):
    def row(label, t, a, d=""):
        return f"<tr><th>{_e(label)}</th><td>{t}</td><td>{a}</td><td>{d}</td></tr>"

    def diff(a, t, pct=True):
        if not (np.isfinite(a) and np.isfinite(t)):
            return "–"
        s = f"{signed(a - t, 0)} lx" if abs(a - t) >= 10 else f"{signed(a - t, 2)} lx"
        if pct and t > 0:
            s += f" ({signed(100 * (a - t) / t, 1)} %)"
        return s

    rows = [
        row("Em (mean, lx)", fmt_lux(m["target_em"]), fmt_lux(m["em"]),
            diff(m["em"], m["target_em"])),
        row("Emin (lx)", fmt_lux(m["target_emin"]), fmt_lux(m["emin"]),
            diff(m["emin"], m["target_emin"])),
        row("Emax (lx)", fmt_lux(m["target_emax"]), fmt_lux(m["emax"]),
            diff(m["emax"], m["target_emax"])),
        row("U0 = Emin / Em", fmt_ratio(m["target_u0"]), fmt_ratio(m["u0"]),
            "–" if not np.isfinite(m["u0"] - m["target_u0"])
            else signed(m['u0'] - m['target_u0'], 2)),
    ]
    return ("<table class=\"metrics\"><tr><th></th><th>target</th><th>achieved</th>"
            "<th>difference</th></tr>" + "".join(rows) + "</table>")


def _facts(m):
    items = []
    if m["n_faces"] > m["n_shade_faces"]:
        items.append(f"RMSE <b>{fmt_pct(m['rmse_pct'])}</b> ({fmt_lux(m['rmse_lux'])} lx),"
                     f" mean absolute deviation <b>{fmt_pct(m['mae_pct'])}</b>"
                     f" ({fmt_lux(m['mae_lux'])} lx) of the target mean;"
                     f" {fmt_pct(m['within_tol_pct'])} of the area within"
                     f" ±{m['tolerance_pct']:.0f} % of its target")
        sign = "too bright" if m["max_dev_lux"] > 0 else "too dark"
        if m["max_dev_where"]:
            items.append(f"Largest deviation <b>{signed(m['max_dev_lux'], 0)} lx"
                         f" ({fmt_pct(m['max_dev_pct'], True)})</b>, {sign}, on the"
                         f" {_e(m['max_dev_where'])}")
        else:
            items.append("The achieved illuminance equals the target at every point")
        if m["max_rel_dev_where"] and m["max_rel_dev_where"] != m["max_dev_where"]:
            items.append(f"Largest relative deviation {fmt_pct(m['max_rel_dev_pct'], True)}"
                         f" ({signed(m['max_rel_dev_lux'], 0)} lx) on the"
                         f" {_e(m['max_rel_dev_where'])}")
        items.append(f"Darkest target point {fmt_lux(m['emin'])} lx on the"
                     f" {_e(m['emin_where'])}")
    if m["n_shade_faces"]:
        items.append(f"Shade targets ({m['shade_area_m2']:.2f} m²): brightest"
                     f" <b>{fmt_lux(m['shade_max_lux'])} lx</b> on the"
                     f" {_e(m['shade_max_where'])}, mean {fmt_lux(m['shade_mean_lux'])} lx")
    if not m["n_faces"]:
        items.append("No targets in this room.")
    return "<ul class=\"facts\">" + "".join(f"<li>{s}</li>" for s in items) + "</ul>"


def _parts_table(parts):
    if not parts:
        return ""
    head = ("<tr><th>surface</th><th>area (m²)</th><th>target Em</th><th>Em</th>"
            "<th>target U0</th><th>U0</th><th>RMSE</th><th>largest dev.</th>"
            "<th>shade max (lx)</th></tr>")
    rows = []
    for p in parts:
        m = p["metrics"]
        cls = f' class="{_e(p["kind"]).replace(" ", "-")}"'
        dev = ("–" if not np.isfinite(m["max_dev_lux"])
               else f"{signed(m['max_dev_lux'], 0)} lx ({fmt_pct(m['max_dev_pct'], True)})")
        rows.append(f"<tr{cls}><td>{_e(p['part'])}</td><td>{m['area_m2']:.2f}</td>"
                    f"<td>{fmt_lux(m['target_em'])}</td><td>{fmt_lux(m['em'])}</td>"
                    f"<td>{fmt_ratio(m['target_u0'])}</td><td>{fmt_ratio(m['u0'])}</td>"
                    f"<td>{fmt_pct(m['rmse_pct'])}</td><td>{dev}</td>"
                    f"<td>{fmt_lux(m['shade_max_lux'])}</td></tr>")
    return ("<table class=\"parts\">" + head + "".join(rows) + "</table>")


def facing_text(normal):
    """A luminaire's facing for people: 'down', 'up', '+x'..., else the rounded vector
    (never '-0.00')."""
    n = np.asarray(normal, dtype=float)
    n = n / max(float(np.linalg.norm(n)), 1e-12)
    for axis, name in ((2, "z"), (0, "x"), (1, "y")):
        if abs(n[axis]) > 0.999:
            if axis == 2:
                return "down" if n[2] < 0 else "up"
            return ("+" if n[axis] > 0 else "-") + name
    return ", ".join(f"{(round(float(x), 2) + 0.0):+.2f}" for x in n)


def _lum_table(luminaires, idx, lum_room, room_names, extra_keys):
    # the vote score is the method's internal figure: in luminaires.csv, not here
    head = ("<tr><th>#</th><th>room</th><th>position x, y, z (m)</th><th>facing</th>"
            "<th>flux (lm)</th><th>radius (m)</th>"
            + "".join(f"<th>{_e(k)}</th>" for k in extra_keys) + "</tr>")
    rows = []
    for i in idx:
        l = luminaires[i]
        pos = ", ".join(f"{(round(float(x), 3) + 0.0):.3f}" for x in l.position)
        nrm = facing_text(l.normal)
        rows.append(f"<tr><td>L{i + 1}</td><td>{_e(_room_name(room_names, lum_room[i]))}</td>"
                    f"<td>{pos}</td><td>{nrm}</td><td>{l.flux_lm:.0f}</td>"
                    f"<td>{l.radius_m:.2f}</td>"
                    + "".join(f"<td>{_e(l.extra.get(k, ''))}</td>" for k in extra_keys)
                    + "</tr>")
    if not rows:
        return "<p>No luminaires.</p>"
    return "<table class=\"lums\">" + head + "".join(rows) + "</table>"


def _figure(stage, images, key, caption, embed):
    if key not in images:
        return ""
    return (f'<figure><img src="{_img_src(stage, images[key], embed)}" alt="{_e(caption)}">'
            f"<figcaption>{_e(caption)}</figcaption></figure>")


def _page(title, extra, room_reports, luminaires, lum_room, room_names, scale, stage,
          embed, extra_keys):
    css = _load_css()
    summary = []
    for rr in room_reports:
        m = rr["metrics"]
        summary.append(
            f"<tr><td><a href=\"#room{rr['room']}\">{_e(rr['name'])}</a></td>"
            f"<td>{len(rr['luminaires'])}</td><td>{rr['flux_lm']:.0f}</td>"
            f"<td>{fmt_lux(m['target_em'])}</td><td>{fmt_lux(m['em'])}</td>"
            f"<td>{fmt_ratio(m['target_u0'])}</td><td>{fmt_ratio(m['u0'])}</td>"
            f"<td>{fmt_pct(m['rmse_pct'])}</td><td>{fmt_pct(m['mae_pct'])}</td>"
            f"<td>{_signed_lux(m['max_dev_lux'])}"
            f"</td><td>{fmt_lux(m['shade_max_lux'])}</td></tr>")
        for part in rr["parts"]:
            if part["kind"] not in ("work plane", "group"):
                continue
            q = part["metrics"]
            summary.append(
                f"<tr class=\"sub\"><td>&nbsp;&nbsp;↳ {_e(part['part'])}</td><td></td><td></td>"
                f"<td>{fmt_lux(q['target_em'])}</td><td>{fmt_lux(q['em'])}</td>"
                f"<td>{fmt_ratio(q['target_u0'])}</td><td>{fmt_ratio(q['u0'])}</td>"
                f"<td>{fmt_pct(q['rmse_pct'])}</td><td>{fmt_pct(q['mae_pct'])}</td>"
                f"<td>{_signed_lux(q['max_dev_lux'])}</td>"
                f"<td>{fmt_lux(q['shade_max_lux'])}</td></tr>")
    run = ""
    if extra:
        run = ("<table class=\"run\">" + "".join(
            f"<tr><th>{_e(k)}</th><td>{_e(v)}</td></tr>" for k, v in extra.items())
            + "</table>")
    sections = []
    for rr in room_reports:
        im_ = rr["images"]
        figs = "".join([
            _figure(stage, im_, "target", "Target illuminance, all planes unfolded", embed),
            _figure(stage, im_, "achieved", "Achieved illuminance, all planes unfolded",
                    embed),
            _figure(stage, im_, "deviation", "Deviation (achieved - target) / target",
                    embed),
            _figure(stage, im_, "plan_achieved", "Plan view: achieved illuminance and"
                    " luminaires", embed),
            _figure(stage, im_, "plan_deviation", "Plan view: deviation and luminaires",
                    embed)])
        sections.append(
            f"<section id=\"room{rr['room']}\"><h2>{_e(rr['name'])}"
            f" <span class=\"rid\">room id {rr['room']}</span></h2>"
            f"<p>All target points of the room ({rr['metrics']['area_m2']:.2f} m² with a"
            f" target, {len(rr['luminaires'])} luminaire(s), {rr['flux_lm']:.0f} lm):</p>"
            + _metric_table(rr["metrics"]) + _facts(rr["metrics"])
            + "<h3>By surface</h3>" + _parts_table(rr["parts"])
            + "<h3>Images</h3><div class=\"figs\">" + figs + "</div>"
            + f"<h3>Luminaires in {_e(rr['name'])}</h3>"
            + _lum_table(luminaires, rr["luminaires"], lum_room, room_names, extra_keys)
            + "</section>")
    legend = (
        f"<p class=\"legend\">Illuminance images: viridis, linear from"
        f" {fmt_lux(scale['lux_min'])} to {fmt_lux(scale['lux_max'])} lx for every room"
        f" (brighter values in the top colour); grey hatching: no target; black in target"
        f" images: shade target (0 lx). Deviation images: (achieved - target) / target,"
        f" blue too dark, white on target, red too bright, ±"
        f"{100 * scale['deviation_limit']:.0f} % at the ends; on shade targets the achieved"
        f" light in % of the room's mean target.</p>"
        f"<div class=\"bars\"><img src=\"{_img_src(stage, 'colourbar_lux.png', embed)}\""
        f" alt=\"illuminance colour scale\"><img src=\""
        f"{_img_src(stage, 'colourbar_deviation.png', embed)}\" alt=\"deviation colour"
        f" scale\"></div>")
    # one room: its own table already lists every luminaire
    all_lums = ("" if len(room_reports) <= 1 else "<h2>All luminaires</h2>" + _lum_table(
        luminaires, range(len(luminaires)), lum_room, room_names, extra_keys))
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{_e(title)}</title>
<style>{css}</style></head><body>
<h1>{_e(title)}</h1>
<p>{len(luminaires)} luminaire(s) in {len(room_reports)} room(s). <i>Achieved</i> is the
forward solve of the luminaires at the mesh vertices; values vary linearly over each
triangle and the metrics integrate them over the faces that carry a target (EN 12464-1
terms: Em mean, Emin, Emax, uniformity U0 = Emin / Em). Shade targets (0 lx, must stay
dark) are reported apart.</p>
{run}
<h2>Summary</h2>
<table class="summary"><tr><th>room</th><th>luminaires</th><th>flux (lm)</th>
<th>target Em (lx)</th><th>Em (lx)</th><th>target U0</th><th>U0</th><th>RMSE</th>
<th>mean abs. dev.</th><th>largest dev.</th><th>shade max (lx)</th></tr>
{''.join(summary)}</table>
<h2>Colour scales</h2>
{legend}
{''.join(sections)}
{all_lums}
<p class="foot">Files next to this page: rooms.csv (one row per room), surfaces.csv (per
surface and work plane), luminaires.csv, metrics.json, the PNG images and their values as
EXR (channels target, achieved, deviation). Generated by invrad.</p>
</body></html>
"""
