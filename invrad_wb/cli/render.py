"""``invrad render SCENE --luminaires LUMS.json -o OUT.ply``: forward solve, writes the
scene with its computed illuminance as ``lux`` (a target scene with a known answer)."""
import sys
import time

import numpy as np

from invrad_wb.cli.common import (check_placement, photometry_arg, read_scene_arg,
                                  scene_args, with_photometry)
from invrad_wb.progress import CliProgress
from invrad_wb.outputs import check_file


def add_parser(sub):
    p = sub.add_parser("render", help="forward solve: illuminance of given luminaires")
    scene_args(p)
    p.add_argument("--luminaires", required=True, help="LUMS.json")
    p.add_argument("-o", "--output", required=True, help="output PLY with lux")
    p.add_argument("-v", "--verbose", action="store_true", help="one line per step")
    p.add_argument("--no-interreflection", action="store_true", help="direct light only")
    p.add_argument("--no-occlusion", action="store_true", help="no shadows")
    p.set_defaults(func=run)


def run(args):
    from invrad_wb.core.model.luminaires import load_luminaires
    from invrad_wb.core.forward.render import render, work_note
    from invrad_wb.core.io.sceneio import write_scene
    check_file(args.output, "-o", inputs=[args.scene, args.luminaires])
    phot = photometry_arg(args)
    scene = read_scene_arg(args)
    lums = with_photometry(load_luminaires(args.luminaires), phot)
    check_placement(args.luminaires, scene, lums)
    note = work_note(scene, lums, not args.no_interreflection)   # luminaires x points
    if note:
        print(f"invrad: {note}", file=sys.stderr)
    t = time.time()
    with CliProgress(args.verbose, "render") as progress:
        total, direct, indirect = render(scene, lums,
                                         interreflection=not args.no_interreflection,
                                         occlusion=not args.no_occlusion,
                                         backend=args.backend, return_parts=True,
                                         progress=progress)
    write_scene(args.output, scene, lux=total)
    print(f"rendered {len(lums)} luminaire(s) on {len(scene.vertices)} vertices in"
          f" {time.time() - t:.2f} s: {total.min():.1f}-{total.max():.1f} lx"
          f" (indirect up to {indirect.max():.1f} lx) -> {args.output}")
    if lums and not np.nanmax(total) > 0:
        print(f"invrad: the luminaires of {args.luminaires} light no surface of"
              f" {args.scene}: check their positions, normals and units", file=sys.stderr)
        return 3
