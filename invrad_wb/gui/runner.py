"""The workbench's long actions: locate, design, recalculate peaks, verify and report.

Each function is what a command records through ``Gui.doCommand`` (so a macro replays
it) and does the same thing in every case:

1. read what it needs from the document in the main thread (room meshes, targets,
   fixtures) with :func:`invrad_wb.app.pipeline.prepare`;
2. compute in a worker thread behind a progress dialog that can cancel
   (:func:`invrad_wb.gui.progress.run`);
3. change the document in the main thread, as ONE undoable transaction.

A failed or cancelled run changes nothing and says why in a dialog and in the report
view (:mod:`.messages`); the functions then return None instead of raising. The last
locate result of each document is kept in memory (:func:`stored`), so that *Recalculate
peaks* can post-process its votes without voting again; it is forgotten when the
document is closed.

Without a GUI everything runs in the calling thread and messages go to the console.
"""
from dataclasses import dataclass
import os
import time

from invrad_wb.gui import messages, params
from invrad_wb.gui import progress as P


@dataclass
class Stored:
    """A document's last locate run."""
    result: object            # PipelineResult (building, luminaires, locate_result ...)
    settings: object          # PipelineSettings it ran with
    verified: object = None   # VerifyResult of the last Verify and report
    when: float = 0.0


_RESULTS = {}


def stored(doc):
    """The document's last locate run (:class:`Stored`) or None."""
    return None if doc is None else _RESULTS.get(doc.Name)


def forget(doc_name):
    _RESULTS.pop(doc_name, None)


def _doc(doc):
    import FreeCAD
    doc = doc or FreeCAD.ActiveDocument
    if doc is None:
        from invrad_wb.errors import SceneError
        raise SceneError("no active document: open or create one with rooms (Arch Spaces)")
    if isinstance(doc, str):
        doc = FreeCAD.getDocument(doc)
    return doc


def _colour_fixtures(doc, names):
    """The fixtures' look (app.fixtures.style_fixture; make_fixture sets it already, this
    restores it after an undo/redo brought old view objects back)."""
    import FreeCAD
    if not FreeCAD.GuiUp:
        return
    from invrad_wb.app.fixtures import style_fixture
    for n in names:
        obj = doc.getObject(n)
        if obj is not None:
            style_fixture(obj)


def _drop_achieved(doc):
    """New fixtures: the last achieved light (and its deviation view) is out of date."""
    from invrad_wb.gui import display
    display.drop_achieved(doc)


def _room_keys(rooms):
    if not rooms:
        return None
    return [r.Name if hasattr(r, "Name") else str(r) for r in rooms]


def locate(doc=None, rooms=None, run=None, locate=None):
    """Find luminaires for the rooms' targets and insert them as light fixtures.

    Parameters
    ----------
    doc : FreeCAD document or its name (default: the active one)
    rooms : list of Spaces or their names/labels (default: every room with targets)
    run : dict, overrides of the stored run options (``flux_lm``, ``resolution_m``,
        ``interreflection``, ``backend``, ``replace``)
    locate : dict, overrides of the stored locate settings

    Returns
    -------
    PipelineResult, or None after an error or a cancel (already reported).
    """
    title = "Locate luminaires"
    try:
        doc = _doc(doc)
        from invrad_wb.app import pipeline, results
        from invrad_wb.core.inverse.locate import LocateSettings
        settings = params.pipeline_settings(rooms=_room_keys(rooms), insert=False, run=run,
                                            locate=locate)
        pipeline.check_flux(settings.flux_lm)
        LocateSettings.from_dict(settings.locate)
        building = pipeline.prepare(doc, settings)
        res = P.run(title, lambda cb: pipeline.run(doc, settings, progress=cb,
                                                   building=building))
        new = results.insert(doc, res.building, res.luminaires, replace=settings.replace,
                             name=f"invrad: locate {len(res.luminaires)} luminaire(s)")
    except BaseException as exc:
        messages.exception(title, exc)
        return None
    res.fixtures = [o.Name for o in new]
    _colour_fixtures(doc, res.fixtures)
    _drop_achieved(doc)
    _RESULTS[doc.Name] = Stored(res, settings, when=time.time())
    rooms_txt = ", ".join(res.building.room_names)
    lines = [f"{len(res.luminaires)} luminaire(s) of {settings.flux_lm:.0f} lm in"
             f" {len(res.building.rooms)} room(s) ({rooms_txt}),"
             f" {res.timings.get('total', 0):.1f} s"]
    # per room: met or not, the regular layout of a requirement room, why not, and the
    # pointer to Design (what the freecad command prints)
    lines += pipeline.describe_rooms(res.summary)
    messages.show("info", title, "\n".join(lines), box=False)
    return res


def design(doc=None, spec=None, rooms=None, run=None):
    """Design lighting from requirements with a catalogue and insert the fixtures.

    Parameters
    ----------
    doc : FreeCAD document or its name (default: the active one)
    spec : dict in the form of DESIGN.json (``maintenance_factor``, ``catalogue``,
        ``rooms`` keyed by room label or name, ``"*"`` for every other room); default: the
        design panel's stored spec
    rooms : list of Spaces or their names/labels (default: every room the spec has a
        requirement for)
    run : dict, overrides of the stored run options (``resolution_m``, ``interreflection``,
        ``backend``, ``replace``)

    A room with a requirement but no work-plane target first gets one (its own undo step,
    taken back if the design fails or is cancelled); the fixtures are the second undo step.
    The client report goes to :func:`default_report_dir` ("design": not Verify's
    folder). Returns the PipelineResult, or
    None after an error or a cancel (already reported).
    """
    title = "Design lighting"
    added = []
    try:
        doc = _doc(doc)
        from invrad_wb.app import design as app_design, pipeline, results
        from invrad_wb.app.document import transaction
        from invrad_wb.app.rooms import find_spaces, room_name
        data = params.load_design() if spec is None else spec
        base = os.path.dirname(doc.FileName) if doc.FileName else os.getcwd()
        dspec = app_design.spec_from_data(data, "design panel", base)
        keys = _room_keys(rooms)
        spaces = (pipeline.select_rooms(doc, keys) if keys else
                  [sp for sp in find_spaces(doc) if dspec.room_spec(sp.Name, room_name(sp))])
        if not spaces:
            from invrad_wb.errors import SceneError
            raise SceneError("no room of the document has a requirement in the design"
                             " (add one per room, or '*' for every room)", doc.Label)
        with transaction(doc, "invrad: work planes for the design"):
            added = app_design.work_planes_for(spaces, dspec)
        out = default_report_dir(doc, "design")
        settings = params.pipeline_settings(rooms=[sp.Name for sp in spaces],
                                            report_dir=out, insert=False, run=run)
        settings.design = dspec
        building = pipeline.prepare(doc, settings)
        _import_in_main_thread()
        res = P.run(title, lambda cb: pipeline.run(doc, settings, progress=cb,
                                                   building=building))
        new = results.insert(doc, res.building, res.luminaires, replace=settings.replace,
                             name=f"invrad: design, {len(res.luminaires)} luminaire(s)")
    except BaseException as exc:
        if added:
            try:
                doc.undo()            # the work planes this failed run added
            except Exception:
                pass
        messages.exception(title, exc)
        return None
    res.fixtures = [o.Name for o in new]
    _colour_fixtures(doc, res.fixtures)
    _show_design(doc, res)
    messages.show("info", title, "\n".join(describe_design(res)), box=False)
    return res


def _show_design(doc, res):
    """A false-colour view already open shows the design's achieved illuminance (and
    room names placed clear of the new fixtures), not the previous run's."""
    from invrad_wb.gui import display
    if display.state(doc) is None or getattr(res, "achieved", None) is None:
        return
    try:
        display.show_achieved(doc, res.building, res.achieved)
    except Exception as exc:         # the design stands; only the view is stale
        messages.exception("Design lighting: view", exc)


def _import_in_main_thread():
    """Import matplotlib (and WeasyPrint) here, before the worker thread draws the report
    with it.

    In FreeCAD's GUI every import goes through shiboken's import hook; matplotlib's first
    import in the worker thread, while the GUI thread was handling events, crashed
    FreeCAD 0.20 (SIGSEGV in the GUI thread, seen in the GUI smoke test).
    """
    import matplotlib.figure  # noqa: F401   (no pyplot: FreeCAD's own backend is left alone)
    import matplotlib.backends.backend_agg  # noqa: F401
    from invrad_wb.core.output import document
    try:                        # the reports' PDF engine, likewise (its absence is a note)
        document.pdf_engine()
    except document.PdfUnavailable:
        pass


def describe_design(res):
    """Lines for the report view: total watts, per room verdict, Em and U0."""
    d = res.summary.get("design") or {}
    lines = [f"{len(res.luminaires)} luminaire(s), {d.get('total_watts', 0):.1f} W in"
             f" {len(res.building.rooms)} room(s);"
             f" {'every requirement met' if d.get('compliant') else 'NOT every requirement met'};"
             f" report: {res.summary.get('report', '')}"]
    from invrad_wb.app.pipeline import collect_small_sources, point_source_note
    nan = float("nan")
    small = []                  # luminaire types rated as point sources, said once
    for r in d.get("rooms", []):
        name = r.get("name") or r.get("room")
        req = r.get("requirement") or {}
        verdict = "meets its requirements" if r.get("compliant") else "FAILS"
        # task areas given: each one's own figures (the work plane's over all of them
        # are not what is judged)
        areas = r.get("task_areas") or [
            {"name": None, "em_lux": r.get("em_lux", nan), "u0": r.get("u0", nan),
             "emin_lux": r.get("emin_lux"),
             "required": req}]
        figs = "; ".join(
            ("" if a["name"] is None else f"{a['name']} ")
            + f"Em {a.get('em_lux', nan):.0f} lx for {a['required'].get('lux', nan):.0f},"
            f" U0 {_u0(a):.2f} for {a['required'].get('u0', nan):.2f}"
            for a in areas)
        pw = r.get("power") or {}
        rated = ("" if pw.get("rated_w") is None else
                 f", {pw['rated_w']:.1f} W installed ({pw.get('rated_w_per_m2', nan):.1f}"
                 " W/m2)")
        lines.append(f"  {name}: {verdict}; {figs}; {r.get('watts', 0):.1f} W drawn"
                     f" ({r.get('w_per_m2', 0):.1f} W/m2){rated}")
        if "em_lux" in r:
            lines.append("    " + "; ".join(_other_items(r)))
        lines += [f"    {n}" for n in r.get("notes") or []
                  if not collect_small_sources(n, small)]
    if small:
        # what to do about it, in the panel's words
        lines.append(point_source_note(small) + ": give the type its Luminous size in the"
                     " Design panel (the diameter of its lit opening), or a photometry"
                     " file with one, for its UGR from its luminance")
    return lines


def _u0(d):
    """U0 of a summary's figures: its ``u0`` (kept to 6 places since round 13, read to 2
    once, as the report reads the unrounded figure); Emin / Em where it is missing. Not
    Emin / Em first: those are rounded to 2 places (Em 100.004, Emin 67.4951: U0 0.674924,
    '0.67' in the report, but 67.5 / 100.0 = 0.675 -> '0.68')."""
    u0 = d.get("u0")
    if u0 is not None:
        return u0
    em, emin = d.get("em_lux"), d.get("emin_lux")
    return emin / em if em and emin is not None else float("nan")


def _other_items(r):
    """The room's EN 12464-1 items beyond the task area, as the command line and the
    report give them: walls, ceiling, surroundings, background, Ez where judged, UGR with
    its limit (or none: a value, not a verdict)."""
    from invrad_wb.core.design.spec import part_name
    areas = {part_name(a["name"]) for a in r.get("task_areas") or ()}  # said before
    items = [f"{k} Em {v['em_lux']:.0f} lx for {v['required']['lux']:.4g},"
             f" U0 {_u0(v):.2f} for {v['required']['u0']:.2f}"
             for k, v in (r.get("surfaces") or {}).items()
             if v.get("required") and k not in areas]
    cz = r.get("cylindrical") or {}
    if cz.get("judged"):
        items.append(f"Ez {cz['em_lux']:.0f} lx for {cz['required']['lux']:g},"
                     f" U0 {cz['u0']:.2f} for {cz['required']['u0']:.2f}")
    if r.get("ugr") is None:
        items.append("UGR not computable")
    elif r.get("ugr_limit") is None:
        items.append(f"UGR {r['ugr']:.1f} (no limit given)")
    else:
        items.append(f"UGR {r['ugr']:.1f} for at most {r['ugr_limit']:g}")
    return items


def repeak(doc=None, threshold=None, neighbourhood_m=None):
    """New threshold/neighbourhood on the stored votes; replaces the rooms' fixtures.

    Returns the new list of Luminaires, or None after an error or a cancel.
    """
    title = "Recalculate peaks"
    try:
        doc = _doc(doc)
        from invrad_wb.app import results
        from invrad_wb.errors import SceneError
        st = stored(doc)
        if st is None:
            raise SceneError("no locate result for this document in this session: run"
                             " Locate luminaires first", doc.Label)
        from invrad_wb.core.inverse.locate import LocateSettings
        probe = dict(st.result.locate_result.settings)
        if threshold is not None:
            probe["threshold"] = float(threshold)
        if neighbourhood_m is not None:
            probe["neighbourhood_m"] = float(neighbourhood_m)
        LocateSettings.from_dict(probe)
        lums = P.run(title, lambda cb: results.repeak(st.result, threshold,
                                                      neighbourhood_m, cb))
        new = results.insert(doc, st.result.building, lums, replace=True,
                             name=f"invrad: recalculate peaks, {len(lums)} luminaire(s)")
    except BaseException as exc:
        messages.exception(title, exc)
        return None
    st.result.luminaires = lums
    st.result.fixtures = [o.Name for o in new]
    st.verified = None
    _colour_fixtures(doc, st.result.fixtures)
    _drop_achieved(doc)
    keep = {}
    if threshold is not None:
        keep["threshold"] = float(threshold)
    if neighbourhood_m is not None:
        keep["neighbourhood_m"] = float(neighbourhood_m)
    params.save_locate(keep)
    messages.show("info", title, f"{len(lums)} luminaire(s) with threshold"
                  f" {st.result.locate_result.settings.get('threshold')} and neighbourhood"
                  f" {st.result.locate_result.settings.get('neighbourhood_m')} m", box=False)
    return lums


#: The report folders' names per action: Design's client report and Verify's
#: verification report go to folders of their own, so neither replaces the other.
REPORT_KINDS = {"verify": "report", "design": "design"}


def default_report_dir(doc, kind="verify"):
    """Where *Verify and report* (``kind`` "verify") or *Design* ("design") writes:
    ``Run/report_dir``/<document>/<kind>, else next to the saved document
    (``<name>_invrad_report``, ``<name>_invrad_design``), else FreeCAD's user data
    folder (``invrad/reports/<document>/<kind>``)."""
    import FreeCAD
    if kind not in REPORT_KINDS:
        raise ValueError(f"report kind {kind!r} is not one of {sorted(REPORT_KINDS)}")
    base = params.load_run().get("report_dir") or ""
    if base:
        return os.path.join(base, doc.Name, kind)
    if doc.FileName:
        stem = os.path.splitext(os.path.basename(doc.FileName))[0]
        return os.path.join(os.path.dirname(doc.FileName),
                            f"{stem}_invrad_{REPORT_KINDS[kind]}")
    return os.path.join(FreeCAD.getUserAppDataDir(), "invrad", "reports", doc.Name, kind)


def verify(doc=None, rooms=None, report_dir=None, show=True):
    """Forward solve for the fixtures in the document, report, metrics sheet.

    The report (HTML, CSV, images, ``summary.json``) goes to ``report_dir`` (default
    :func:`default_report_dir`); the per-room metrics go into the Spreadsheet
    ``InvRadReport`` (one undoable step); with ``show`` the achieved illuminance is shown
    in false colour. Returns the VerifyResult, or None after an error or a cancel.
    """
    title = "Verify and report"
    try:
        doc = _doc(doc)
        from invrad_wb.app import pipeline, results
        out = report_dir or default_report_dir(doc)
        settings = params.pipeline_settings(rooms=_room_keys(rooms), report_dir=out,
                                            insert=False)
        building = pipeline.prepare(doc, settings)
        lums, skipped = results.document_luminaires(building)
        _import_in_main_thread()         # the report draws with matplotlib
        vr = P.run(title, lambda cb: results.verify(doc, settings, progress=cb,
                                                    building=building, luminaires=lums))
        vr.skipped = skipped
        html = getattr(vr.report, "html", None) or vr.summary.get("report") or out
        results.write_sheet(doc, vr.rows, note=f"Report: {html}")
    except BaseException as exc:
        messages.exception(title, exc)
        return None
    st = stored(doc)
    if st is not None:
        st.verified = vr
    if show:
        try:
            from invrad_wb.gui import display
            display.show_achieved(doc, vr.building, vr.achieved)
        except Exception as exc:               # the display is a nicety, not the result
            messages.warning(title, f"could not show the result in false colour: {exc}")
    lines = [f"{len(vr.luminaires)} luminaire(s) in {len(vr.building.rooms)} room(s);"
             f" report: {html}"]
    # per room met or not, as after Locate (the sheet and the report hold the numbers)
    lines += pipeline.describe_rooms(vr.summary)
    if skipped:
        lines.append(f"  left out (no luminous flux): {', '.join(skipped)}")
    messages.show("info", title, "\n".join(lines), box=False)
    return vr
