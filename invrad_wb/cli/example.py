"""``invrad example NAME -o OUT.ply``: write a generated known-answer scene."""
import numpy as np

from invrad_wb.errors import InvradError
from invrad_wb.outputs import check_file

#: finest mesh of a generated example (metres): finer meshes grow past a laptop's memory
MIN_EXAMPLE_CELL_M = 0.02


def add_parser(sub):
    p = sub.add_parser("example", help="write a generated known-answer scene")
    p.add_argument("name", help="one of: " + ", ".join(
        ("one_ceiling", "two_ceiling", "wall_light", "pendant", "pillar", "l_room", "sloped",
         "disk", "four_rooms")))
    p.add_argument("-o", "--output", required=True)
    p.add_argument("--truth", help="also write the true luminaires (JSON)")
    p.add_argument("--reflectance", type=float, default=0.0)
    p.add_argument("--cell", type=float, default=0.1, help="mesh size, metres")
    p.add_argument("--backend", default="auto", choices=("auto", "opencl", "numpy"))
    p.set_defaults(func=run)


def run(args):
    from invrad_wb.core.io.jsonout import write_luminaires_json
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
