"""A large render (luminaires x points) is announced with its size before it starts."""
import numpy as np

from invrad_wb.core.forward import render as R
from invrad_wb.core.model.luminaires import Luminaire
from invrad_wb.core.synthetic import generate


def _lums(k):
    xs = np.linspace(0.2, 3.8, k)
    return [Luminaire([x, 1.5, 2.45], [0, 0, -1], 10.0) for x in xs]


def test_work_grows_as_luminaires_times_points_and_large_renders_are_announced():
    scene = generate.with_reflectances(generate.box_room((4, 3, 2.5), cell=0.25))
    rays, points = R.render_work(scene, _lums(10), interreflection=False)
    assert points == len(scene.vertices) and rays == 10 * points
    rays_ir, points_ir = R.render_work(scene, _lums(10))
    assert points_ir > points and rays_ir == 10 * points_ir     # + the patches' samples
    disk = _lums(1)[0]
    disk.radius_m = 0.2
    assert R.render_work(scene, [disk], False)[0] > points      # a disk: several samples
    assert R.work_note(scene, _lums(10)) is None
    many = int(R.LARGE_RENDER_RAYS / points_ir) + 1
    note = R.work_note(scene, _lums(many))
    assert note.startswith(f"{many} luminaire(s) x {points_ir} points") and "\n" not in note
