"""Command line: ``python -m invrad_wb <command> ...`` (also installed as ``invrad``).

Commands work on plain meshes without FreeCAD:

* ``render SCENE --luminaires LUMS.json -o OUT.ply``: forward solve, writes the scene with
  its computed illuminance as ``lux`` (a target scene with a known answer).
* ``locate SCENE [--flux LM] -o RESULT.json [--vote-maps DIR]``: find luminaire positions
  (and, without ``--flux``, each one's flux).
* ``verify SCENE --luminaires RESULT.json --report DIR``: forward solve of found luminaires
  against the scene's targets, with an HTML/CSV report.
* ``example NAME -o OUT.ply``: write a generated known-answer scene.
* ``info SCENE``: rooms, planes and targets of a scene.
* ``freecad IN.FCStd|IN.ifc --out OUT --report DIR``: the FreeCAD pipeline (runs under
  freecadcmd).

Errors in the input are reported in one line naming the file and value, exit status 2.
"""
import argparse
from dataclasses import asdict, fields
import json
import os
import sys
import time

import numpy as np

from invrad_wb.errors import InvradError
from invrad_wb.outputs import check_file, check_folder
from invrad_wb.progress import CliProgress, add_parallel_args, workers_arg

#: finest mesh of a generated example (metres): finer meshes grow past a laptop's memory
MIN_EXAMPLE_CELL_M = 0.02
#: target illuminance above which a scene is suspicious: brighter than direct sunlight
#: (about 100,000 lx), never an indoor lighting requirement; more likely wrong units
SUSPICIOUS_LUX = 150000.0


def _warn_suspicious_targets(path, scene):
    """A warning (stderr) when targets are brighter than sunlight (units, a typo)."""
    t = scene.vertex_targets()
    top = float(np.nanmax(t)) if np.isfinite(t).any() else 0.0
    if top > SUSPICIOUS_LUX:
        n = int(np.sum(t > SUSPICIOUS_LUX))
        print(f"invrad: warning: {path}: {n} target(s) up to {top:.3g} lx, brighter than"
              f" direct sunlight ({SUSPICIOUS_LUX:.0f} lx): check the targets' units",
              file=sys.stderr)


def _scene_args(p, many=False):
    if many:
        p.add_argument("scene", nargs="+",
                       help="scene file: PLY with x y z lux (+ room reflectance), or any mesh"
                            " trimesh reads together with --lux or --texture; several files or"
                            " folders of PLY files: one process for all, -o is then a folder"
                            " of SCENE.json results")
    else:
        p.add_argument("scene", help="scene file: PLY with x y z lux (+ room reflectance), or"
                                     " any mesh trimesh reads together with --lux or --texture")
    p.add_argument("--lux", help="sidecar with target lux per vertex or face (.json/.csv)")
    p.add_argument("--texture", help="illuminance texture (EXR/HDR/PNG) for a UV-mapped mesh")
    p.add_argument("--texture-max-lux", type=float,
                   help="lux of a white pixel in an 8/16-bit texture")
    p.add_argument("--unit", default="m", choices=("m", "cm", "mm"),
                   help="length unit of the scene file (default m)")
    p.add_argument("--backend", default="auto", choices=("auto", "opencl", "numpy"),
                   help="compute backend (default: OpenCL if a device is present)")
    p.add_argument("--photometry", metavar="FILE",
                   help="EULUMDAT (.ldt) or IES (.ies) intensity distribution of every"
                        " luminaire without its own (default: lambertian)")


def _photometry(args):
    """The --photometry file read (or None); errors name the file."""
    if not getattr(args, "photometry", None):
        return None
    from invrad_wb.core.model.photometry import read_photometry
    return read_photometry(args.photometry)


def _with_photometry(lums, phot):
    """Give luminaires without their own distribution the --photometry one."""
    if phot is not None:
        for lum in lums:
            if lum.photometry is None:
                lum.photometry = phot
    return lums


def _read(args):
    from invrad_wb.core.io.sceneio import read_scene
    return read_scene(args.scene, lux=args.lux, texture=args.texture,
                      texture_max_lux=args.texture_max_lux, unit=args.unit)


def _cmd_render(args):
    from invrad_wb.core.model.luminaires import load_luminaires
    from invrad_wb.core.forward.render import render
    from invrad_wb.core.io.sceneio import write_scene
    check_file(args.output, "-o", inputs=[args.scene, args.luminaires])
    phot = _photometry(args)
    scene = _read(args)
    lums = _with_photometry(load_luminaires(args.luminaires), phot)
    _check_placement(args.luminaires, scene, lums)
    t = time.time()
    total, direct, indirect = render(scene, lums, interreflection=not args.no_interreflection,
                                     occlusion=not args.no_occlusion, backend=args.backend,
                                     return_parts=True)
    write_scene(args.output, scene, lux=total)
    print(f"rendered {len(lums)} luminaire(s) on {len(scene.vertices)} vertices in"
          f" {time.time() - t:.2f} s: {total.min():.1f}-{total.max():.1f} lx"
          f" (indirect up to {indirect.max():.1f} lx) -> {args.output}")
    if lums and not np.nanmax(total) > 0:
        print(f"invrad: the luminaires of {args.luminaires} light no surface of"
              f" {args.scene}: check their positions, normals and units", file=sys.stderr)
        return 3


def _check_placement(path, scene, lums):
    """Errors (a disk larger than its room) stop the command; the rest are warnings."""
    from invrad_wb.core.model.luminaires import placement_problems
    errors, warnings = placement_problems(scene, lums)
    if errors:
        raise InvradError(f"{path}: {errors[0]}" + (f" (and {len(errors) - 1} more)"
                                                    if len(errors) > 1 else ""))
    for w in warnings[:10]:
        print(f"invrad: warning: {path}: {w}", file=sys.stderr)
    if len(warnings) > 10:
        print(f"invrad: warning: {path}: {len(warnings) - 10} more such luminaire(s)",
              file=sys.stderr)


def _settings_from_args(args):
    from invrad_wb.core.inverse.locate import LocateSettings
    s = LocateSettings()
    for f in fields(LocateSettings):
        v = getattr(args, f.name, None)
        if v is not None:
            setattr(s, f.name, v)
    if getattr(args, "settings", None):
        try:
            with open(args.settings, "r", encoding="utf-8") as fh:
                d = json.load(fh)
        except (OSError, json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise InvradError(f"{args.settings}: cannot read settings: {exc}")
        if not isinstance(d, dict):
            raise InvradError(f"{args.settings}: settings must be a JSON object of"
                              f" name: value, got {type(d).__name__}")
        try:
            s = LocateSettings.from_dict({**asdict(s), **d})
        except InvradError as exc:
            raise InvradError(f"{args.settings}: {exc}")
    return s.check()


#: scene files a folder given to ``locate`` contributes (PLY only: other meshes need --lux)
BATCH_SUFFIXES = (".ply",)


def _batch_scenes(paths):
    """The scene files of ``locate``'s arguments: files as given, folders' PLY files sorted."""
    out = []
    for p in paths:
        if os.path.isdir(p):
            found = sorted(os.path.join(p, f) for f in os.listdir(p)
                           if f.lower().endswith(BATCH_SUFFIXES)
                           and os.path.isfile(os.path.join(p, f)))
            if not found:
                raise InvradError(f"{p}: the folder holds no scene file (*.ply)")
            out.extend(found)
        elif not os.path.exists(p):
            raise InvradError(f"{p}: no such scene file or folder")
        else:
            out.append(p)
    stems = {}
    for p in out:
        stem = os.path.splitext(os.path.basename(p))[0]
        if stem in stems:
            raise InvradError(f"{p}: same name as {stems[stem]}: their results would both"
                              f" be {stem}.json; rename one")
        stems[stem] = p
    return out


def run_batch(scenes, one):
    """``one(path, stem) -> exit status`` for each scene in turn, each announced; a scene's
    InvradError is printed in one line and counts as status 2, the others go on.
    Returns ``([(path, status) of the scenes that did not end with 0], seconds)``."""
    failed, t0 = [], time.time()
    for i, path in enumerate(scenes):
        print(f"[{i + 1}/{len(scenes)}] {path}")
        try:
            rc = one(path, os.path.splitext(os.path.basename(path))[0])
        except InvradError as exc:
            print(f"invrad: error: {exc}", file=sys.stderr)
            rc = 2
        if rc:
            failed.append((path, rc))
    return failed, time.time() - t0


def _cmd_locate(args):
    scenes = args.scene
    batch = len(scenes) > 1 or os.path.isdir(scenes[0])
    settings = _settings_from_args(args)
    phot = _photometry(args)
    workers = workers_arg(args.workers)
    if args.flux is None and phot is not None and phot.flux_lm:
        args.flux = phot.flux_lm
        print(f"flux of one luminaire: {args.flux:.0f} lm, from {args.photometry}")
    elif args.flux is None:
        print("no --flux: the number, positions and flux of each luminaire are fitted")
    if not batch:
        check_file(args.output, "-o", inputs=scenes)
        if args.vote_maps:
            check_folder(args.vote_maps, "--vote-maps")
        return _locate_one(args, scenes[0], args.output, args.vote_maps, settings, phot,
                           workers)
    # many scenes in one process: one OpenCL context, kernels built once
    if args.lux or args.texture:
        raise InvradError("--lux/--texture name one scene's sidecar: with several scenes"
                          " give PLY files that carry their targets")
    scenes = _batch_scenes(scenes)
    check_folder(args.output, "-o (a folder for RESULT.json files with several scenes)")
    if args.vote_maps:
        check_folder(args.vote_maps, "--vote-maps")
    os.makedirs(args.output, exist_ok=True)

    def one(path, stem):
        out = os.path.join(args.output, stem + ".json")
        check_file(out, "-o", inputs=[path])
        return _locate_one(args, path, out, args.vote_maps and
                           os.path.join(args.vote_maps, stem), settings, phot, workers)
    failed, seconds = run_batch(scenes, one)
    print(f"{len(scenes) - len(failed)} of {len(scenes)} scene(s) located in"
          f" {seconds:.1f} s -> {args.output}")
    if failed:
        print("invrad: no result for: " + ", ".join(p for p, _ in failed), file=sys.stderr)
        return max(rc for _, rc in failed)


def _locate_one(args, scene_path, output, vote_maps, settings, phot, workers):
    """One scene: locate, write RESULT.json (and vote maps), print the luminaires."""
    from invrad_wb.core.io.atomic import atomic_write_text
    from invrad_wb.core.inverse.locate import locate
    from invrad_wb.core.io.sceneio import read_scene
    scene = read_scene(scene_path, lux=args.lux, texture=args.texture,
                       texture_max_lux=args.texture_max_lux, unit=args.unit)
    _warn_suspicious_targets(scene_path, scene)
    with CliProgress(args.verbose, "locate") as progress:
        # a plain mesh's single room takes the scene's name (progress, vote-map titles)
        names = ({int(scene.rooms[0]): os.path.splitext(os.path.basename(scene_path))[0]}
                 if len(scene.rooms) == 1 else None)
        result = locate(scene, args.flux, settings=settings, backend=args.backend,
                        progress=progress, photometry=phot, workers=workers, dask=args.dask,
                        room_names=names)
    _with_photometry(result.luminaires, phot)
    data = result.to_dict()
    if vote_maps:                  # first: an interrupted map write leaves RESULT.json as it was
        files = result.save_vote_maps(vote_maps)
    atomic_write_text(output, strict_json(data))
    for l in result.luminaires:
        p = ", ".join(f"{x:.3f}" for x in l.position)
        n = ", ".join(f"{round(float(x), 2) + 0.0:.2f}" for x in l.normal)   # never -0.00
        print(f"room {l.room}: luminaire at ({p}) m facing ({n}), {l.flux_lm:.0f} lm,"
              f" score {l.score:.3f} [{l.extra.get('mount', '')}]")
    of = "" if args.flux is None else f" of {args.flux:g} lm"
    print(f"{len(result.luminaires)} luminaire(s){of} in"
          f" {result.timings['total']:.2f} s ({result.backend}) -> {output}")
    if vote_maps:
        print(f"vote maps: {len(files)} files in {vote_maps}")
    if not result.luminaires:
        lit = np.nan_to_num(scene.vertex_targets(), nan=0.0) > 0
        if lit.any():
            print(f"invrad: no luminaire{of} explains the targets of"
                  f" {scene_path} ({int(lit.sum())} lit target points): check the flux, the"
                  " units (--unit) and that the targets are reachable from the room's"
                  " surfaces", file=sys.stderr)
            return 3
    return 0


def _cmd_verify(args):
    from invrad_wb.core.model.luminaires import load_luminaires
    from invrad_wb.core.forward.render import render
    from invrad_wb.core.output.report import build_report
    check_folder(args.report, "--report")
    phot = _photometry(args)
    scene = _read(args)
    _warn_suspicious_targets(args.scene, scene)
    lums = _with_photometry(load_luminaires(args.luminaires), phot)
    _check_placement(args.luminaires, scene, lums)
    achieved = render(scene, lums, interreflection=not args.no_interreflection,
                      backend=args.backend)
    paths = build_report(scene, scene.vertex_targets(), achieved, lums, args.report,
                         project=os.path.splitext(os.path.basename(args.scene))[0])
    print(f"report -> {paths.html}" + (f" and {paths.pdf}" if paths.pdf else ""))
    for note in paths.notes:
        print(f"invrad: {note}", file=sys.stderr)


def _cmd_example(args):
    from invrad_wb.core.model.luminaires import write_luminaires_json
    from invrad_wb.core.synthetic.scenarios import known_scene, MIXED_SCENARIOS
    from invrad_wb.core.synthetic.scenarios import SCENARIOS as ONE_FLUX
    SCENARIOS = ONE_FLUX + MIXED_SCENARIOS
    from invrad_wb.core.io.sceneio import write_scene
    if args.name not in SCENARIOS:
        raise InvradError(f"unknown example {args.name!r}; choose one of {', '.join(SCENARIOS)}")
    if not (np.isfinite(args.cell) and MIN_EXAMPLE_CELL_M <= args.cell <= 5.0):
        raise InvradError(f"--cell {args.cell} m: the mesh size must be between"
                          f" {MIN_EXAMPLE_CELL_M} and 5 m")
    if not (np.isfinite(args.reflectance) and 0.0 <= args.reflectance < 1.0):
        raise InvradError(f"--reflectance {args.reflectance}: must be in [0, 1)")
    check_file(args.output, "-o")
    if args.truth:
        check_file(args.truth, "--truth")
    scene, lums = known_scene(args.name, reflectance=args.reflectance, cell=args.cell,
                              backend=args.backend)
    write_scene(args.output, scene)
    print(f"wrote {args.output} ({len(scene.faces)} faces, lit by {len(lums)} luminaire(s))")
    if args.truth:
        write_luminaires_json(args.truth, lums, scenario=args.name)
        print(f"true luminaires -> {args.truth}")


def _cmd_info(args):
    scene = _read(args)
    print(scene)
    tg = scene.vertex_targets()
    fin = np.isfinite(tg)
    print(f"targets: {int(fin.sum())} of {len(tg)} vertices"
          f" ({int((tg[fin] == 0).sum())} shade), {np.nanmin(tg) if fin.any() else float('nan'):.1f}"
          f"-{np.nanmax(tg) if fin.any() else float('nan'):.1f} lx")
    lo, hi = scene.bounds
    print(f"bounds: {lo.round(3).tolist()} - {hi.round(3).tolist()} m")
    for p in scene.planes:
        print(f"  plane {p.index:3d} room {p.room} normal {p.normal.round(3).tolist()}"
              f" area {p.area:.2f} m^2 ({len(p.faces)} faces){' virtual' if p.is_virtual else ''}")


def strict_json(data):
    """JSON text any strict reader accepts: NaN and infinities become null."""
    from invrad_wb.core.io.jsonout import dumps
    return dumps(data)


def _json_default(o):
    from invrad_wb.core.io.jsonout import jsonable
    return jsonable(o)


def _bool(s):
    if s.lower() in ("1", "true", "yes", "on"):
        return True
    if s.lower() in ("0", "false", "no", "off"):
        return False
    if s == "auto":
        return "auto"
    raise argparse.ArgumentTypeError(f"expected true/false, got {s!r}")


def build_parser():
    ap = argparse.ArgumentParser(prog="python -m invrad_wb",
                                 description="invrad: inverse lighting design (inverted radiosity)")
    sub = ap.add_subparsers(dest="command", required=True)

    p = sub.add_parser("render", help="forward solve: illuminance of given luminaires")
    _scene_args(p)
    p.add_argument("--luminaires", required=True, help="LUMS.json")
    p.add_argument("-o", "--output", required=True, help="output PLY with lux")
    p.add_argument("--no-interreflection", action="store_true", help="direct light only")
    p.add_argument("--no-occlusion", action="store_true", help="no shadows")
    p.set_defaults(func=_cmd_render)

    p = sub.add_parser("locate", help="find luminaire positions for the scene's targets")
    _scene_args(p, many=True)
    p.add_argument("--flux", type=float,
                   help="flux of one luminaire, lm (default: the --photometry file's; without"
                        " either, each luminaire's flux is fitted)")
    p.add_argument("-o", "--output", required=True,
                   help="RESULT.json (with several scenes: a folder)")
    p.add_argument("--vote-maps", help="folder for vote-map images (several scenes: one"
                                       " subfolder each)")
    p.add_argument("--settings", help="JSON file with locate settings")
    p.add_argument("-v", "--verbose", action="store_true", help="one line per step")
    add_parallel_args(p)
    g = p.add_argument_group("locate settings (defaults need only the flux)")
    g.add_argument("--vote-model", dest="vote_model", choices=("exact", "ellipse"))
    g.add_argument("--resolution", dest="pixel_m", type=float, metavar="M",
                   help="vote-map resolution, metres per pixel (0.1); not the room mesh"
                        " size, which is `freecad --mesh-size`")
    g.add_argument("--votes-per-m2", dest="votes_per_m2", type=float)
    g.add_argument("--weighting", choices=("illumination", "distance", "both", "none"))
    g.add_argument("--vote-strength", dest="vote_strength", type=float)
    g.add_argument("--occlusion", type=_bool, help="auto/true/false")
    g.add_argument("--dummy-planes", dest="dummy_planes", type=_bool)
    g.add_argument("--dummy-spacing", dest="dummy_spacing_m", type=float)
    g.add_argument("--dummy-count", dest="dummy_count", type=int)
    g.add_argument("--two-sided-dummies", dest="two_sided_dummies", type=_bool)
    g.add_argument("--all-planes", dest="all_planes", type=_bool)
    g.add_argument("--threshold", type=float, help="0-254 (24)")
    g.add_argument("--neighbourhood", dest="neighbourhood_m", type=float, help="metres (0.3)")
    g.add_argument("--refine", type=_bool, help="joint refinement (true)")
    g.add_argument("--optimiser", choices=("lm", "es"))
    g.add_argument("--indirect", choices=("radiosity", "ambient", "none"))
    g.add_argument("--aim", choices=("fixed", "free"),
                   help="fixed: luminaires face along their surface's normal (default);"
                        " free: fit each mounted luminaire's aim too (adjustable spots)")
    g.add_argument("--max-tilt", dest="max_tilt_deg", type=float, metavar="DEG",
                   help="with --aim free: largest tilt from the surface's normal (70)")
    p.set_defaults(func=_cmd_locate)

    p = sub.add_parser("verify", help="report how close given luminaires come to the targets")
    _scene_args(p)
    p.add_argument("--luminaires", required=True, help="LUMS.json or a locate RESULT.json")
    p.add_argument("--report", required=True, help="output folder")
    p.add_argument("--no-interreflection", action="store_true")
    p.set_defaults(func=_cmd_verify)

    p = sub.add_parser("example", help="write a generated known-answer scene")
    p.add_argument("name", help="one of: " + ", ".join(
        ("one_ceiling", "two_ceiling", "wall_light", "pendant", "pillar", "l_room", "sloped",
         "disk", "four_rooms")))
    p.add_argument("-o", "--output", required=True)
    p.add_argument("--truth", help="also write the true luminaires (JSON)")
    p.add_argument("--reflectance", type=float, default=0.0)
    p.add_argument("--cell", type=float, default=0.1, help="mesh size, metres")
    p.add_argument("--backend", default="auto", choices=("auto", "opencl", "numpy"))
    p.set_defaults(func=_cmd_example)

    p = sub.add_parser("info", help="describe a scene")
    _scene_args(p)
    p.set_defaults(func=_cmd_info)

    from invrad_wb import design_cli
    design_cli.add_parser(sub)
    try:
        from invrad_wb import freecad_cli
        freecad_cli.add_parser(sub)
    except ImportError:
        pass
    return ap


def main(argv=None):
    import warnings

    def show(message, category, filename, lineno, file=None, line=None):
        print(f"invrad: warning: {message}", file=sys.stderr)
    warnings.showwarning = show     # before parsing: deprecated options warn there
    ap = build_parser()
    args = ap.parse_args(argv)
    if getattr(args, "verbose", False):
        # -v: also the OpenCL compiler's messages and build times (silent otherwise)
        import logging
        handler = logging.StreamHandler(sys.stderr)
        handler.setFormatter(logging.Formatter("invrad: %(message)s"))
        handler.name = "invrad-cli"
        log = logging.getLogger("invrad_wb.opencl")
        if not any(h.name == handler.name for h in log.handlers):
            log.addHandler(handler)
        log.setLevel(logging.INFO)
    try:
        rc = args.func(args)
    except InvradError as exc:
        if getattr(exc, "traceback_text", None):      # an internal error of a child process
            return _internal_error(exc, exc.traceback_text, argv)
        print(f"invrad: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("invrad: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # the reader of our output went away (``| head``): not an error of ours
        try:
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        except (OSError, ValueError):
            pass
        return 141
    except Exception as exc:             # a bug: one line, the traceback in a log file
        import traceback
        return _internal_error(exc, traceback.format_exc(), argv)
    return rc if isinstance(rc, int) else 0


#: exit status of an internal error (BSD sysexits EX_SOFTWARE)
EXIT_INTERNAL = 70
ENV_LOG_DIR = "INVRAD_LOG_DIR"


def log_folder():
    """Where internal errors' tracebacks go: ``$INVRAD_LOG_DIR``, else
    ``$XDG_CACHE_HOME/invrad`` (``~/.cache/invrad``)."""
    if os.environ.get(ENV_LOG_DIR):
        return os.environ[ENV_LOG_DIR]
    cache = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(cache, "invrad")


def _internal_error(exc, tb_text, argv=None):
    """Report an unexpected exception in one line that says what to report and where its
    traceback went (a log file); returns :data:`EXIT_INTERNAL`.

    The traceback is for the maintainers, not the user: it goes to a log file with the
    command line and versions. Only when no log file can be written does it go to stderr
    (after the line), so that it is never lost."""
    import datetime
    import platform
    from invrad_wb import __version__
    stamp = datetime.datetime.now().strftime("%Y%m%d-%H%M%S")
    cmd = " ".join(sys.argv[:1] + list(sys.argv[1:] if argv is None else argv))
    text = (f"invrad {__version__} internal error\n"
            f"command: {cmd}\ncwd: {os.getcwd()}\n"
            f"python {platform.python_version()}, numpy {np.__version__},"
            f" {platform.platform()}\n\n{tb_text}")
    path = None
    for folder in (log_folder(), None):
        try:
            if folder is None:
                import tempfile
                folder = tempfile.gettempdir()
            os.makedirs(folder, exist_ok=True)
            candidate = os.path.join(folder, f"invrad-error-{stamp}-{os.getpid()}.log")
            with open(candidate, "w", encoding="utf-8") as fh:
                fh.write(text)
            path = candidate
            break
        except OSError:
            continue
    if getattr(exc, "traceback_text", None):     # the child said "internal error: T: msg"
        what = str(exc).replace("internal error: ", "", 1).replace("\n", " ")
    else:
        what = f"{type(exc).__name__}: {exc}".replace("\n", " ")
    if len(what) > 300:
        what = what[:297] + "..."
    if isinstance(exc, MemoryError):
        what = ("out of memory (an allocation invrad did not estimate; set"
                f" INVRAD_MEMORY_LIMIT lower or ask for less): {what}")
    where = f"the traceback is in {path}" if path else "the traceback follows"
    print(f"invrad: internal error: {what}. This is a bug in invrad, not in your input:"
          f" please report it with the command line, the input files if you can share"
          f" them, and the log file ({where})", file=sys.stderr)
    if path is None:
        sys.stderr.write(text)
    return EXIT_INTERNAL


if __name__ == "__main__":
    sys.exit(main())
