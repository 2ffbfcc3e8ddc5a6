"""Every OpenCL kernel against its numpy twin, from the one registry of pairs.

Each registered pair must have a case below (a new kernel without one fails
``test_every_pair_has_a_case``); tolerances state the physics, so they hold on any device:
float32 arithmetic moves a value by a few 1e-4 relative, a grazing ray or a sample on a
pixel border may flip, but totals stay.
"""
import os
import subprocess
import sys

import numpy as np
import pytest

from invrad_wb.core.accel.registry import pairs
from invrad_wb.core.geometry.bvh import BVH
from invrad_wb.core.model.luminaires import Luminaire
from invrad_wb.core.synthetic import generate as g


def _direct():
    s = g.pillar_room(cell=0.2)
    lums = [Luminaire([1.5, 2.0, 2.99], [0, 0, -1], 3000, 0.25),
            Luminaire([0.01, 1.0, 2.0], [1, 0, 0], 1500)]
    args = (s.vertices, s.vertex_normals, lums)
    kw = {"bvh": BVH(s.triangles)}

    def same(a, b):
        assert (a == 0).sum() > 100                            # shadows exist
        assert np.sum(np.abs(a - b) > 1e-3 * a.max() + 1e-3) <= 3   # grazing rays
    return args, kw, same


def _occlusion():
    s = g.pillar_room(cell=0.3)
    rng = np.random.default_rng(7)
    lo, hi = np.array([0.01, 0.01, 0.01]), np.array([5.99, 3.99, 2.99])
    p, q = rng.uniform(lo, hi, (3000, 3)), rng.uniform(lo, hi, (3000, 3))

    def same(a, b):
        assert a.sum() > 100
        assert np.sum(a != b) <= 3                            # grazing rays at float32
    return (BVH(s.triangles), p, q), {}, same


def _form_factors():
    from invrad_wb.core.forward.radiosity import RadiosityModel
    m = RadiosityModel(g.l_room(), backend="numpy", patch_size=0.5)
    room = m.rooms[0]
    pts, nrm = m.vertex_receivers()
    sel = np.flatnonzero(m.patch_room[np.maximum(m.vertex_patch, 0)] == room.room)[::7]
    local = m.vertex_patch[sel] - room.sl.start
    args = (pts[sel], nrm[sel], room.patches.plane[local], room.patches, local, room.vis)

    def same(a, b):
        assert a.sum() > 1.0
        np.testing.assert_allclose(b, a, rtol=2e-3, atol=2e-5)
    return args, {}, same


def _votes(model):
    from invrad_wb.core.forward.render import render
    from invrad_wb.core.inverse.locate import occluding_faces
    from invrad_wb.core.inverse.sampling import voting_points
    from invrad_wb.core.inverse.votemaps import build_canvas
    from invrad_wb.core.inverse.votes import vote_weights
    s = g.pillar_room((4, 3, 2.6), pillar=((1.9, 1.3), (2.2, 1.6)), cell=0.25)
    lums = [Luminaire([1.0, 1.5, 2.6], [0, 0, -1], 2000)]
    s = s.with_vertex_lux(render(s, lums, interreflection=False, backend="numpy"))
    pts = voting_points(s, density=30)
    canvas = build_canvas(s, 0, pixel=0.15, dummy_spacing=0.3)
    W = vote_weights(canvas, pts, pts.lux, "illumination")
    kw = {"bvh": BVH(s.triangles[occluding_faces(s)])}

    def same(a, b):
        assert a.sum() > 10
        # the same votes, except samples within float32 rounding of a pixel border
        assert abs(a.sum() - b.sum()) < 2e-3 * a.sum()
        assert np.mean(np.abs(a - b) > 2e-3 * a.max() + 0.05) < 2e-3
        assert np.argmax(a) == np.argmax(b) or b[np.argmax(a)] >= 0.99 * b.max()
    return (canvas, pts, W, pts.lux, 2000.0), kw, same


CASES = {"direct_illuminance": _direct, "segments_occluded": _occlusion,
         "form_factors": _form_factors, "votes_exact": lambda: _votes("exact"),
         "votes_ellipse": lambda: _votes("ellipse")}


def test_every_pair_has_a_case():
    assert set(pairs()) == set(CASES)


@pytest.mark.opencl
@pytest.mark.parametrize("name", sorted(CASES))
def test_opencl_matches_its_numpy_twin(name):
    pair = pairs()[name]
    args, kw, same = CASES[name]()
    same(pair.numpy(*args, **kw), pair.opencl(*args, **kw))


def test_the_switch_turns_opencl_off():
    code = ("import warnings; warnings.simplefilter('ignore');"
            "from invrad_wb.core.accel import clenv;"
            "from invrad_wb.core.accel.registry import implementation, pairs;"
            "print(clenv.opencl_available(), clenv.check_backend('auto'),"
            " implementation('direct_illuminance', 'auto') is pairs()"
            "['direct_illuminance'].numpy)")
    env = dict(os.environ, INVRAD_OPENCL="0")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                         text=True, timeout=120, cwd=os.path.dirname(os.path.dirname(
                             os.path.abspath(__file__))))
    assert out.stdout.split() == ["False", "numpy", "True"], out.stderr
