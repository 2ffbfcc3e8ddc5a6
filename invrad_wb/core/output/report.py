"""Verification report: how far the achieved illuminance is from the targets, per room.

A document for the client (``index.html``, self-contained, and ``report.pdf`` beside it):

* a cover: project, date, a summary (rooms, luminaires, how many rooms meet their
  targets) and one row per room;
* a page per room: target vs achieved Em, Emin, Emax, U0 with the verdict
  (:func:`invrad_wb.core.output.metrics.verdict`), where the largest deviations are, the
  room from above (false colour, labelled iso-lux lines, luminaires) beside its value
  grid, every surface unfolded (target and achieved on one scale, one colour bar), the
  deviation, a table per surface and the room's luminaires;
* a technical appendix: run settings, the statistical figures (RMSE, mean absolute
  deviation, area within tolerance), plane ids, the colour scales and the files.

Beside it: ``rooms.csv`` (one row per room, all its targets), ``surfaces.csv`` (per room:
work plane, surfaces, each plane, custom groups), ``luminaires.csv`` (with the vote score),
``metrics.json``, the figures as PNG and their values as EXR (unfolded and plan rasters,
channels target, achieved, deviation). Metrics: :mod:`invrad_wb.core.output.metrics`;
figures: :mod:`invrad_wb.core.output.room_figures` (matplotlib); the page: the Jinja2
template ``templates/verification_report.html.j2`` (autoescape); the PDF:
:mod:`invrad_wb.core.output.document` (WeasyPrint). All files are written to a staging
folder first and moved into place only when everything succeeded, ``index.html`` last: a
failed run leaves the previous report untouched.

Colour scales are chosen once per room: illuminance from 0 to
:func:`~invrad_wb.core.output.images.nice_max` of the larger of the room's highest target
and the 99th percentile of its achieved illuminance on target points (``lux_range``
overrides for every room); deviation ``(E - T) / T`` within +-``deviation_limit``, on shade
targets (T = 0) the achieved light in % of the room's mean target.
"""
from dataclasses import dataclass, field
import base64
import csv
import datetime
import io
import json
import os
import shutil
import tempfile

import numpy as np

from invrad_wb.errors import SceneError
from invrad_wb.core.output import images as im
from invrad_wb.core.geometry.meshing import nearest_site
from invrad_wb.core.output import document
from invrad_wb.core.output import room_figures as rfig
from invrad_wb.core.output.images import describe_plane, room_floor_z  # noqa: F401 - API
from invrad_wb.core.output.metrics import (  # noqa: F401 - part of this module's API
    TOLERANCE, U0_CAP, describe_point, relative_deviation, room_metrics, verdict)

#: colour scale of the deviation images: -50 % .. +50 %
DEVIATION_LIMIT = im.DEVIATION_LIMIT
_NAN = float("nan")
_TEMPLATE = "verification_report.html.j2"


# ---------------------------------------------------------------------------- results
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
    pdf: str = ""
    notes: list = field(default_factory=list)

    @property
    def index_html(self):
        return self.html




def room_name(room_names, r, project=None, single=False):
    """A room's name for people: its given name; unnamed, the project's name when it is
    the only room, else 'Room <id + 1>'."""
    name = None
    if room_names is not None:
        try:
            name = room_names[r]
        except (KeyError, IndexError, TypeError):
            name = None
    if name is not None and str(name).strip():
        return str(name)
    return project if single and project else f"Room {int(r) + 1}"


def luminaire_rooms(scene, luminaires):
    """Room id of each luminaire: its ``room``, else the room of the nearest face centroid
    (one k-d tree query for all: 100,000 luminaires took minutes one by one)."""
    out = [None if l.room is None else int(l.room) for l in luminaires]
    free = [i for i, r in enumerate(out) if r is None]
    if not free:
        return out
    pos = np.array([luminaires[i].position for i in free], dtype=np.float64).reshape(-1, 3)
    for i, k in zip(free, nearest_site(scene.face_centroids, pos)):
        out[i] = int(scene.face_room[int(k)])
    return out



# ---------------------------------------------------------------------------- text
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




# ---------------------------------------------------------------------------- the report
def build_report(scene, target_vertex_lux, achieved_vertex_lux, luminaires, out_dir,
                 room_names=None, title="Lighting verification", extra=None,
                 groups=None, lux_range=None, deviation_limit=DEVIATION_LIMIT,
                 metres_per_pixel=None, tolerance=TOLERANCE, embed_images=True,
                 write_exr=True, rooms=None, project=None, pdf=True, verdicts=None):
    """Write the report of a forward solve against the targets.

    Parameters
    ----------
    scene : Scene
    target_vertex_lux, achieved_vertex_lux : (n,) float64, lux per scene vertex
        (``scene.vertex_targets()`` and :func:`invrad_wb.core.forward.render.render`)
    luminaires : list of Luminaire (``room`` groups them; None = room of the nearest face)
    out_dir : folder (created); files are replaced atomically, ``index.html`` last
    room_names : sequence or dict, room id -> name (default: see :func:`room_name`)
    title : str, the document's title
    extra : dict, run information for the technical appendix and metrics.json
        (e.g. ``{"interreflection": True, "backend": "opencl"}``)
    groups : list of (room, name, faces), optional
        Extra face sets to evaluate, e.g. a task area; rows in the room's surface table.
    lux_range : (vmin, vmax) lux of every illuminance figure (default: per room, see the
        module docstring)
    deviation_limit : fraction drawn in the end colours of deviation figures (0.5 = 50 %)
    metres_per_pixel : float, pixel size of the EXR rasters (default: per room, so that
        the raster is at most about 800 pixels)
    tolerance : float, for ``within_tol_pct`` and the verdicts
    embed_images : bool, inline the PNGs into index.html (self-contained page); else link
    write_exr : bool, also write the values of the figures as half-float EXR, channels
        ``target``, ``achieved`` (lux) and ``deviation`` (fraction), NaN off the faces
    rooms : list of room ids to report (default all)
    project : str, the project's name on the cover (default: the scene file's name)
    verdicts : dict room id -> dict, optional
        Per-room verdicts of the locate pipeline (``invrad_wb.app.pipeline.room_verdicts``):
        a room whose targets are requirements (``targets: 'requirement'``) is judged by it
        (Em within -10/+30 % of the level, U0 against EN 12464-1 for the level, on the task
        area) instead of against its uniform target's U0; exact rooms show their fit
        quality (``words``)
    pdf : bool, also print ``report.pdf`` (skipped with a warning in ``notes`` when
        WeasyPrint is not installed)

    Returns
    -------
    :class:`ReportPaths`
    """
    target = np.asarray(target_vertex_lux, dtype=np.float64).reshape(-1)
    achieved = np.asarray(achieved_vertex_lux, dtype=np.float64).reshape(-1)
    if len(target) != len(scene.vertices) or len(achieved) != len(scene.vertices):
        raise SceneError(f"report: {len(target)} target and {len(achieved)} achieved values"
                         f" for {len(scene.vertices)} scene vertices", scene.source)
    if lux_range is not None and not float(lux_range[1]) > float(lux_range[0]):
        raise ValueError(f"lux_range {lux_range}: the top must be above the bottom")
    if not float(deviation_limit) > 0:
        raise ValueError(f"deviation_limit {deviation_limit}: must be > 0")
    rooms = [int(r) for r in (scene.rooms if rooms is None else rooms)]
    if project is None:
        project = _project_name(scene)
    run = _Run(scene, target, achieved, luminaires, luminaire_rooms(scene, luminaires),
               list(groups or []), lux_range, float(deviation_limit), metres_per_pixel,
               tolerance, write_exr, verdicts={int(k): v for k, v in (verdicts or {}).items()})
    stage = _Staging(out_dir)
    try:
        reports = [_room_report(stage, run, r, room_name(room_names, r, project,
                                                          len(rooms) == 1))
                   for r in rooms]
        names = {rr["room"]: rr["name"] for rr in reports}
        _write_tables(stage, run, reports, lambda r: names.get(r) or room_name(
            room_names, r, project, len(rooms) == 1))
        scale = {"lux_range": None if lux_range is None else [float(x) for x in lux_range],
                 "rooms": {rr["room"]: rr["lux_max"] for rr in reports},
                 # one scale for a whole view (the workbench's false colour): the highest
                 "lux_max": max([rr["lux_max"] for rr in reports] or [1.0]),
                 "deviation_limit": run.limit, "colour_map": "viridis",
                 "deviation_map": "RdBu (blue too dark, red too bright)"}
        _write_json(stage, title, extra, scale, reports, run)
        page = _page(stage, run, reports, title, project, extra, embed_images)
        notes = _write_pdf(stage, page) if pdf else []
        stage.text("index.html", page)
        written = stage.commit("index.html")
    finally:
        stage.cleanup()
    return _paths(out_dir, written, reports, scale, notes)


def _project_name(scene):
    src = getattr(scene, "source", None)
    if not src:
        return "invrad scene"
    return os.path.splitext(os.path.basename(str(src)))[0]


@dataclass
class _Run:
    """The inputs of one report, shared by its rooms."""
    scene: object
    target: np.ndarray
    achieved: np.ndarray
    luminaires: list
    lum_room: list
    groups: list
    lux_range: tuple
    limit: float
    mpp: float
    tolerance: float
    write_exr: bool
    refine: bool = True
    backend: str = "auto"
    verdicts: dict = None


def _paths(out_dir, written, reports, scale, notes):
    out = os.path.abspath(out_dir)
    j = lambda n: os.path.join(out, n)  # noqa: E731
    rooms = [{k: v for k, v in rr.items() if k != "figures"} for rr in reports]
    pdf = j("report.pdf") if j("report.pdf") in written else ""
    return ReportPaths(
        html=j("index.html"), rooms_csv=j("rooms.csv"), luminaires_csv=j("luminaires.csv"),
        surfaces_csv=j("surfaces.csv"), metrics_json=j("metrics.json"), out_dir=out,
        images=[p for p in written if p.endswith(".png")],
        exr=[p for p in written if p.endswith(".exr")], rooms=rooms,
        metrics={rr["room"]: rr["metrics"] for rr in reports}, scale=scale, pdf=pdf,
        notes=notes)


def _room_parts(run, r, rf, floor_z):
    """The room's surface table: work plane and real surfaces (when the room has a work
    plane), custom groups, each plane with a target."""
    scene, t, a, tol = run.scene, run.target, run.achieved, run.tolerance
    parts = []
    virt = rf[scene.face_virtual[rf]]
    if len(virt):
        for part, kind, faces in (("work plane", "work plane", virt),
                                  ("surfaces", "surfaces", rf[~scene.face_virtual[rf]])):
            m = room_metrics(scene, t, a, faces, tol)
            if m["n_faces"]:
                parts.append({"part": part, "kind": kind, "metrics": m})
    for g_room, g_name, g_faces in run.groups:
        if int(g_room) == r:
            parts.append({"part": str(g_name), "kind": "group",
                          "metrics": room_metrics(scene, t, a, g_faces, tol)})
    seen = {}
    for p in scene.planes:
        if p.room != r:
            continue
        m = room_metrics(scene, t, a, p.faces, tol)
        if m["n_faces"]:
            words = describe_plane(p, floor_z)
            seen[words] = seen.get(words, 0) + 1
            label = words if seen[words] == 1 else f"{words} ({seen[words]})"
            parts.append({"part": label, "kind": "plane", "plane": p.index, "metrics": m})
    return parts


def _room_report(stage, run, r, name):
    """Metrics, figures and rasters of one room (a dict, see :class:`ReportPaths`)."""
    scene = run.scene
    rf = np.flatnonzero(scene.face_room == r)
    floor_z = room_floor_z(scene, r)
    m_all = room_metrics(scene, run.target, run.achieved, rf, run.tolerance)
    lums = [i for i in range(len(run.luminaires)) if run.lum_room[i] == r]
    ref = m_all["target_em"]
    if not np.isfinite(ref):
        lit = np.isfinite(run.target) & (run.target > 0)
        ref = float(run.target[lit].mean()) if lit.any() else _NAN
    dev = relative_deviation(run.target, run.achieved, ref)
    vmax = (float(run.lux_range[1]) if run.lux_range is not None
            else rfig.scale_top(run.target, run.achieved, rf, scene))
    view = rfig.RoomView(
        scene, r, name, run.target, run.achieved, dev, vmax, run.limit,
        np.array([run.luminaires[i].position for i in lums]).reshape(-1, 3),
        [f"L{i + 1}" for i in lums], 0.0 if run.lux_range is None
        else float(run.lux_range[0]), reference=ref)
    # steep light next to luminaires drawn from the exact direct light, not a polygon
    view.mesh = rfig.display_mesh(scene, r, run.target, run.achieved, vmax, ref,
                                  run.luminaires if run.refine else None, run.backend)
    figures = _room_figures(stage, view, f"room{r}", m_all["target_em"])
    if run.write_exr:
        figures.update(_room_rasters(stage, run, r, dev, f"room{r}", view.unfolded()))
    return {"room": r, "name": name, "metrics": m_all,
            "verdict": _verdict(m_all, run, r),
            "parts": _room_parts(run, r, rf, floor_z), "luminaires": lums,
            "flux_lm": float(sum(run.luminaires[i].flux_lm for i in lums)),
            "images": figures, "floor_z": floor_z, "lux_max": vmax,
            "layout": view.unfolded().layout}


def _verdict(m, run, r):
    """The room's verdict: the pipeline's for requirement targets (Em against the level,
    U0 against EN 12464-1 for it, saying so), else :func:`verdict`; ``words`` and
    ``why_not`` carry the pipeline's sentences (the fit quality of exact targets)."""
    v = verdict(m, run.tolerance)
    pv = (run.verdicts or {}).get(r)
    if pv is None:
        return v
    if pv.get("targets") == "requirement":
        v = {"em": pv["em_ok"], "u0": pv["u0_ok"], "shade": None,
             "u0_required": pv["u0_required"], "ok": pv["met"],
             "requirement": {"level": pv["level_lux"], "em": pv["em_lux"], "u0": pv["u0"],
                             "u0_source": pv["u0_source"]}}
    v["words"] = pv.get("words", "")
    v["why_not"] = list(pv.get("why_not", ())) + [x for x in (pv.get("advice"),
                                                              pv.get("warning")) if x]
    return v


def _room_figures(stage, view, stem, required):
    """The room's three figures as PNG files; returns kind -> file name."""
    out = {}
    for kind, png in (("plan", rfig.plan_pair(view, required)),
                      ("surfaces", rfig.unfolded_pair(view)),
                      ("deviation", rfig.deviation_pair(view))):
        if png is None:
            continue
        fname = f"{stem}_{kind}.png"
        with open(stage.path(fname), "wb") as fh:
            fh.write(png)
        out[kind] = fname
    return out


def _room_rasters(stage, run, r, dev, stem, layout):
    """The values behind the figures as half-float EXR (unfolded and from above)."""
    scene, out = run.scene, {}
    ras = im.unfolded_raster(scene, r, run.mpp, layout=layout)
    fname = f"{stem}_unfolded.exr"
    im.save_exr(stage.path(fname), np.stack([ras.sample(run.target), ras.sample(
        run.achieved), ras.sample(dev)], axis=2), ["target", "achieved", "deviation"],
        half=True)
    out["unfolded_exr"] = fname
    plan = im.plan_raster(scene, r, run.mpp)
    if plan is not None:
        fname = f"{stem}_plan.exr"
        im.save_exr(stage.path(fname), np.stack([plan.sample(run.target), plan.sample(
            run.achieved), plan.sample(dev)], axis=2), ["target", "achieved", "deviation"],
            half=True)
        out["plan_exr"] = fname
    return out


def _write_tables(stage, run, reports, name_of):
    """rooms.csv, surfaces.csv and luminaires.csv (every figure, the vote score too)."""
    head = ["room", "name", "luminaires", "flux_lm"] + _metric_header()
    rows = [[rr["room"], rr["name"], len(rr["luminaires"]), _csv_value(rr["flux_lm"])]
            + _metric_cells(rr["metrics"]) for rr in reports]
    stage.text("rooms.csv", _csv_text(head, rows))
    head = ["room", "name", "part", "kind"] + _metric_header()
    rows = [[rr["room"], rr["name"], p["part"], p["kind"]] + _metric_cells(p["metrics"])
            for rr in reports for p in rr["parts"]]
    stage.text("surfaces.csv", _csv_text(head, rows))
    keys = _extra_keys(run.luminaires)
    head = ["luminaire", "room", "room_name", "x_m", "y_m", "z_m", "nx", "ny", "nz",
            "flux_lm", "radius_m", "score"] + keys
    rows = [[i + 1, run.lum_room[i], name_of(run.lum_room[i])]
            + [_csv_value(x) for x in l.position] + [_csv_value(x) for x in l.normal]
            + [_csv_value(l.flux_lm), _csv_value(l.radius_m), _csv_value(l.score)]
            + [_csv_value(l.extra.get(k)) for k in keys]
            for i, l in enumerate(run.luminaires)]
    stage.text("luminaires.csv", _csv_text(head, rows))


def _extra_keys(luminaires):
    keys = []
    for l in luminaires:
        for k, v in l.extra.items():
            if k not in keys and isinstance(v, (str, int, float, bool)):
                keys.append(k)
    return keys


def _write_json(stage, title, extra, scale, reports, run):
    data = {"title": title, "extra": extra or {}, "scale": scale,
            "rooms": [{k: v for k, v in rr.items() if k != "figures"} for rr in reports],
            "luminaires": [dict(l.to_dict(), room=run.lum_room[i])
                           for i, l in enumerate(run.luminaires)]}
    stage.text("metrics.json", json.dumps(_json_clean(data), indent=1,
                                          default=_json_default) + "\n")


def _write_pdf(stage, page):
    """report.pdf from the page (its images are inlined or beside it in the stage)."""
    try:
        document.write_pdf(page, stage.dir, stage.path("report.pdf"))
    except document.PdfUnavailable as exc:
        stage.names.remove("report.pdf")
        return [str(exc)]
    return []


def _png_data_uri(path):
    with open(path, "rb") as fh:
        return "data:image/png;base64," + base64.b64encode(fh.read()).decode("ascii")


# ---------------------------------------------------------------------------- the page
def _page(stage, run, reports, title, project, extra, embed):
    """index.html: cover, a page per room, technical appendix (Jinja2, autoescaped)."""
    def src(fname):
        return _png_data_uri(os.path.join(stage.dir, fname)) if embed else fname

    judged = [rr for rr in reports if rr["verdict"]["ok"] is not None]
    rooms = [_room_context(rr, run, src) for rr in reports]
    return document.render_page(
        _TEMPLATE, title=title, project=project,
        date=datetime.date.today().isoformat(), rooms=rooms,
        n_lum=len(run.luminaires),
        flux=f"{sum(l.flux_lm for l in run.luminaires):.0f}",
        n_pass=sum(1 for rr in judged if rr["verdict"]["ok"]), n_judged=len(judged),
        tol=f"{100 * run.tolerance:.0f}", limit=f"{100 * run.limit:.0f}",
        u0_cap=f"{U0_CAP:g}",
        run=[(str(k), str(v)) for k, v in (extra or {}).items()],
        appendix=[_appendix_row(rr) for rr in reports],
        fixed_range=None if run.lux_range is None else
        f"{fmt_lux(run.lux_range[0])} to {fmt_lux(run.lux_range[1])} lx")


def _diff(a, t, pct=True):
    if not (np.isfinite(a) and np.isfinite(t)):
        return "–"
    s = f"{signed(a - t, 0)} lx" if abs(a - t) >= 10 else f"{signed(a - t, 2)} lx"
    if pct and t > 0:
        s += f" ({signed(100 * (a - t) / t, 1)} %)"
    return s


def _metric_rows(m, v):
    """Target / achieved / difference rows of a room's table, with the verdict per row."""
    q = v.get("requirement")
    if q is not None:       # a level: Em -10/+30 %, U0 of EN 12464-1, on the task area
        return [
            {"label": "Em, mean on the task area (lx)", "target":
             f"{fmt_lux(q['level'])} (-10/+30 %)", "achieved": fmt_lux(q["em"]),
             "diff": _diff(q["em"], q["level"]), "ok": v["em"]},
            {"label": "U0 = Emin / Em", "target":
             f"at least {fmt_ratio(v['u0_required'])} ({q['u0_source']})",
             "achieved": fmt_ratio(q["u0"]), "diff": signed(q["u0"] - v["u0_required"], 2),
             "ok": v["u0"]}]
    du = ("–" if not np.isfinite(m["u0"] - m["target_u0"])
          else signed(m["u0"] - m["target_u0"], 2))
    return [
        {"label": "Em, mean (lx)", "target": fmt_lux(m["target_em"]),
         "achieved": fmt_lux(m["em"]), "diff": _diff(m["em"], m["target_em"]),
         "ok": v["em"]},
        {"label": "Emin (lx)", "target": fmt_lux(m["target_emin"]),
         "achieved": fmt_lux(m["emin"]), "diff": _diff(m["emin"], m["target_emin"]),
         "ok": None},
        {"label": "Emax (lx)", "target": fmt_lux(m["target_emax"]),
         "achieved": fmt_lux(m["emax"]), "diff": _diff(m["emax"], m["target_emax"]),
         "ok": None},
        {"label": "U0 = Emin / Em", "target": fmt_ratio(m["target_u0"]) + (
            f" (needed: {fmt_ratio(v['u0_required'])})" if np.isfinite(v["u0_required"])
            and v["u0_required"] < m["target_u0"] - 1e-9 else ""),
         "achieved": fmt_ratio(m["u0"]), "diff": du, "ok": v["u0"]}]


def _facts(m):
    """Where the light deviates, in sentences: (lead, strong, tail) triples."""
    items = []
    if m["n_faces"] > m["n_shade_faces"]:
        items.append(("", fmt_pct(m["within_tol_pct"]),
                      f" of the area with a target is within ±{m['tolerance_pct']:.0f} %"
                      " of its target."))
        if m["max_dev_where"]:
            sign = "too bright" if m["max_dev_lux"] > 0 else "too dark"
            items.append(("Largest deviation: ", f"{signed(m['max_dev_lux'], 0)} lx"
                          f" ({fmt_pct(m['max_dev_pct'], True)})",
                          f", {sign}, on the {m['max_dev_where']}."))
        else:
            items.append(("", "The achieved illuminance equals the target everywhere.", ""))
        if m["max_rel_dev_where"] and m["max_rel_dev_where"] != m["max_dev_where"]:
            items.append(("Largest relative deviation: ",
                          fmt_pct(m["max_rel_dev_pct"], True),
                          f" ({signed(m['max_rel_dev_lux'], 0)} lx) on the"
                          f" {m['max_rel_dev_where']}."))
        items.append(("Darkest target point: ", f"{fmt_lux(m['emin'])} lx",
                      f" on the {m['emin_where']}."))
    if m["n_shade_faces"]:
        items.append((f"Areas to keep dark ({m['shade_area_m2']:.2f} m²): brightest ",
                      f"{fmt_lux(m['shade_max_lux'])} lx",
                      f" on the {m['shade_max_where']}, mean"
                      f" {fmt_lux(m['shade_mean_lux'])} lx."))
    if not m["n_faces"]:
        items.append(("", "No targets in this room.", ""))
    return items


def _part_row(p):
    m = p["metrics"]
    return {"part": p["part"], "kind": p["kind"].replace(" ", "-"),
            "area": f"{m['area_m2']:.2f}", "target_em": fmt_lux(m["target_em"]),
            "em": fmt_lux(m["em"]), "target_u0": fmt_ratio(m["target_u0"]),
            "u0": fmt_ratio(m["u0"]), "dev": "–" if not np.isfinite(m["max_dev_lux"])
            else f"{signed(m['max_dev_lux'], 0)} lx ({fmt_pct(m['max_dev_pct'], True)})",
            "shade": fmt_lux(m["shade_max_lux"])}


def _unique_rows(parts):
    """The surface table's rows, each set of faces once (a room's only work plane is both
    'work plane' and a plane: listed once, as the work plane)."""
    rows, seen = [], set()
    for p in parts:
        m = p["metrics"]
        key = (round(m["area_m2"], 9), m["n_faces"], m["em"], m["target_em"])
        if key not in seen:
            seen.add(key)
            rows.append(_part_row(p))
    return rows if len(rows) > 1 else []


def _facing(lum):
    """:func:`facing_text`, with the tilt and pan of an aimed luminaire (locate --aim free
    gives them in its extras)."""
    ex = getattr(lum, "extra", None) or {}
    if isinstance(ex.get("tilt_deg"), (int, float)) and ex["tilt_deg"] >= 0.5:
        return (f"{facing_text(lum.normal)} (tilt {ex['tilt_deg']:.1f}\u00b0, pan"
                f" {float(ex.get('pan_deg', 0.0)):.0f}\u00b0)")
    return facing_text(lum.normal)


def _lum_rows(run, idx):
    keys = _extra_keys(run.luminaires)
    return keys, [{"label": f"L{i + 1}", "position": ", ".join(
        f"{(round(float(x), 2) + 0.0):.2f}" for x in run.luminaires[i].position),
        "facing": _facing(run.luminaires[i]),
        "flux": f"{run.luminaires[i].flux_lm:.0f}",
        "radius": f"{run.luminaires[i].radius_m:.2f}",
        "extra": [str(run.luminaires[i].extra.get(k, "")) for k in keys]} for i in idx]


_CAPTIONS = {
    "plan": "From above: achieved illuminance on the {what} with labelled iso-lux lines"
            " and the luminaires (L = row of the luminaire table); right, the values on a"
            " calculation grid (EN 12464-1 spacing). One scale, 0 to {top} lx.",
    "surfaces": "Every surface of the room, unfolded as seen from inside (floor in the"
                " middle, walls folded out around it, ceiling beyond the top wall): target"
                " and achieved illuminance on one scale, 0 to {top} lx.{extra}",
    "deviation": "Deviation of the achieved from the target illuminance, (achieved -"
                 " target) / target: blue too dark, white on target, red too bright,"
                 " ±{limit} % at the ends.{extra}"}


#: luminaire rows of a room's table in the HTML/PDF report; luminaires.csv has them all
#: (10,000 rows made a 300-page PDF)
MAX_TABLE_LUMINAIRES = 200


def _room_context(rr, run, src):
    m, v = rr["metrics"], rr["verdict"]
    keys, lums = _lum_rows(run, rr["luminaires"][:MAX_TABLE_LUMINAIRES])
    shade = " Black: areas to keep dark (0 lx); grey: no target." \
        if m["n_shade_faces"] else " Grey: no target."
    top_plane = [p for p in rr["parts"] if p["kind"] == "work plane"]
    fmt = {"top": fmt_lux(rr["lux_max"]), "limit": f"{100 * run.limit:.0f}",
           "what": "work plane" if top_plane else "floor",
           "extra": shade if m["n_faces"] else ""}
    figures = [{"src": src(f), "kind": k, "caption": _CAPTIONS[k].format(**fmt)}
               for k, f in rr["images"].items() if k in _CAPTIONS]
    return {"id": rr["room"], "name": rr["name"], "verdict": v,
            "area": f"{m['area_m2']:.2f}", "n_lum": len(rr["luminaires"]),
            "flux": f"{rr['flux_lm']:.0f}", "rows": _metric_rows(m, v),
            "facts": _facts(m), "figures": figures,
            "parts": _unique_rows(rr["parts"]),
            "lum_keys": keys, "lums": lums,
            "more_lums": max(0, len(rr["luminaires"]) - len(lums)),
            "target_em": fmt_lux(m["target_em"]),
            "em": fmt_lux(m["em"]), "target_u0": fmt_ratio(m["target_u0"]),
            "u0": fmt_ratio(m["u0"]), "shade_max": fmt_lux(m["shade_max_lux"]),
            "has_target": bool(m["n_faces"]), **_requirement_context(v)}


def _requirement_context(v):
    """Overview cells of a room judged as a requirement (level, U0 of EN 12464-1)."""
    q = v.get("requirement")
    if q is None:
        return {}
    return {"target_em": fmt_lux(q["level"]), "em": fmt_lux(q["em"]),
            "target_u0": f"{fmt_ratio(v['u0_required'])} ({q['u0_source']})",
            "u0": fmt_ratio(q["u0"])}


def _appendix_row(rr):
    m = rr["metrics"]
    planes = ", ".join(f"{p['plane']}: {p['part']}" for p in rr["parts"]
                       if p["kind"] == "plane")
    return {"name": rr["name"], "id": rr["room"], "rmse": fmt_pct(m["rmse_pct"]),
            "rmse_lux": fmt_lux(m["rmse_lux"]), "mae": fmt_pct(m["mae_pct"]),
            "bias": fmt_pct(m["bias_pct"], True), "within": fmt_pct(m["within_tol_pct"]),
            "faces": f"{m['n_lit_faces']} / {m['n_transition_faces']} /"
                     f" {m['n_shade_faces']}", "points": m["n_points"],
            "top": fmt_lux(rr["lux_max"]), "layout": rr["layout"], "planes": planes}
