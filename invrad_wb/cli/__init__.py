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
* ``design SCENE --spec DESIGN.json -o RESULT.json``: lighting design from requirements.
* ``freecad IN.FCStd|IN.ifc --out OUT --report DIR``: the FreeCAD pipeline (runs under
  freecadcmd).

One module per command (``add_parser`` and ``run``); what they share is in
:mod:`invrad_wb.cli.common`.

Errors in the input are reported in one line naming the file and value, exit status 2.
"""
import argparse
import os
import sys

from invrad_wb.cli import design, example, info, locate, render, verify
from invrad_wb.cli.common import internal_error
from invrad_wb.errors import InvradError


def build_parser():
    ap = argparse.ArgumentParser(prog="python -m invrad_wb",
                                 description="invrad: inverse lighting design (inverted radiosity)")
    sub = ap.add_subparsers(dest="command", required=True)
    for command in (render, locate, verify, example, info, design):
        command.add_parser(sub)
    try:
        from invrad_wb.cli import freecad_cmd
        freecad_cmd.add_parser(sub)
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
    from invrad_wb.runguard import RunGuard, exit_status, interrupted_text, output_error
    try:
        with RunGuard():              # signals like Ctrl-C; a failed run's outputs removed
            rc = args.func(args)
    except InvradError as exc:
        if getattr(exc, "traceback_text", None):      # an internal error of a child process
            return internal_error(exc, exc.traceback_text, argv)
        print(f"invrad: error: {exc}", file=sys.stderr)
        return 2
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


if __name__ == "__main__":
    sys.exit(main())
