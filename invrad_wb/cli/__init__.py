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
import sys

# before anything imports numpy (cli.blas imports neither)
from invrad_wb.cli.blas import one_blas_thread_at_start

one_blas_thread_at_start()

from invrad_wb.cli import design, example, info, locate, render, verify  # noqa: E402
from invrad_wb.cli.common import run_guarded  # noqa: E402


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
    return run_guarded(args.func, args, argv)


if __name__ == "__main__":
    sys.exit(main())
