"""Forward solver, direct part: CIE 171 style analytic cases, occlusion, backends agree."""
import numpy as np
import pytest

from invrad_wb.core.synthetic import generate as g
from invrad_wb.core.geometry.bvh import BVH, segments_occluded_bruteforce, segments_occluded_numpy
from invrad_wb.core.forward.direct import direct_illuminance_numpy, direct_illuminance_opencl
from invrad_wb.core.model.luminaires import Luminaire, disk_quadrature, load_luminaires
from invrad_wb.core.forward.render import render
from invrad_wb.errors import LuminaireError

BACKENDS = [direct_illuminance_numpy, pytest.param(direct_illuminance_opencl,
                                                   marks=pytest.mark.opencl)]


@pytest.mark.parametrize("fn", BACKENDS)
def test_cie171_point_source_1000cd(fn):
    # lambertian point source with I0 = 1000 cd (flux = pi * 1000 lm), 3 m above a floor
    lum = [Luminaire([0, 0, 3], [0, 0, -1], 1000 * np.pi)]
    pts = np.array([[0, 0, 0], [1.5, 1.5, 0], [-1.5, 1.5, 0]], float)
    nrm = np.tile([0, 0, 1.0], (3, 1))
    e = fn(pts, nrm, lum)
    assert e[0] == pytest.approx(111.11, rel=0.01)
    assert e[1] == pytest.approx(49.38, rel=0.01)
    assert e[2] == pytest.approx(49.38, rel=0.01)


@pytest.mark.parametrize("fn", BACKENDS)
def test_disk_on_axis_matches_closed_form(fn):
    # lambertian disk, parallel coaxial receiver: E = F / (pi (h^2 + R^2))
    F, R = 2000.0, 0.3
    for h in (0.5, 1.0, 3.0):
        e = fn(np.array([[0, 0, 0.0]]), np.array([[0, 0, 1.0]]),
               [Luminaire([0, 0, h], [0, 0, -1], F, R)])
        assert e[0] == pytest.approx(F / (np.pi * (h * h + R * R)), rel=0.01)


def test_disk_quadrature_is_normalised_and_exact_for_r2():
    p, w = disk_quadrature()
    assert w.sum() == pytest.approx(1.0)
    r2 = (p ** 2).sum(1)
    assert np.sum(w * r2) == pytest.approx(0.5)        # mean of r^2 over the unit disk
    assert np.sum(w * r2 ** 2) == pytest.approx(1 / 3)


@pytest.mark.parametrize("fn", BACKENDS)
def test_back_facing_and_behind_receive_nothing(fn):
    lum = [Luminaire([0, 0, 3], [0, 0, -1], 1000.0)]
    e = fn(np.array([[0, 0, 0], [0, 0, 5], [1, 0, 0]], float),
           np.array([[0, 0, -1], [0, 0, 1], [0, 0, 1]], float), lum)
    assert e[0] == 0 and e[1] == 0 and e[2] > 0


def _random_segments(rng, n, lo, hi):
    return rng.uniform(lo, hi, (n, 3)), rng.uniform(lo, hi, (n, 3))


def test_bvh_numpy_matches_bruteforce(rng):
    s = g.pillar_room(cell=0.3)
    bvh = BVH(s.triangles)
    p, q = _random_segments(rng, 400, [0, 0, 0], [6, 4, 3])
    ref = segments_occluded_bruteforce(s.triangles, p, q)
    assert ref.sum() > 20  # the test exercises real hits
    assert np.array_equal(segments_occluded_numpy(bvh, p, q), ref)


@pytest.mark.opencl
def test_bvh_opencl_matches_bruteforce(rng):
    from invrad_wb.core.forward.occlusion import segments_occluded_opencl
    s = g.pillar_room(cell=0.3)
    bvh = BVH(s.triangles)
    p, q = _random_segments(rng, 2000, [0, 0, 0], [6, 4, 3])
    ref = segments_occluded_bruteforce(s.triangles, p, q)
    got = segments_occluded_opencl(bvh, p, q)
    # float32 may differ on rays grazing an edge; allow a handful
    assert np.sum(got != ref) <= 2
    assert ref.sum() > 50


@pytest.mark.opencl
def test_a_bvh_is_uploaded_once_per_context_and_pickles_without_its_buffers():
    import pickle
    from invrad_wb.core.accel.device import get_env
    from invrad_wb.core.forward.occlusion import bvh_buffers
    env = get_env()
    bvh = BVH(g.pillar_room(cell=0.6).triangles)
    bufs = bvh_buffers(env, bvh)
    assert len(bufs) == 4 and bvh_buffers(env, bvh) is bufs
    assert bvh_buffers(env) is bvh_buffers(env, None)            # the empty BVH's, once
    clone = pickle.loads(pickle.dumps(bvh))                        # as a worker gets it
    assert bvh_buffers(env, clone) is not bufs


def test_pillar_casts_a_shadow():
    s = g.pillar_room((6, 4, 3), pillar=((2.8, 1.8), (3.2, 2.2)), cell=0.2)
    lum = [Luminaire([1.0, 2.0, 3.0], [0, 0, -1], 3000.0)]
    pts = np.array([[4.0, 2.0, 0.0], [4.0, 0.5, 0.0]])   # behind the pillar / in the open
    nrm = np.tile([0, 0, 1.0], (2, 1))
    bvh = BVH(s.triangles)
    e = direct_illuminance_numpy(pts, nrm, lum, bvh=bvh)
    e0 = direct_illuminance_numpy(pts, nrm, lum, bvh=None, occlusion=False)
    assert e[0] == 0.0 and e0[0] > 10
    assert e[1] == pytest.approx(e0[1])


@pytest.mark.opencl
def test_direct_opencl_matches_numpy_with_occlusion():
    s = g.pillar_room(cell=0.2)
    lums = [Luminaire([1.5, 2.0, 2.99], [0, 0, -1], 3000, 0.25),
            Luminaire([0.01, 1.0, 2.0], [1, 0, 0], 1500)]
    bvh = BVH(s.triangles)
    a = direct_illuminance_numpy(s.vertices, s.vertex_normals, lums, bvh=bvh)
    b = direct_illuminance_opencl(s.vertices, s.vertex_normals, lums, bvh=bvh)
    assert (a == 0).sum() > 100  # shadows exist
    mismatch = np.abs(a - b) > 1e-3 * a.max() + 1e-3
    assert mismatch.sum() <= 3  # grazing rays at float32


def test_render_direct_matches_direct_module():
    s = g.box_room((4, 4, 3), cell=0.5, reflectance=0.0)
    lums = [Luminaire([2, 2, 3], [0, 0, -1], 3000)]
    tot, d, ind = render(s, lums, interreflection=False, backend="numpy", return_parts=True)
    assert np.all(ind == 0) and np.allclose(tot, d)
    floor_centre = np.argmin(np.linalg.norm(s.vertices - [2, 2, 0], axis=1))
    assert tot[floor_centre] == pytest.approx(3000 / (np.pi * 9), rel=1e-6)


def test_luminaire_json_errors(tmp_path):
    p = tmp_path / "l.json"
    p.write_text('{"luminaires": [{"position": [0, 0, 3], "flux_lm": -5}]}')
    with pytest.raises(LuminaireError, match=r"l.json: luminaires\[0\].flux_lm is -5"):
        load_luminaires(str(p))
    p.write_text('{"luminaires": [{"position": [0, "a", 3], "flux_lm": 5}]}')
    with pytest.raises(LuminaireError, match="position must be"):
        load_luminaires(str(p))
    p.write_text('{"luminaires": [')
    with pytest.raises(LuminaireError, match="not valid JSON"):
        load_luminaires(str(p))


@pytest.mark.opencl
def test_chunked_direct_launches_match(monkeypatch):
    from invrad_wb import constants as C
    s = g.box_room((4, 3, 2.5), cell=0.25)
    lums = [Luminaire([2, 1.5, 2.5], [0, 0, -1], 2000)]
    a = direct_illuminance_opencl(s.vertices, s.vertex_normals, lums, bvh=BVH(s.triangles))
    monkeypatch.setattr(C, "CL_CHUNK_RECEIVERS", 100)
    b = direct_illuminance_opencl(s.vertices, s.vertex_normals, lums, bvh=BVH(s.triangles))
    assert np.array_equal(a, b)
