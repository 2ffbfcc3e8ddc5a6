"""What the commands share: scene arguments and reading, photometry, placement checks,
batches of scenes, strict JSON, and the internal-error report (a log file and one line)."""
import argparse
import os
import sys
import time

import numpy as np

from invrad_wb.errors import InvradError

#: target illuminance above which a scene is suspicious: brighter than direct sunlight
#: (about 100,000 lx), never an indoor lighting requirement; more likely wrong units
SUSPICIOUS_LUX = 150000.0


def warn_suspicious_targets(path, scene):
    """A warning (stderr) when targets are brighter than sunlight (units, a typo)."""
    t = scene.vertex_targets()
    top = float(np.nanmax(t)) if np.isfinite(t).any() else 0.0
    if top > SUSPICIOUS_LUX:
        n = int(np.sum(t > SUSPICIOUS_LUX))
        print(f"invrad: warning: {path}: {n} target(s) up to {top:.3g} lx, brighter than"
              f" direct sunlight ({SUSPICIOUS_LUX:.0f} lx): check the targets' units",
              file=sys.stderr)


def scene_args(p, many=False):
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


def photometry_arg(args):
    """The --photometry file read (or None); errors name the file."""
    if not getattr(args, "photometry", None):
        return None
    from invrad_wb.core.model.photometry import read_photometry
    return read_photometry(args.photometry)


def with_photometry(lums, phot):
    """Give luminaires without their own distribution the --photometry one."""
    if phot is not None:
        for lum in lums:
            if lum.photometry is None:
                lum.photometry = phot
    return lums


def read_scene_arg(args):
    from invrad_wb.core.io.sceneio import read_scene
    return read_scene(args.scene, lux=args.lux, texture=args.texture,
                      texture_max_lux=args.texture_max_lux, unit=args.unit)


def check_placement(path, scene, lums):
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



#: scene files a folder given to ``locate`` contributes (PLY only: other meshes need --lux)
BATCH_SUFFIXES = (".ply",)


def batch_scenes(paths):
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


def strict_json(data):
    """JSON text any strict reader accepts: NaN and infinities become null."""
    from invrad_wb.core.io.jsonout import dumps
    return dumps(data)


def bool_arg(s):
    if s.lower() in ("1", "true", "yes", "on"):
        return True
    if s.lower() in ("0", "false", "no", "off"):
        return False
    if s == "auto":
        return "auto"
    raise argparse.ArgumentTypeError(f"expected true/false, got {s!r}")



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


def internal_error(exc, tb_text, argv=None):
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


#: ``INVRAD_SLOW_EXIT=1``: end ``python -m invrad_wb`` through the interpreter's whole
#: finalisation (see :func:`leave`)
ENV_SLOW_EXIT = "INVRAD_SLOW_EXIT"


def exit_status(rc):
    """The process exit status ``sys.exit(rc)`` would give (None 0, an int itself, else 1)."""
    if rc is None:
        return 0
    if isinstance(rc, bool) or not isinstance(rc, int):
        return 1
    return rc & 0xFF


def leave(rc):
    """End ``python -m invrad_wb`` with ``rc`` once its work is done and written.

    Python's exit hooks run (``atexit``: logging's flush, ``weakref.finalize``: temporary
    folders, multiprocessing's and Dask's shut-downs), the standard streams are flushed,
    then the process ends with ``os._exit``: the interpreter's own finalisation (tearing
    down some 600 modules, the OpenCL driver's and LLVM's library destructors) is skipped.
    Measured on the 2-core PoCL machine (``bench/bench_cli.py``, the office example):
    that finalisation took 0.9-1.1 s wall and 0.2 s CPU after every run; now 0.07-0.09 s.
    Not when another Python thread is still alive (the interpreter would wait for it),
    Dask was used, a profiler or tracer runs (``python -m cProfile -m invrad_wb`` writes
    its figures after the module returns; coverage, debuggers), nor with
    ``INVRAD_SLOW_EXIT=1``: then ``sys.exit`` as before. Never
    used when the command line runs inside FreeCAD (``cli.main``), only by
    ``python -m invrad_wb``."""
    import threading
    code = exit_status(rc)
    if (os.environ.get(ENV_SLOW_EXIT, "").strip() not in ("", "0")
            or sys.getprofile() is not None or sys.gettrace() is not None
            or any(t is not threading.main_thread() and t.is_alive()
                   for t in threading.enumerate())
            or "distributed" in sys.modules):
        sys.exit(rc)
    import atexit
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        try:
            if stream is not None:
                stream.flush()
        except BrokenPipeError:         # the reader went away (``| head``), as run_guarded
            code = code or 141
        except (OSError, ValueError):
            code = code or 1
    os._exit(code)


def run_guarded(func, args, argv=None, cancelled_status=2):
    """``func(args)`` under a :class:`~invrad_wb.runguard.RunGuard` (signals end it like
    Ctrl-C, a failed run leaves no output it created), with the command line's endings:
    an InvradError or a full disk in one line (2), a signal ``128 + signal`` with one
    line, a closed pipe 141, anything else an internal error (70, the traceback in a log
    file). A :class:`~invrad_wb.errors.Cancelled` run ends with ``cancelled_status``.
    Returns the exit status. Used by ``python -m invrad_wb`` and by a direct
    ``python -m invrad_wb.cli.freecad_cmd``."""
    from invrad_wb.errors import Cancelled
    from invrad_wb.runguard import RunGuard, exit_status, interrupted_text, output_error
    try:
        with RunGuard():              # signals like Ctrl-C; a failed run's outputs removed
            rc = func(args)
    except InvradError as exc:
        if getattr(exc, "traceback_text", None):      # an internal error of a child process
            return internal_error(exc, exc.traceback_text, argv)
        print(f"invrad: error: {exc}", file=sys.stderr)
        return cancelled_status if isinstance(exc, Cancelled) else 2
    except KeyboardInterrupt as exc:              # also SIGTERM, SIGHUP (runguard)
        print(f"invrad: {interrupted_text(exc)}", file=sys.stderr)
        return exit_status(exc)
    except BrokenPipeError:
        # the reader of our output went away (``| head``): not an error of ours
        try:
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        except (OSError, ValueError):
            pass
        return 141
    except Exception as exc:             # a bug: one line, the traceback in a log file
        line = output_error(exc)         # ... unless the disk is full or read-only
        if line:
            print(f"invrad: error: {line}", file=sys.stderr)
            return 2
        import traceback
        return internal_error(exc, traceback.format_exc(), argv)
    return rc if isinstance(rc, int) else 0
