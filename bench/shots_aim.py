#!/usr/bin/env python3
"""Screenshots of aimed luminaires in FreeCAD (issue 23): a result JSON (``locate --aim
free``, or bench/bench_aim.py --save's ``<room>_found.json``) inserted as light fixtures into
a walled room of the result's size, seen in isometric, from the side and from above, with
each fixture's beam axis drawn to where it meets the room; with ``--reopen`` after the
document was saved, closed and opened again; with ``--native`` (FreeCAD 1.x) two spots
aimed in FZK-Haus opened as a NativeIFC document, saved and reopened (the document, and
the saved .ifc opened fresh as File > Open does).

::

    .venv/bin/python bench/shots_aim.py FOUND.json [--true TRUE.json] [--out DIR]
        [--freecad freecad] [--reopen]

re-launches itself as ``xvfb-run freecad bench/shots_aim.py`` and, inside the GUI, writes
``<out>/<room>_<fc version>_{iso,side,top}.png`` and ``<out>/<room>_<fc version>.json``: per
fixture the angle between its placement's light axis (local -Z) and the result's aim, the
distance of its placement from the result's position, and, with ``--true``, the distance
from the true luminaire and the angle to its aim, and where its beam axis meets the room.
"""
import json
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
ENV = "INVRAD_AIMSHOT"


def relaunch(argv):
    import argparse
    import shutil
    import subprocess
    import sysconfig
    import tempfile
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("found", nargs="?", help="a result JSON (not with --native)")
    ap.add_argument("--true")
    ap.add_argument("--out", default=os.path.join(ROOT, "out", "shots-aim"))
    ap.add_argument("--freecad", default=os.environ.get("INVRAD_FREECAD", "freecad"))
    ap.add_argument("--timeout", type=float, default=300.0)
    ap.add_argument("--reopen", action="store_true",
                    help="save the document, close it and open it again before the shots"
                         " (the beam axes are drawn again by the workbench's InitGui.py)")
    ap.add_argument("--native", action="store_true",
                    help="FreeCAD 1.x: FZK-Haus as a NativeIFC document, two spots aimed"
                         " 40 degrees in its Wohnen, saved and reopened (implies --reopen)")
    args = ap.parse_args(argv)
    if not args.native and not args.found:
        ap.error("a result JSON is needed (or --native)")
    exe, xvfb = shutil.which(args.freecad), shutil.which("xvfb-run")
    if not exe or not xvfb:
        print(f"shots_aim: needs {args.freecad} and xvfb-run on the PATH", file=sys.stderr)
        return 2
    os.makedirs(args.out, exist_ok=True)
    home = tempfile.mkdtemp(prefix="invrad-fchome-")
    os.makedirs(os.path.join(home, "Mod"))
    os.symlink(ROOT, os.path.join(home, "Mod", "invrad"))   # the workbench, as installed
    paths = os.environ.get("PYTHONPATH", "").split(os.pathsep) + [
        sysconfig.get_paths()["purelib"], ROOT]
    paths = [p for i, p in enumerate(paths) if p and p not in paths[:i]]
    env = dict(os.environ, FREECAD_USER_HOME=home, PYTHONPATH=os.pathsep.join(paths),
               INVRAD_SITE_PACKAGES=os.pathsep.join(paths), QTWEBENGINE_DISABLE_SANDBOX="1")
    env[ENV] = json.dumps({"found": args.found and os.path.abspath(args.found),
                           "native": args.native,
                           "true": args.true and os.path.abspath(args.true),
                           "out": os.path.abspath(args.out), "paths": paths,
                           "reopen": args.reopen})
    env.pop("QT_QPA_PLATFORM", None)
    try:
        rc = subprocess.run([xvfb, "-a", "-s", "-screen 0 1280x800x24", exe,
                             os.path.abspath(__file__)], env=env, timeout=args.timeout).returncode
    finally:
        shutil.rmtree(home, ignore_errors=True)
    return rc


def inside():
    cfg = json.loads(os.environ[ENV])
    for p in reversed(cfg["paths"]):
        if p not in sys.path:
            sys.path.insert(0, p)
    if cfg.get("native"):
        return inside_native(cfg)
    import numpy as np
    import FreeCAD
    import FreeCADGui
    sys.path.insert(0, os.path.join(ROOT, "tests", "freecad"))
    from fctest import make_walled_room
    from invrad_wb.app import fixtures
    from invrad_wb.core.model.luminaires import luminaire_from_dict

    def load(path):
        with open(path) as fh:
            data = json.load(fh)
        # a bench's photometry lies in its temporary folder: the body is then the default
        return data, [luminaire_from_dict({k: v for k, v in d.items() if k != "photometry"
                                           or os.path.isfile(str(v))})
                      for d in data["luminaires"]]

    data, found = load(cfg["found"])
    true = load(cfg["true"])[1] if cfg.get("true") else []
    lo, hi = np.array(data["bounds"][0]), np.array(data["bounds"][1])
    name = data.get("room", "room")
    ver = "fc" + "".join(FreeCAD.Version()[:2])
    doc = FreeCAD.newDocument("AimShots")
    wall = 0.2
    space = make_walled_room(doc, size=tuple(hi[:2] - lo[:2] + wall) + (hi[2] - lo[2],),
                             wall=wall, origin=(lo[0] - wall / 2, lo[1] - wall / 2, lo[2]),
                             label=name.capitalize())
    objs = fixtures.insert_fixtures(doc, [(space, found)])
    doc.recompute()
    if cfg.get("reopen"):
        # saved, closed and opened again: what a user sees the next day
        from PySide import QtGui
        names, sname = [o.Name for o in objs], space.Name
        path = os.path.join(cfg["out"], f"{name}_{ver}.FCStd")
        doc.saveAs(path)
        FreeCAD.closeDocument(doc.Name)
        doc = FreeCAD.openDocument(path)
        for _ in range(10):
            QtGui.QApplication.processEvents()
            FreeCADGui.updateGui()
        objs = [doc.getObject(n) for n in names]
        space = doc.getObject(sname)
        ver += "_reopened"
    report = []
    for obj, lum in zip(objs, found):
        pl = obj.Placement
        d = pl.Rotation.multVec(FreeCAD.Vector(0, 0, -1))
        d = np.array([d.x, d.y, d.z])
        row = {"label": obj.Label,
               "axis_vs_aim_deg": float(np.degrees(np.arccos(np.clip(d @ lum.normal, -1, 1)))),
               "base_vs_position_mm": float(np.linalg.norm(
                   np.array([pl.Base.x, pl.Base.y, pl.Base.z]) - lum.position * 1000)),
               "tilt_deg": getattr(obj, "Tilt", None), "pan_deg": getattr(obj, "Pan", None)}
        if "AimPoint" in obj.PropertiesList:
            a = obj.AimPoint
            row["aim_point_m"] = [round(a.x / 1000, 3), round(a.y / 1000, 3),
                                  round(a.z / 1000, 3)]
        if true:
            t = min(true, key=lambda t: np.linalg.norm(t.position - lum.position))
            row["vs_true_cm"] = float(100 * np.linalg.norm(t.position - lum.position))
            row["vs_true_deg"] = float(np.degrees(np.arccos(np.clip(t.normal @ d, -1, 1))))
        vo = obj.ViewObject
        row["beam_axis_drawn"] = any(vo.RootNode.getChild(i).getName() == "InvradBeamAxis"
                                     for i in range(vo.RootNode.getNumChildren()))
        report.append(row)
    for obj in doc.Objects:
        if obj.TypeId != "Part::Part2DObjectPython" and hasattr(obj, "IfcType") and \
                obj.IfcType in ("Wall", "Slab") and obj.ViewObject is not None:
            obj.ViewObject.Transparency = 75
        elif obj.Name.startswith(("Wire", "Rectangle")) and obj.ViewObject is not None:
            obj.ViewObject.Visibility = False
    if space.ViewObject is not None:
        space.ViewObject.Visibility = False
    view = FreeCADGui.activeDocument().activeView()
    shots = []
    for tag, cam in (("iso", view.viewIsometric), ("side", view.viewRight),
                     ("front", view.viewRear), ("top", view.viewTop)):
        cam()
        view.fitAll()
        FreeCADGui.updateGui()
        path = os.path.join(cfg["out"], f"{name}_{ver}_{tag}.png")
        view.saveImage(path, 1200, 800, "White")
        shots.append(path)
    with open(os.path.join(cfg["out"], f"{name}_{ver}.json"), "w") as fh:
        json.dump({"freecad": FreeCAD.Version()[:3], "fixtures": report, "shots": shots},
                  fh, indent=1)


def settle():
    """Let FreeCAD's event loop run (deferred drawing, NativeIFC's timers)."""
    import time
    import FreeCADGui
    from PySide import QtGui
    for _ in range(20):
        QtGui.QApplication.processEvents()
        FreeCADGui.updateGui()
        time.sleep(0.05)


def inside_native(cfg):
    """FZK-Haus as a NativeIFC document: two spots aimed 40 degrees (pans 0 and 180) from
    the middle of its Wohnen's ceiling, inserted as IfcLightFixture entities; the IFC and
    the document saved, the document closed and opened again; shots, and per fixture its
    aim read from the saved IFC against the one inserted."""
    import shutil
    import numpy as np
    import FreeCAD
    import FreeCADGui
    import ifcopenshell
    import ifcopenshell.util.unit as U
    sys.path.insert(0, os.path.join(ROOT, "tests", "freecad"))
    from fctest import FZK
    from invrad_wb.app import fixtures, ifcdata, ifcimport, nativeifc, rooms
    from invrad_wb.app.fixturebody import has_beam_axis
    from invrad_wb.core.model.aiming import aim_from_tilt_pan, aimed_c0
    from invrad_wb.core.model.luminaires import Luminaire
    ver = "fc" + "".join(FreeCAD.Version()[:2])
    src = os.path.join(cfg["out"], f"fzk_native_{ver}.ifc")
    shutil.copy(FZK, src)
    doc, proj = ifcimport.open_ifc(src, shapemode=1)
    settle()
    space = {rooms.room_name(s): s for s in rooms.find_spaces(doc)}["Wohnen"]
    bb = nativeifc.space_solid(space).BoundBox
    mount = np.array([0.0, 0.0, -1.0])
    lums = []
    for k, pan in enumerate((0.0, 180.0)):
        pos = np.array([bb.Center.x + (k - 0.5) * 600.0, bb.Center.y, bb.ZMax - 10.0]) / 1000
        aim = aim_from_tilt_pan(mount, 40.0, pan)
        lums.append(Luminaire(pos, aim, 800.0, c0=aimed_c0(mount, aim),
                              extra={"tilt_deg": 40.0, "pan_deg": pan}))
    objs = fixtures.insert_fixtures(doc, [(space, lums)])
    names, sname = [o.Name for o in objs], space.Name
    nativeifc.save(proj)
    path = os.path.join(cfg["out"], f"fzk_native_{ver}.FCStd")
    doc.saveAs(path)
    FreeCAD.closeDocument(doc.Name)
    doc = FreeCAD.openDocument(path)
    settle()
    objs = [doc.getObject(n) for n in names]
    objs_guids = [o.GlobalId for o in objs]
    saved = ifcopenshell.open(src)
    scale = U.calculate_unit_scale(saved)
    by_guid = {e.GlobalId: e for e in saved.by_type("IfcLightFixture")}
    report = []
    for obj, lum in zip(objs, lums):
        row = {"label": obj.Label, "tilt_deg": getattr(obj, "Tilt", None),
               "pan_deg": getattr(obj, "Pan", None), "beam_axis_drawn": has_beam_axis(obj)}
        a = getattr(obj, "AimPoint", None)
        if a is not None:
            row["aim_point_m"] = [round(a.x / 1000, 3), round(a.y / 1000, 3),
                                  round(a.z / 1000, 3)]
        ent = by_guid.get(getattr(obj, "GlobalId", None))
        got = ifcdata.invrad_fixture_data(ent, scale, saved) if ent is not None else None
        if got is not None:
            row["saved_ifc"] = {
                "position_mm": float(1000 * np.linalg.norm(got.position - lum.position)),
                "aim_deg": float(np.degrees(np.arccos(np.clip(got.normal @ lum.normal,
                                                               -1, 1)))),
                "tilt_deg": got.extra.get("tilt_deg"), "pan_deg": got.extra.get("pan_deg")}
        report.append(row)
    shots = _native_shots(doc, objs, doc.getObject(sname), cfg["out"],
                          f"fzk_native_{ver}_reopened")
    # the saved .ifc opened fresh, as File > Open does (NativeIFC's import, the document
    # itself the project, its building structure in NativeIFC's coin display): a space's
    # contents have no objects until it is expanded, and invrad's observer (InitGui.py)
    # makes the aimed fixtures' with their aim and beam axis
    from nativeifc import ifc_import
    FreeCAD.closeDocument(doc.Name)
    fresh = FreeCAD.newDocument("FreshIfc")
    ifc_import.insert(src, fresh.Name, strategy=1, shapemode=1, switchwb=False, silent=True,
                      singledoc=True)
    settle()
    got = {getattr(o, "GlobalId", ""): o for o in fresh.Objects
           if nativeifc.is_native_fixture(o, generated_only=True)}
    fresh_rows = []
    for obj, lum in zip(objs_guids, lums):
        o = got.get(obj)
        row = {"guid": obj, "made": o is not None}
        if o is not None:
            pl = o.Placement
            d = pl.Rotation.multVec(FreeCAD.Vector(0, 0, -1))
            a = getattr(o, "AimPoint", None)
            row.update(label=o.Label, tilt_deg=getattr(o, "Tilt", None),
                       pan_deg=getattr(o, "Pan", None), beam_axis_drawn=has_beam_axis(o),
                       placement_vs_position_mm=float(np.linalg.norm(
                           np.array([pl.Base.x, pl.Base.y, pl.Base.z]) - lum.position * 1000)),
                       placement_axis_vs_aim_deg=float(np.degrees(np.arccos(np.clip(
                           np.dot([d.x, d.y, d.z], lum.normal), -1, 1)))),
                       aim_point_m=None if a is None else
                       [round(a.x / 1000, 3), round(a.y / 1000, 3), round(a.z / 1000, 3)])
        fresh_rows.append(row)
    spaces = [s for s in rooms.find_spaces(fresh) if rooms.room_name(s) == "Wohnen"]
    fresh_objs = [o for o in got.values()]
    shots += _native_shots(fresh, fresh_objs, spaces[0] if spaces else None, cfg["out"],
                           f"fzk_native_{ver}_fresh_ifc")
    with open(os.path.join(cfg["out"], f"fzk_native_{ver}_reopened.json"), "w") as fh:
        json.dump({"freecad": FreeCAD.Version()[:3], "fixtures": report,
                   "fresh_ifc": fresh_rows, "shots": shots}, fh, indent=1)


def _native_shots(doc, objs, space, out, stem):
    """Isometric, front and top shots of ``space`` and its fixtures ``objs``, framed on the
    space's solid: its storey and building (NativeIFC draws the elements not expanded as
    theirs) see-through, everything else hidden; the paths."""
    import FreeCADGui
    from pivy import coin
    from invrad_wb.app import nativeifc
    parents = set(space.InListRecursive) if space is not None else set()
    for o in doc.Objects:
        vo = getattr(o, "ViewObject", None)
        if vo is None or o in objs:
            continue
        if o is space or o in parents:
            vo.Visibility = True
            if hasattr(vo, "Transparency"):
                vo.Transparency = 70 if o is space else 85
        else:
            vo.Visibility = False
    settle()
    view = FreeCADGui.getDocument(doc.Name).activeView()
    view.setCameraType("Orthographic")
    bb = nativeifc.space_solid(space).BoundBox if space is not None else None
    shots = []
    for tag, cam in (("iso", view.viewIsometric), ("front", view.viewFront),
                     ("top", view.viewTop)):
        cam()
        if bb is not None:
            m = 500.0
            box = coin.SbBox3f(bb.XMin - m, bb.YMin - m, bb.ZMin - m,
                               bb.XMax + m, bb.YMax + m, bb.ZMax + m)
            view.getCameraNode().viewBoundingBox(box, 1.5, 1.0)
        else:
            view.fitAll()
        settle()
        shot = os.path.join(out, f"{stem}_{tag}.png")
        view.saveImage(shot, 1200, 800, "White")
        shots.append(shot)
    return shots


def run_inside():
    try:
        inside()
    except Exception:
        import traceback
        traceback.print_exc()
    finally:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(0)


if os.environ.get(ENV) and getattr(sys.modules.get("FreeCAD"), "GuiUp", 0):
    # FreeCAD runs this file as a macro (not as __main__): the work starts once its event
    # loop runs
    from PySide import QtCore
    QtCore.QTimer.singleShot(1000, run_inside)
elif __name__ == "__main__":
    sys.exit(relaunch(sys.argv[1:]))
