"""After a locate run: new peaks without voting again, verification and the metrics sheet.

The workbench keeps the :class:`~invrad_wb.app.pipeline.PipelineResult` of the last
*Locate luminaires* run per document; these headless functions work on it and on the
document:

* :func:`repeak` post-processes the stored votes again with a new threshold and
  neighbourhood (:meth:`invrad_wb.core.inverse.locate.LocateResult.repeak`) and replaces the rooms'
  fixtures, one undoable transaction;
* :func:`verify` solves forward (direct + interreflected light) for the light fixtures that
  are in the document now (moved, deleted or added by hand included), computes the
  per-room metrics and writes the report (:func:`invrad_wb.app.pipeline.write_report`);
* :func:`write_sheet` puts the per-room metrics into a Spreadsheet of the document, one
  undoable transaction.

Like the pipeline, nothing here changes the document before its last step, so a failed
or cancelled call leaves it as it was.
"""
from dataclasses import dataclass, field
import os
import time

import numpy as np

from invrad_wb.errors import LuminaireError, SceneError
from invrad_wb.app import settings as S
from invrad_wb.app.document import transaction
from invrad_wb.app.fixtures import fixture_luminaire, insert_fixtures, room_fixtures
from invrad_wb.app.pipeline import (_progress, assign_rooms, by_room, prepare, write_report,
                                    _write_json)
from invrad_wb.app.rooms import room_name

#: Name of the metrics spreadsheet (its Label is :data:`SHEET_LABEL`).
SHEET_NAME = S.SHEET_NAME
SHEET_LABEL = "Lighting report"

#: Columns of the metrics sheet: (key of a metrics row, header). The keys are those of
#: the report's metrics (:func:`invrad_wb.core.output.report.room_metrics`), so that the sheet
#: shows the report's own numbers.
SHEET_COLUMNS = [
    ("room", "Room"),
    ("part", "Targets"),
    ("luminaires", "Luminaires"),
    ("flux_lm", "Flux (lm)"),
    ("target_em", "Target Em (lx)"),
    ("em", "Em (lx)"),
    ("emin", "Emin (lx)"),
    ("emax", "Emax (lx)"),
    ("u0", "U0"),
    ("rmse_pct", "RMSE (%)"),
    ("max_rel_dev_pct", "Largest deviation (%)"),
    ("within_tol_pct", "Within tolerance (%)"),
    ("shade_max_lux", "Shade max (lx)"),
]
#: Points with a target below this fraction of the mean target are not candidates for
#: the largest relative deviation (as in the report: soft target edges would always win).
REL_DEV_MIN_TARGET = 0.1
TOLERANCE = 0.2


@dataclass
class VerifyResult:
    """What :func:`verify` computed.

    Attributes
    ----------
    building : BuildingScene
    luminaires : list of Luminaire (room ids set), read from the document's fixtures
    target, achieved : (n,) float64 lux at the scene's vertices (target NaN = no target)
    rows : list of dict, per room and part: the report's metrics (:func:`report_rows`),
        else :func:`room_metrics`
    summary : dict (also ``summary.json`` in the report folder)
    report : what the report builder returned (None without a report folder)
    skipped : labels of light fixtures left out (no LuminousFlux)
    """
    building: object
    luminaires: list
    target: np.ndarray
    achieved: np.ndarray
    rows: list
    summary: dict = field(default_factory=dict)
    report: object = None
    skipped: list = field(default_factory=list)
    timings: dict = field(default_factory=dict)


def insert(doc, building, luminaires, replace=True, name=None):
    """Insert luminaires into their rooms as fixtures (one transaction); the new objects."""
    for p in building.rooms:
        try:
            p.space.Name
        except Exception:
            raise SceneError("a room of the stored result was deleted from the document;"
                             " run Locate luminaires again", doc.Label)
    groups = by_room(building, luminaires)
    return insert_fixtures(doc, [(p.space, groups[p.room_id]) for p in building.rooms],
                           replace=replace,
                           name=name or f"invrad: {len(luminaires)} luminaire(s)")


def repeak(result, threshold=None, neighbourhood_m=None, progress=None):
    """New peaks from the stored votes of a pipeline result (no document change).

    Parameters
    ----------
    result : PipelineResult with ``locate_result`` (a LocateResult)
    threshold : float in [0, 254], optional
    neighbourhood_m : float >= 0, metres, optional
    progress : callable(fraction, message) -> bool, optional; False cancels

    Returns
    -------
    list of Luminaire (with room ids: a lighting zone's go to the room that contains
    them); ``result.luminaires`` is left alone, so that the caller replaces it only once
    the fixtures are in the document.
    """
    loc = getattr(result, "locate_result", None)
    if loc is None or not hasattr(loc, "repeak"):
        raise SceneError("no stored locate result to post-process: run Locate luminaires"
                         " first")
    step = _progress(progress, 0.0, 1.0)
    # the core's refinement reports a fraction only
    loc.repeak(threshold=threshold, neighbourhood=neighbourhood_m,
               progress=lambda frac, msg="refinement": step(frac, f"peaks: {msg}"))
    # requirement rooms' regular layouts (and lone exact rooms) are not from these votes
    return assign_rooms(result.building, loc.luminaires) + list(
        getattr(loc, "fixed_luminaires", []))


def document_luminaires(building):
    """The light fixtures in the rooms of ``building``, as Luminaires with room ids.

    Returns
    -------
    (luminaires, skipped) : list of Luminaire, list of labels of fixtures without a flux
    """
    lums, skipped = [], []
    for p in building.rooms:
        for obj in room_fixtures(p.space, generated_only=False):
            # a classic fixture's flux is its LuminousFlux property; a NativeIFC one's is in
            # its IFC entity (InvRad_Luminaire), read by the backend (LuminaireError: none)
            try:
                lum = fixture_luminaire(obj)
            except LuminaireError:
                lum = None
            if lum is not None and float(lum.flux_lm or 0.0) > 0:
                lum.room = p.room_id
                lum.extra["fixture"] = obj.Label
                lums.append(lum)
            else:
                skipped.append(obj.Label)
    return lums, skipped


def _part_metrics(t, a, tolerance=TOLERANCE):
    """Vertex-based metrics of one set of target points (the report's keys)."""
    lit = np.isfinite(t) & (t > 0)
    dark = np.isfinite(t) & (t == 0)
    d = {"n_points": int(lit.sum()), "n_shade_points": int(dark.sum())}
    if lit.any():
        tl, al = t[lit], a[lit]
        t_em, em = float(tl.mean()), float(al.mean())
        dev = al - tl
        d.update(target_em=t_em, em=em, emin=float(al.min()), emax=float(al.max()),
                 u0=float(al.min() / em) if em > 0 else float("nan"),
                 rmse_pct=100.0 * float(np.sqrt(np.mean(dev ** 2))) / t_em,
                 within_tol_pct=100.0 * float(np.mean(np.abs(dev) <= tolerance * tl)))
        cand = tl >= REL_DEV_MIN_TARGET * t_em
        if cand.any():
            rel = dev[cand] / tl[cand]
            d["max_rel_dev_pct"] = 100.0 * float(rel[np.argmax(np.abs(rel))])
    if dark.any():
        d["shade_max_lux"] = float(a[dark].max())
    return d


def room_metrics(building, target, achieved, luminaires):
    """Per room: all its targets, then its work plane and surfaces apart.

    Vertex-based (each target point counts the same): the fallback of the sheet when the
    report (which integrates over the faces) is not available. ``u0 = Emin / Em``;
    ``rmse_pct`` is the RMS of (E - T) in % of the mean target; shade points (0 lx) are
    counted apart with their brightest achieved value.

    Returns
    -------
    list of dict, keys of :data:`SHEET_COLUMNS` (missing where they do not apply)
    """
    scene = building.scene
    vr = np.full(len(scene.vertices), -1)
    vr[scene.faces.reshape(-1)] = np.repeat(scene.face_room, 3)
    vvirt = np.zeros(len(scene.vertices), bool)
    vvirt[scene.faces[scene.face_virtual].reshape(-1)] = True
    groups = by_room(building, luminaires)
    rows = []
    for p in building.rooms:
        sel = vr == p.room_id
        lums = groups[p.room_id]
        parts = [("all targets", sel)]
        if (sel & vvirt).any():
            parts += [("work plane", sel & vvirt), ("surfaces", sel & ~vvirt)]
        for part, mask in parts:
            row = {"room": room_name(p.space), "part": part}
            if part == "all targets":
                row.update(luminaires=len(lums), flux_lm=float(sum(l.flux_lm for l in lums)))
            row.update(_part_metrics(target[mask], achieved[mask]))
            if row["n_points"] or row["n_shade_points"]:
                rows.append(row)
    return rows


def report_rows(report, building):
    """The sheet rows from the report's own metrics (``ReportPaths.rooms``), or None if
    the report did not provide them."""
    rooms = getattr(report, "rooms", None)
    if not rooms:
        return None
    names = {p.room_id: room_name(p.space) for p in building.rooms}
    rows = []
    try:
        for rr in rooms:
            name = names.get(rr.get("room"), rr.get("name"))
            row = {"room": name, "part": "all targets",
                   "luminaires": len(rr.get("luminaires") or []),
                   "flux_lm": rr.get("flux_lm")}
            row.update(rr["metrics"])
            rows.append(row)
            for part in rr.get("parts") or []:
                if part.get("kind") in ("work plane", "surfaces"):
                    prow = {"room": name, "part": part["part"]}
                    prow.update(part["metrics"])
                    rows.append(prow)
    except (KeyError, TypeError, AttributeError):
        return None
    return rows


def verify(doc, settings, progress=None, building=None, luminaires=None):
    """Forward solve for the document's fixtures, metrics and report (no document change).

    Parameters
    ----------
    doc : FreeCAD document
    settings : PipelineSettings (``flux_lm`` is not used; ``rooms``, ``resolution_m``,
        ``interreflection``, ``backend``, ``report_dir``, ``base_dir`` are)
    progress : callable(fraction, message) -> bool, optional; False cancels
    building : BuildingScene, optional (from :func:`invrad_wb.app.pipeline.prepare`)
    luminaires : list of Luminaire with room ids, optional (default: the fixtures in the
        rooms, :func:`document_luminaires`)

    Returns
    -------
    VerifyResult
    """
    timings = {}
    t0 = time.perf_counter()
    if building is None:
        building = prepare(doc, settings, _progress(progress, 0.0, 0.1))
    skipped = []
    if luminaires is None:
        luminaires, skipped = document_luminaires(building)
    step = _progress(progress, 0.1, 0.85)
    step(0.0, f"forward solve: {len(luminaires)} luminaire(s)"
              + (" with interreflection" if settings.interreflection else ""))
    scene = building.scene
    t = time.perf_counter()
    if luminaires:        # on the zones' scene: a zone's luminaires light all of it
        from invrad_wb.core.forward.render import render
        achieved = render(building.locate_scene, building.to_zones(luminaires),
                          interreflection=settings.interreflection,
                          backend=settings.backend,
                          progress=lambda frac, msg: step(frac, f"forward solve: {msg}"))
    else:
        achieved = np.zeros(len(scene.vertices))
    timings["render"] = time.perf_counter() - t
    target = scene.vertex_lux.copy() if scene.vertex_lux is not None \
        else scene.vertex_targets()
    from invrad_wb.app.pipeline import _room_stats
    summary = {"document": doc.Label, "resolution_m": settings.resolution_m,
               "interreflection": bool(settings.interreflection),
               "rooms": _room_stats(scene, target, achieved, building.rooms),
               "luminaires": [dict(l.to_dict(), room_name=room_name(building.rooms[l.room].space))
                              for l in luminaires],
               "skipped_fixtures": skipped}
    # per room met or not, as after Locate: a level on the work plane judged on its task
    # area against EN 12464-1's U0 (the whole plane up to the walls is darker: Locate said
    # 'met, Em 205 lx', Verify 'Em 167 lx for 200' of the same fixtures); also the report's
    from invrad_wb.app.pipeline import room_verdicts
    summary["verdicts"] = room_verdicts(building, target, achieved, located=False)
    for d, v in zip(summary["rooms"], summary["verdicts"]):
        d["verdict"] = v
    report = None
    if settings.report_dir:
        _progress(progress, 0.85, 1.0)(0.0, "report")
        t = time.perf_counter()
        report = write_report(settings.report_dir, building, target, achieved, luminaires,
                              summary)
        timings["report"] = time.perf_counter() - t
    rows = report_rows(report, building) or room_metrics(building, target, achieved,
                                                         luminaires)
    summary["metrics"] = rows
    timings["total"] = time.perf_counter() - t0
    summary["timings"] = timings
    if settings.report_dir:
        _write_json(os.path.join(settings.report_dir, "summary.json"), summary)
    return VerifyResult(building, luminaires, target, achieved, rows, summary, report,
                        skipped, timings)


def _cell(value):
    if isinstance(value, (float, np.floating)):
        if not np.isfinite(value):
            return ""
        return f"{value:.3g}" if abs(value) < 10 else f"{value:.1f}"
    if isinstance(value, str):
        return "'" + value                 # a text cell, never a formula or a number
    return str(value)


def write_sheet(doc, rows, name=SHEET_NAME, label=SHEET_LABEL, note=None):
    """The per-room metrics as a Spreadsheet (created or replaced), one undoable step.

    Returns the sheet. Row 1 holds the headers of :data:`SHEET_COLUMNS`, one row per room
    and surface part follows; ``note`` (e.g. the report's path) goes below the table.
    """
    with transaction(doc, "invrad: lighting report sheet"):
        sheet = doc.getObject(name)
        if sheet is None or sheet.TypeId != "Spreadsheet::Sheet":
            sheet = doc.addObject("Spreadsheet::Sheet", name)
        sheet.clearAll()
        sheet.Label = label
        cols = [chr(ord("A") + i) for i in range(len(SHEET_COLUMNS))]
        for c, (_, header) in zip(cols, SHEET_COLUMNS):
            sheet.set(f"{c}1", _cell(header))
        sheet.setStyle(f"A1:{cols[-1]}1", "bold")
        sheet.setColumnWidth("A", 140)
        for r, row in enumerate(rows, start=2):
            for c, (key, _) in zip(cols, SHEET_COLUMNS):
                if key in row and row[key] is not None:
                    sheet.set(f"{c}{r}", _cell(row[key]))
        if note:
            sheet.set(f"A{len(rows) + 3}", _cell(str(note)))
    return sheet


__all__ = ["VerifyResult", "by_room", "insert", "repeak", "document_luminaires",
           "room_metrics", "report_rows", "verify", "write_sheet"]
