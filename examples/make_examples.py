#!/usr/bin/env python3
"""Regenerate the bundled examples (known-answer scenes) in examples/.

office.ply: a 6 x 4 x 3 m office (floor 0.3, walls 0.6, ceiling 0.8 reflectance) lit by four
3000 lm ceiling luminaires, rendered with interreflection; the targets are what those
luminaires give, so ``locate --flux 3000`` should find them (examples/office_true.json).
"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from invrad_wb.core.synthetic import generate as g  # noqa: E402
from invrad_wb.core.model.luminaires import Luminaire  # noqa: E402
from invrad_wb.core.io.jsonout import write_luminaires_json  # noqa: E402
from invrad_wb.core.forward.render import render  # noqa: E402
from invrad_wb.core.io.sceneio import write_scene  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))


def office():
    mb = g.MeshBuilder(cell=0.1)
    g.add_prism_room(mb, [(0, 0), (6, 0), (6, 4), (0, 4)], [(0, 0, 6, 4)], height=3.0,
                     reflectance=0.6, floor_reflectance=0.3, ceiling_reflectance=0.8)
    scene = mb.scene()
    lums = [Luminaire([x, y, 3.0], [0, 0, -1], 3000.0) for x in (1.6, 4.4) for y in (1.1, 2.9)]
    lux = render(scene, lums, interreflection=True)
    write_scene(os.path.join(HERE, "office.ply"), scene, lux=lux)
    write_luminaires_json(os.path.join(HERE, "office_true.json"), lums,
                          note="the luminaires that produced office.ply's targets")
    print(f"office.ply: {len(scene.faces)} faces, {lux.min():.0f}-{lux.max():.0f} lx")


if __name__ == "__main__":
    office()
