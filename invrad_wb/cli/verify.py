"""``invrad verify SCENE --luminaires RESULT.json --report DIR``: forward solve of found
luminaires against the scene's targets, with an HTML/CSV report."""
import os
import sys

from invrad_wb.cli.common import (check_placement, photometry_arg, read_scene_arg,
                                  scene_args, warn_suspicious_targets, with_photometry)
from invrad_wb.core.model.targets import require_targets
from invrad_wb.progress import CliProgress
from invrad_wb.outputs import check_folder


def add_parser(sub):
    p = sub.add_parser("verify", help="report how close given luminaires come to the targets")
    scene_args(p)
    p.add_argument("--luminaires", required=True, help="LUMS.json or a locate RESULT.json")
    p.add_argument("--report", required=True, help="output folder")
    p.add_argument("-v", "--verbose", action="store_true", help="one line per step")
    p.add_argument("--no-interreflection", action="store_true")
    p.set_defaults(func=run)


def run(args):
    from invrad_wb.core.model.luminaires import load_luminaires
    from invrad_wb.core.forward.render import render, work_note
    from invrad_wb.core.output.report import build_report
    check_folder(args.report, "--report")
    phot = photometry_arg(args)
    scene = read_scene_arg(args)
    require_targets(scene, args.scene, args.lux, args.texture)
    warn_suspicious_targets(args.scene, scene)
    lums = with_photometry(load_luminaires(args.luminaires), phot)
    check_placement(args.luminaires, scene, lums)
    note = work_note(scene, lums, not args.no_interreflection)   # luminaires x points
    if note:
        print(f"invrad: {note}", file=sys.stderr)
    with CliProgress(args.verbose, "verify") as progress:
        achieved = render(scene, lums, interreflection=not args.no_interreflection,
                          backend=args.backend, progress=progress)
    paths = build_report(scene, scene.vertex_targets(), achieved, lums, args.report,
                         project=os.path.splitext(os.path.basename(args.scene))[0])
    print(f"report -> {paths.html}" + (f" and {paths.pdf}" if paths.pdf else ""))
    for note in paths.notes:
        print(f"invrad: {note}", file=sys.stderr)
