"""``invrad info SCENE``: rooms, planes and targets of a scene."""
import numpy as np

from invrad_wb.cli.common import read_scene_arg, scene_args


def add_parser(sub):
    p = sub.add_parser("info", help="describe a scene")
    scene_args(p)
    p.set_defaults(func=run)


def run(args):
    scene = read_scene_arg(args)
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
