"""``python -m invrad_wb freecad``: the FreeCAD pipeline from the command line.

::

    python -m invrad_wb freecad IN.FCStd|IN.ifc [--targets T.json] --out OUT.FCStd|OUT.ifc
                                --report DIR [--flux LM] [--mesh-size M] ...

Opens a FreeCAD document (or imports an IFC file's rooms with ifcopenshell), adds the
targets of ``T.json`` (format: :data:`invrad_wb.app.targets.TARGETS_JSON_DOC`), runs the
pipeline over every room with targets (:mod:`invrad_wb.app.pipeline`), and writes the lit
model: ``.FCStd`` (FreeCAD document) or ``.ifc`` (merged into the input IFC file when the
input is one, else FreeCAD's exporter; light fixtures inside their IfcSpace).

Run outside FreeCAD, the command re-launches itself under ``freecadcmd`` (found on the
PATH, or ``--freecadcmd`` / ``$INVRAD_FREECADCMD``) with this interpreter's site-packages
and the checkout on ``PYTHONPATH``; the job travels as a JSON file named by
``$INVRAD_FREECAD_JOB`` and its outcome comes back the same way, so errors are reported as
one line and the exit status is right (freecadcmd itself exits 0 after an uncaught
exception in a script; the child ends with ``os._exit``).
"""
import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile


def honour_pythonpath():
    """Put $PYTHONPATH's folders on sys.path (in front, in order) where they are missing.

    FreeCAD 1.0's freecadcmd runs an isolated interpreter that ignores PYTHONPATH (0.20
    honoured it): the child run and the FreeCAD tests find invrad and its venv this way on
    both. Runs before the package's own imports when freecadcmd executes this file.
    """
    paths = [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]
    for p in reversed(paths):
        if p not in sys.path:
            sys.path.insert(0, p)


honour_pythonpath()
if __name__ == "__main__":
    # a direct ``python -m invrad_wb.cli.freecad_cmd``: a stop signal while the modules
    # load ends it with one line (the run guard takes over in _standalone)
    from invrad_wb.runguard import stop_early_on_signals
    stop_early_on_signals()
if __name__ == "freecad_cmd":
    # run as a script by freecadcmd, which puts this folder on sys.path: its modules
    # (design, locate, common...) must not pass for top-level ones
    _here = os.path.dirname(os.path.abspath(__file__))
    sys.path[:] = [p for p in sys.path if os.path.abspath(p or os.curdir) != _here]

from invrad_wb.errors import Cancelled, InvradError, SettingsError  # noqa: E402
from invrad_wb.cli.common import run_guarded  # noqa: E402
from invrad_wb.progress import workers_arg  # noqa: E402

ENV_JOB = "INVRAD_FREECAD_JOB"
#: Printed by the child before its own output; what comes before is FreeCAD's banner.
SENTINEL = "--8<-- invrad --8<--"


class FreeCADError(InvradError, RuntimeError):
    """FreeCAD (freecadcmd) is missing or the FreeCAD run failed."""


def add_parser(subparsers):
    """Add the ``freecad`` command to the main CLI's subparsers."""
    p = subparsers.add_parser(
        "freecad", help="run the pipeline on a FreeCAD document or IFC file (via freecadcmd)",
        description="Find luminaires for the lighting targets of a FreeCAD document or an"
                    " IFC file's rooms, insert them as light fixtures and report how close"
                    " they come (runs under freecadcmd).",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog=_epilog())
    add_arguments(p)
    p.set_defaults(func=main)
    return p


def _epilog():
    try:
        from invrad_wb.app.targets import TARGETS_JSON_DOC
    except Exception:
        return None
    return TARGETS_JSON_DOC


def add_arguments(p):
    p.add_argument("input", help="FreeCAD document (.FCStd) or IFC file (.ifc) with rooms")
    p.add_argument("--targets", help="JSON file with lighting targets per room")
    p.add_argument("--out", required=True, help="output .FCStd or .ifc")
    p.add_argument("--report", required=True, help="folder for the verification report")
    p.add_argument("--flux", type=float, help="luminous flux of one luminaire, lm (or"
                                              " flux_lm in the targets file; without"
                                              " either, each luminaire's flux is fitted)")
    p.add_argument("--mesh-size", dest="mesh_size", type=float, metavar="M",
                   help="longest triangle edge of the room meshes, metres (0.3; or"
                        " resolution_m in the targets file)")
    # the old spelling; in `invrad locate`, --resolution is vote-map metres per pixel
    p.add_argument("--resolution", dest="mesh_size", type=float, action=_DeprecatedAlias,
                   new="--mesh-size", help=argparse.SUPPRESS)
    p.add_argument("--rooms", nargs="+", help="only these rooms (labels, names or GlobalIds)")
    p.add_argument("--no-interreflection", action="store_true",
                   help="verify with direct light only")
    p.add_argument("--no-zones", action="store_true",
                   help="locate every room on its own, taking open borders (rooms that meet"
                        " without a wall) as walls; by default such rooms are located as one"
                        " lighting zone (each fixture still goes into the room that contains"
                        " it)")
    p.add_argument("--zones", action="store_true", help=argparse.SUPPRESS)   # the default
    p.add_argument("--keep", action="store_true",
                   help="keep fixtures of earlier invrad runs in the processed rooms")
    p.add_argument("--settings", help="JSON file with locate settings")
    p.add_argument("--elements", action="store_true",
                   help="IFC input: also import walls, slabs, windows... (for a .FCStd output)")
    p.add_argument("--backend", default="auto", choices=("auto", "opencl", "numpy"))
    p.add_argument("--freecadcmd", help="path of freecadcmd (default: $INVRAD_FREECADCMD or"
                                        " the PATH)")
    p.add_argument("-v", "--verbose", action="store_true", help="print progress")
    p.add_argument("--workers", default="1", metavar="N",
                   help="rooms on N worker processes ('auto': one per core; default 1); the"
                        " result does not depend on N")


class _DeprecatedAlias(argparse.Action):
    """An old spelling of an option: stores like the new one and warns once per use."""

    def __init__(self, option_strings, dest, new, **kwargs):
        self.new = new
        super().__init__(option_strings, dest, **kwargs)

    def __call__(self, parser, namespace, values, option_string=None):
        import warnings
        warnings.warn(f"{option_string} is deprecated here, use {self.new} (same value, metres)",
                      FutureWarning, stacklevel=2)
        setattr(namespace, self.dest, values)
        setattr(namespace, "typed_" + self.dest, option_string)   # for its errors


# --------------------------------------------------------------------------- parent side
def in_freecad():
    """True when running inside FreeCAD (freecadcmd or the GUI)."""
    fc = sys.modules.get("FreeCAD")
    return fc is not None and hasattr(fc, "newDocument")


def _options(args):
    opts = {k: v for k, v in vars(args).items() if k not in ("func", "command")}
    for k in ("input", "targets", "out", "report", "settings"):
        if opts.get(k):
            opts[k] = os.path.abspath(opts[k])
    return opts


def main(args):
    """Run the ``freecad`` command (parsed ``args``); returns 0 or raises InvradError."""
    opts = _options(args)
    workers_arg(opts.get("workers", "1"))       # a bad count costs no FreeCAD start
    src, ext, _, _ = _checked_paths(opts)   # before FreeCAD starts: a bad path costs no run
    if opts.get("flux") is not None:
        from invrad_wb.core.inverse.locate import check_flux
        try:
            check_flux(opts["flux"])
        except SettingsError as exc:          # the option the user typed
            raise SettingsError(f"--{exc}")
    if opts.get("mesh_size") is not None:
        from invrad_wb.app.settings import MIN_RESOLUTION_M
        m = opts["mesh_size"]
        if not (m == m and abs(m) != float("inf") and m >= MIN_RESOLUTION_M):
            raise SettingsError(f"{opts.get('typed_mesh_size', '--mesh-size')} must be a"
                                f" finite length of at least {MIN_RESOLUTION_M} m, got {m!r}")
    if opts.get("settings"):
        read_settings_file(opts["settings"])
    if ext == ".ifc" and not in_freecad():
        check_ifc_isolated(src)   # a corrupt IFC costs a second, not a FreeCAD start
    if in_freecad():
        run_job(opts)
        return 0
    return relaunch(opts)


def find_freecadcmd(explicit=None):
    # a path the user gave is used or refused, never silently replaced by the PATH's
    for given, how in ((explicit, "--freecadcmd"),
                       (os.environ.get("INVRAD_FREECADCMD"), "$INVRAD_FREECADCMD")):
        if given:
            path = shutil.which(given)
            if not path:
                raise FreeCADError(f"{how} {given}: no such executable")
            return path
    for cand in ("freecadcmd", "FreeCADCmd"):
        if cand:
            path = shutil.which(cand)
            if path:
                return path
    raise FreeCADError("freecadcmd was not found: install FreeCAD (Debian: apt-get install"
                       " freecad-python3) or give its path with --freecadcmd or"
                       " $INVRAD_FREECADCMD")


def _checkout_root():
    """The folder that holds the ``invrad_wb`` package."""
    return os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def child_environment():
    """Environment for freecadcmd: this interpreter's packages and the checkout in front."""
    import site
    import sysconfig
    root = _checkout_root()
    paths = [sysconfig.get_paths()["purelib"]]
    try:
        paths += site.getsitepackages()
    except AttributeError:
        pass
    paths.append(root)
    from invrad_wb.cli.blas import child_blas_environment
    env = child_blas_environment(os.environ.copy())
    if env.get("PYTHONPATH"):
        paths.append(env["PYTHONPATH"])
    seen, out = set(), []
    for p in paths:
        if p and p not in seen:
            seen.add(p)
            out.append(p)
    env["PYTHONPATH"] = os.pathsep.join(out)
    env.setdefault("QT_QPA_PLATFORM", "offscreen")
    return env


def relaunch(opts):
    """Run the job under freecadcmd; stream its output; raise on failure."""
    exe = find_freecadcmd(opts.get("freecadcmd"))
    tmp = tempfile.mkdtemp(prefix="invrad-freecad-")
    try:
        job = os.path.join(tmp, "job.json")
        status_path = os.path.join(tmp, "status.json")
        with open(job, "w", encoding="utf-8") as fh:
            json.dump({"options": opts, "status": status_path}, fh)
        env = child_environment()
        env[ENV_JOB] = job
        proc = subprocess.Popen([exe, os.path.abspath(__file__)], stdout=subprocess.PIPE,
                                env=env, text=True, bufsize=1, errors="replace")
        before = []
        started = False
        try:
            for line in proc.stdout:
                if not started:
                    if SENTINEL in line:
                        started = True
                    else:
                        before.append(line)
                    continue
                sys.stdout.write(line)
                sys.stdout.flush()
        except KeyboardInterrupt:
            proc.terminate()
            raise
        rc = proc.wait()
        status = None
        if os.path.isfile(status_path):
            with open(status_path, "r", encoding="utf-8") as fh:
                status = json.load(fh)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    if status is None:
        tail = "".join(before[-20:]).strip()
        raise FreeCADError(f"freecadcmd ({exe}) exited with status {rc} before the job"
                           f" finished{': ' + tail if tail else ''}")
    if status.get("ok"):
        return 0
    cls = Cancelled if status.get("type") == "Cancelled" else FreeCADError
    exc = cls(status.get("error", f"FreeCAD run failed (status {rc})"))
    if status.get("traceback"):
        # an internal error under freecadcmd: the command line's catch-all logs it and
        # says what to report (invrad_wb.cli.common.internal_error), as for its own
        exc.traceback_text = status["traceback"]
    raise exc


# --------------------------------------------------------------------------- child side
def child_main():
    """Entry point under freecadcmd: run the job named by $INVRAD_FREECAD_JOB, then exit."""
    import traceback
    with open(os.environ[ENV_JOB], "r", encoding="utf-8") as fh:
        job = json.load(fh)
    out = os.fdopen(os.dup(1), "w", buffering=1, encoding="utf-8", errors="replace")
    out.write(SENTINEL + "\n")
    out.flush()
    # FreeCAD's C++ console writes recompute progress bars to fd 1: silence them
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 1)
    sys.stdout = out
    rc = 3
    try:
        summary = run_job(job["options"], out)
        status = {"ok": True, "summary": summary}
        rc = 0
    except InvradError as exc:
        status = {"ok": False, "error": str(exc), "type": type(exc).__name__}
        rc = 130 if isinstance(exc, Cancelled) else 2
    except BaseException as exc:         # an internal error: keep the traceback
        status = {"ok": False, "error": f"internal error: {type(exc).__name__}: {exc}",
                  "type": "internal", "traceback": traceback.format_exc()}
    try:
        with open(job["status"], "w", encoding="utf-8") as fh:
            json.dump(status, fh, default=str)
    finally:
        out.flush()
        sys.stderr.flush()
        os._exit(rc)


def run_job(opts, out=None):
    """Run the pipeline in this (FreeCAD) process; returns the run's summary dict."""
    from invrad_wb.app import pipeline, targets
    from invrad_wb.app.pipeline import PipelineSettings
    out = out or sys.stdout

    def say(msg):
        out.write(msg + "\n")
        out.flush()

    from invrad_wb.app import design as app_design
    src, ext, dst, dext = _checked_paths(opts)
    spec = None
    if opts.get("targets") and app_design.is_design_file(opts["targets"]):
        spec = app_design.spec_from_targets_file(opts["targets"])   # checked before work
    flux, mesh_size, locate_settings = _run_options(opts, design=spec is not None)
    doc = _open_input(src, ext, opts, say)
    if opts.get("targets"):
        targets.apply_targets_file(doc, opts["targets"])
    last = [None]

    def progress(frac, msg):
        if opts.get("verbose") and msg != last[0]:
            say(f"  {100 * frac:5.1f} %  {msg}")
            last[0] = msg
        return True

    settings = PipelineSettings(
        flux_lm=flux, interreflection=not opts.get("no_interreflection"),
        locate=locate_settings, backend=opts.get("backend") or "auto",
        replace=not opts.get("keep"), rooms=opts.get("rooms"), report_dir=opts["report"],
        base_dir=os.path.dirname(opts["targets"]) if opts.get("targets") else
        os.path.dirname(src), design=spec, workers=workers_arg(opts.get("workers", "1")),
        zones=not opts.get("no_zones"))
    if mesh_size is not None:
        settings.resolution_m = float(mesh_size)
    result = pipeline.run(doc, settings, progress=progress)
    _say_result(result.summary, say)
    _save_output(doc, result, src, ext, dst, dext, say)
    summary_json = os.path.join(opts["report"], "summary.json")
    if result.report is not None:
        say(f"report -> {result.summary.get('report')} (and {summary_json})")
    else:
        say(f"report -> {summary_json} ({result.summary.get('report', 'no HTML report')})")
    return result.summary


def _checked_paths(opts):
    """(input, its lower-case extension, output, its extension), checked."""
    from invrad_wb.errors import SceneError
    src = opts["input"]
    ext = os.path.splitext(src)[1].lower()
    if ext not in (".fcstd", ".ifc"):
        raise SettingsError(f"{src}: input must be a FreeCAD document (.FCStd) or an IFC"
                            " file (.ifc)")
    if not os.path.isfile(src):
        raise SceneError("file does not exist", src)
    if ext == ".fcstd":
        _check_fcstd(src)
    if opts.get("freecadcmd"):
        find_freecadcmd(opts["freecadcmd"])
    dst = opts["out"]
    dext = os.path.splitext(dst)[1].lower()
    if dext not in (".fcstd", ".ifc"):
        raise SettingsError(f"{dst}: output must end in .FCStd or .ifc")
    from invrad_wb.outputs import check_file, check_folder
    check_file(dst, "--out", inputs=[src, opts.get("targets")])
    if opts.get("report"):
        check_folder(opts["report"], "--report")
    return src, ext, dst, dext


def _check_fcstd(path):
    """A .FCStd is a zip archive with Document.xml (FreeCAD itself would open anything
    else as an empty document, and the run would then say 'no rooms')."""
    import zipfile
    from invrad_wb.errors import SceneError
    try:
        with zipfile.ZipFile(path) as z:
            ok = "Document.xml" in z.namelist()
    except (zipfile.BadZipFile, OSError) as exc:
        raise SceneError(f"not a FreeCAD document (not a zip archive: {exc})", path) from None
    if not ok:
        raise SceneError("not a FreeCAD document (no Document.xml in the archive)", path)


def _run_options(opts, design=False):
    """(flux lm, mesh size m or None, locate settings dict or None): the command line's,
    else the targets file's ``flux_lm`` / ``resolution_m`` (no flux for a design)."""
    from invrad_wb.app.pipeline import check_flux
    from_file = {}
    if opts.get("targets"):
        try:
            with open(opts["targets"], "r", encoding="utf-8") as fh:
                head = json.load(fh)
            from_file = {k: head[k] for k in ("flux_lm", "resolution_m")
                         if isinstance(head, dict) and k in head}
        except (OSError, ValueError):
            pass      # reported properly when the targets are applied
    flux = opts.get("flux") if opts.get("flux") is not None else from_file.get("flux_lm")
    if flux is None and design:
        flux = 1.0       # unused: a design takes its fluxes from the catalogue
    if flux is None:
        print("no --flux (nor flux_lm in the targets file): the number, positions and flux"
              " of each luminaire are fitted")
    else:
        flux = check_flux(flux)
    mesh_size = (opts["mesh_size"] if opts.get("mesh_size") is not None
                 else from_file.get("resolution_m"))
    locate_settings = None
    if opts.get("settings"):
        locate_settings = read_settings_file(opts["settings"])
    return flux, mesh_size, locate_settings


def read_settings_file(path):
    """The locate settings of a ``--settings`` JSON file as a dict, checked (names, types,
    ranges: :meth:`LocateSettings.from_dict`); errors name the file."""
    from invrad_wb.core.inverse.locate import LocateSettings
    try:
        with open(path, "r", encoding="utf-8") as fh:
            d = json.load(fh)
    except (OSError, ValueError, RecursionError) as exc:   # UnicodeDecodeError is a ValueError
        raise SettingsError(f"{path}: cannot read locate settings:"
                            f" {str(exc) or type(exc).__name__}") from None
    try:
        LocateSettings.from_dict(d)
    except InvradError as exc:
        raise SettingsError(f"{path}: {exc}") from None
    except (TypeError, ValueError, OverflowError) as exc:
        raise SettingsError(f"{path}: bad locate settings: {exc}") from None
    return d


def check_ifc_isolated(path):
    """:func:`check_ifc` in a child Python process: ifcopenshell 0.8 (the one FreeCAD
    1.0.0's NativeIFC needs) dies with a segmentation fault on some malformed files (the fuzz
    test's corrupt IFCs did), which in this process would end the command with no message.
    A child that dies is a one-line SceneError naming the file and the signal."""
    import signal
    from invrad_wb.errors import SceneError
    code = ("import sys\n"
            "from invrad_wb.errors import InvradError\n"
            "from invrad_wb.cli.freecad_cmd import check_ifc\n"
            "try:\n"
            "    check_ifc(sys.argv[1])\n"
            "except InvradError as exc:\n"
            "    print(exc, file=sys.stderr); sys.exit(2)\n")
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(
        [p for p in [_checkout_root(),
                     env.get("PYTHONPATH")] if p])
    p = subprocess.run([sys.executable, "-c", code, path], capture_output=True, text=True,
                       env=env)
    if p.returncode == 0:
        return
    lines = [x for x in p.stderr.strip().splitlines() if x.strip()]
    if p.returncode == 2 and lines:
        raise SceneError(lines[-1].replace(f"{path}: ", "", 1), path)
    if p.returncode < 0:
        try:
            name = signal.Signals(-p.returncode).name
        except ValueError:
            name = f"signal {-p.returncode}"
        raise SceneError(f"not a readable IFC file: ifcopenshell crashed reading it ({name})",
                         path)
    raise SceneError(f"not a readable IFC file: its check ended with status {p.returncode}"
                     + (f" ({lines[-1]})" if lines else ""), path)


def check_ifc(path):
    """Read an IFC file with ifcopenshell, without FreeCAD, as far as the import reads it
    before the geometry: it must parse and have rooms (IfcSpace) whose names, GlobalIds,
    storeys and lighting requirements can be read. A file that is not is refused here in one
    line (SceneError), not after a FreeCAD start or as an internal error inside it. Without
    ifcopenshell in this interpreter the check is left to the import under FreeCAD."""
    from invrad_wb.errors import SceneError
    try:
        import ifcopenshell  # noqa: F401
    except ImportError:
        return None
    from invrad_wb.app import ifcrooms
    ifc = ifcrooms._open(path)
    try:
        spaces = ifc.by_type("IfcSpace")
        for sp in spaces:
            (sp.GlobalId, sp.Name, sp.LongName, sp.id())
            ifcrooms.required_illuminance(sp)
            ifcrooms._storey_of(sp)
        for b in ifc.by_type("IfcBuilding"):
            (b.Name, b.GlobalId)
        sorted(((st.Elevation or 0.0), st.Name, st.GlobalId)
               for st in ifc.by_type("IfcBuildingStorey"))
    except SceneError:
        raise
    except Exception as exc:     # ifcopenshell's own errors on a malformed entity
        raise SceneError(f"not a readable IFC file: {type(exc).__name__}:"
                         f" {str(exc).splitlines()[0] if str(exc) else 'malformed'}",
                         path) from None
    if not spaces:
        raise SceneError("the file has no rooms (IfcSpace)", path)
    return len(spaces)


def _open_input(src, ext, opts, say):
    """The FreeCAD document of the input: opened, or the IFC file's rooms imported."""
    import FreeCAD
    from invrad_wb.app import ifcrooms
    from invrad_wb.errors import SceneError
    if ext == ".ifc":
        imp = ifcrooms.import_ifc(src, elements=bool(opts.get("elements")))
        say(f"imported {len(imp.spaces)} room(s) from {os.path.basename(src)}:"
            f" {', '.join(s.Label for s in imp.spaces)}")
        for w in imp.warnings:
            say(f"  warning: {w}")
        return imp.doc
    try:
        return FreeCAD.openDocument(src)
    except Exception as exc:
        raise SceneError(f"FreeCAD cannot open it: {exc}", src)


def _say_result(summary, say):
    """One line per room (luminaires, mean achieved vs target lux, its verdict), one per
    luminaire."""
    from invrad_wb.app.pipeline import describe_rooms
    if "design" in summary:
        _say_design(summary["design"], say)
    else:
        for line in describe_rooms(summary):
            say(line)
    for l in summary["luminaires"]:
        p = ", ".join(f"{x:.3f}" for x in l["position"])
        n = ", ".join(f"{x:.2f}" for x in l["normal"])
        say(f"  {l['fixture']}: ({p}) m facing ({n})")


def _say_design(d, say):
    """One line per designed room: types, Em, U0, watts, verdict, notes."""
    for r in d["rooms"]:
        if "em_lux" not in r:
            say(f"design {r['name']}: " + "; ".join(r["notes"]))
            continue
        q = r["requirement"]
        types = ", ".join(f"{n} x {t}" for t, n in sorted(r["schedule"].items()))
        surf = "".join(f" {k} Em {v['em_lux']:.0f} lx (>= {v['required']['lux']:.4g})"
                       f" U0 {v['u0']:.2f} (>= {v['required']['u0']:g}),"
                       for k, v in r.get("surfaces", {}).items() if "required" in v)
        bg = r.get("background")
        if bg is not None:
            surf += (" no background area," if (bg.get("why") or "").startswith("none")
                     else " background not judged,")
        cz = r.get("cylindrical") or {}
        if cz.get("judged"):
            surf += (f" Ez {cz['em_lux']:.0f} lx (>= {cz['required']['lux']:g})"
                     f" U0 {cz['u0']:.2f} (>= {cz['required']['u0']:g}),")
        ugr = ("UGR not computable" if r.get("ugr") is None else f"UGR {r['ugr']:.1f}"
               + (f" (<= {r['ugr_limit']:g})" if r.get("ugr_limit") is not None else ""))
        pw = r.get("power", {})
        # task areas given: each is judged on its own cells (among the surfaces), not
        # the work plane's figures over all of them
        wp = ("" if r.get("task_areas") else
              f" Em {r['em_lux']:.0f} lx (>= {q['lux']:g}), U0 {r['u0']:.2f} (>= {q['u0']:g}),")
        say(f"design {r['name']}: {types}:{wp}{surf} {ugr}, {r['watts']:.1f} W drawn,"
            f" {pw.get('rated_w', r['watts']):.1f} W installed"
            f" ({pw.get('rated_w_per_m2', r['w_per_m2']):.2f} W/m^2):"
            f" {'meets' if r['compliant'] else 'DOES NOT MEET'} the requirement")
        for note in r["notes"]:
            say(f"  note: {note}")
    say(f"design: {d['total_watts']:.1f} W in total,"
        f" {'every' if d['compliant'] else 'NOT every'} requirement met")


def _save_output(doc, result, src, ext, dst, dext, say):
    """Save the lit model: .FCStd, or .ifc (merged into an IFC input, else exported)."""
    from invrad_wb.app import ifcexport
    os.makedirs(os.path.dirname(os.path.abspath(dst)) or ".", exist_ok=True)
    if dext == ".fcstd":
        doc.saveAs(dst)
        say(f"{len(result.fixtures)} fixture(s) -> {dst}")
    else:
        info = ifcexport.export_ifc(doc, dst, base_ifc=src if ext == ".ifc" else False)
        say(f"{info.fixtures} light fixture(s) -> {dst} ({info.mode} export)")
        for w in info.warnings:
            say(f"  warning: {w}")


def _standalone(argv=None):
    """``python -m invrad_wb.cli.freecad_cmd ...`` without the main CLI."""
    ap = argparse.ArgumentParser(prog="python -m invrad_wb freecad")
    add_arguments(ap)
    args = ap.parse_args(argv)
    # the command line's run guard: SIGTERM/SIGHUP end it like Ctrl-C (the freecadcmd child
    # terminated, its job folder removed), one line, 128 + signal; a full disk in one line
    return run_guarded(main, args, argv, cancelled_status=130)


if __name__ == "freecad_cmd" and os.environ.get(ENV_JOB):
    # executed as a script by freecadcmd (which names the module after the file)
    from invrad_wb.cli import freecad_cmd as _this
    _this.child_main()
elif __name__ == "__main__":
    sys.exit(_standalone())
