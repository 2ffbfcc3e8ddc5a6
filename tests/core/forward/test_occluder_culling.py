"""Shadow rays only where an occluder is possible: the culled BVH (triangles whose plane
separates some luminaire from some point) gives the same light as the whole scene's BVH,
in rooms with and without occluders, with luminaires inside and outside; and the
photometric light in blocks equals a luminaire-by-luminaire reference."""
import numpy as np
import pytest

from invrad_wb.core.forward import direct as D
from invrad_wb.core.geometry.bvh import BVH, cull_occluders, occluder_mask
from invrad_wb.core.model.aiming import photometric_frame
from invrad_wb.core.model.luminaires import Luminaire
from invrad_wb.core.model.photometry import Photometry
from invrad_wb.core.synthetic import generate as g


def _lums(rng, n, lo, hi, photometry=None):
    return [Luminaire(rng.uniform(lo, hi), [0, 0, -1], float(rng.uniform(200, 2000)),
                      photometry=photometry) for _ in range(n)]


def test_a_convex_room_lit_from_inside_needs_no_shadow_ray():
    s = g.box_room((5.0, 4.0, 3.0), cell=0.5)
    lums = _lums(np.random.default_rng(1), 30, [0.1, 0.1, 0.5], [4.9, 3.9, 2.95])
    src = np.array([lum.position for lum in lums])
    assert not occluder_mask(s.triangles, src, s.vertices).any()
    assert cull_occluders(BVH(s.triangles), src, s.vertices) is None


def test_the_pillar_is_kept_and_the_walls_dropped():
    s = g.pillar_room(cell=0.5)
    src = np.array([[1.0, 1.0, 2.9], [5.0, 3.0, 2.9]])
    mask = occluder_mask(s.triangles, src, s.vertices)
    cent = s.triangles.mean(axis=1)
    pillar = ((cent[:, 0] > 2.79) & (cent[:, 0] < 3.21) & (cent[:, 1] > 1.79)
              & (cent[:, 1] < 2.21) & (cent[:, 2] > 0.01) & (cent[:, 2] < 2.99))
    assert mask[pillar].all() and mask.sum() == pillar.sum()


SCENES = {
    "pillar": (lambda: g.pillar_room(cell=0.4), [0.1, 0.1, 0.5], [5.9, 3.9, 2.9]),
    "L": (lambda: g.l_room(cell=0.4), [0.1, 0.1, 0.5], [5.9, 4.9, 2.9]),
    # luminaires outside the box (behind its walls and above its ceiling): all shadowed
    "outside": (lambda: g.box_room((3.0, 3.0, 2.5), cell=0.4), [-2.0, -2.0, 0.5],
                [5.0, 5.0, 4.0]),
}


@pytest.mark.parametrize("name", sorted(SCENES))
@pytest.mark.parametrize("photometric", [False, True])
def test_culled_shadows_equal_the_whole_scene(name, photometric):
    make, lo, hi = SCENES[name]
    s = make()
    phot = Photometry(np.tile(np.maximum(np.cos(np.radians(np.arange(181.0))), 0.0) ** 2,
                              (361, 1)), name="cos2") if photometric else None
    lums = _lums(np.random.default_rng(3), 12, lo, hi, phot)
    bvh = BVH(s.triangles)
    got = D.direct_illuminance(s.vertices, s.vertex_normals, lums, bvh=bvh, backend="numpy")
    want = D.direct_illuminance_numpy(s.vertices, s.vertex_normals, lums, bvh=bvh)
    free = D.direct_illuminance_numpy(s.vertices, s.vertex_normals, lums, occlusion=False)
    assert np.abs(free - want).max() > 1.0          # the scene does cast shadows
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-9)


def _photometric_reference(points, normals, lums, bvh):
    from invrad_wb.core.geometry.bvh import segments_occluded_numpy
    out = np.zeros(len(points))
    for lum in lums:
        u, v = photometric_frame(lum.normal, lum.c0)
        for i, (p, m) in enumerate(zip(points, normals)):
            r = p - lum.position
            r2 = float(r @ r)
            d = r / np.sqrt(r2)
            cs = -float(m @ d)
            if cs <= 0 or r2 <= 1e-12:
                continue
            e = lum.flux_lm * float(lum.photometry.intensity_per_lm(
                np.array([d @ u, d @ v, d @ lum.normal]))) * cs / r2
            if e > 0 and bvh is not None and segments_occluded_numpy(
                    bvh, lum.position[None], p[None])[0]:
                e = 0.0
            out[i] += e
    return out


def test_photometric_blocks_equal_one_pair_at_a_time(monkeypatch):
    s = g.pillar_room(cell=0.6)
    rng = np.random.default_rng(5)
    narrow = Photometry(np.tile(np.where(np.arange(181.0) < 30, 1.0, 0.0), (361, 1)),
                        name="narrow")
    asym = Photometry(np.outer(1.0 + np.cos(np.radians(np.arange(361.0))),
                               np.maximum(np.cos(np.radians(np.arange(181.0))), 0.0)),
                      name="asymmetric")
    lums = _lums(rng, 5, [0.2, 0.2, 2.0], [5.8, 3.8, 2.9], narrow)
    lums += _lums(rng, 4, [0.2, 0.2, 2.0], [5.8, 3.8, 2.9], asym)
    lums.append(Luminaire([0.3, 2.0, 1.5], [1, 0, -0.3], 900.0, photometry=asym,
                          c0=[0, 1, 0]))                                   # aimed
    monkeypatch.setattr(D, "PHOTOMETRIC_BLOCK_PAIRS", 3 * len(s.vertices))  # several blocks
    monkeypatch.setattr(D, "SHADOW_BATCH_PAIRS", 500)  # shadow rays of several blocks at once
    bvh = BVH(s.triangles)
    want = _photometric_reference(s.vertices, s.vertex_normals, lums, bvh)
    got = D.photometric_numpy(s.vertices, s.vertex_normals, lums, bvh)
    assert want.max() > 10.0 and (want == 0).any()     # lit, with shadows and dark cones
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-9)
