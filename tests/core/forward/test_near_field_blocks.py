"""The radiosity's near-field correction of patch light, computed for blocks of luminaires
at once, equals the one-luminaire-at-a-time reference (the numpy formula it replaced):
point luminaires (visibility from one occlusion test per block), disks and intensity
distributions (direct light one by one), with and without shadows, across block edges."""
import numpy as np
import pytest

from invrad_wb.core.forward import radiosity as R
from invrad_wb.core.forward.direct import direct_illuminance
from invrad_wb.core.geometry.bvh import BVH
from invrad_wb.core.model.luminaires import Luminaire
from invrad_wb.core.model.photometry import Photometry
from invrad_wb.core.synthetic import generate


def _reference(ps, p, n, lums, bvh, occlusion):
    out = np.zeros(ps.n)
    for L in lums:
        c = np.asarray(L.position, dtype=np.float64)
        m = np.asarray(L.normal, dtype=np.float64)
        d2c = np.einsum("ij,ij->i", ps.centroid - c, ps.centroid - c)
        pj = np.flatnonzero((d2c < ps.blend_r2) & ps.emits)
        if not len(pj):
            continue
        d = p[pj] - c
        r2 = np.maximum(np.einsum("ij,ij->i", d, d), 1e-24)
        lam = L.flux_lm * np.maximum(d @ m, 0.0) * np.maximum(
            -np.einsum("ij,ij->i", d, n[pj]), 0.0) / (np.pi * r2 * r2)
        pj, lam = pj[lam > 0], lam[lam > 0]
        if not len(pj):
            continue
        real = direct_illuminance(p[pj], n[pj], [L], bvh=bvh, occlusion=occlusion,
                                  backend="numpy")
        F = R._form_factors_numpy(c[None], m[None], np.array([-1]), ps, None, None)[0]
        out[pj] += (real / lam) * (L.flux_lm * F[pj] / ps.area[pj] - lam)
    return out


@pytest.mark.parametrize("occlusion", [True, False])
def test_blocks_equal_one_luminaire_at_a_time(monkeypatch, occlusion):
    scene = generate.with_reflectances(generate.box_room(size=(5.0, 4.0, 2.5), cell=0.3))
    model = R.RadiosityModel(scene, backend="numpy")
    rng = np.random.default_rng(7)
    lums = []
    tilted = Photometry(np.tile(np.maximum(np.cos(np.radians(np.arange(181) - 20)), 0.0),
                                (361, 1)), name="tilted")
    for i in range(23):
        pos = [rng.uniform(0.05, 4.95), rng.uniform(0.05, 3.95), rng.uniform(2.2, 2.45)]
        lum = Luminaire(pos, [0, 0, -1], float(rng.uniform(100, 3000)))
        if i % 5 == 1:
            lum.radius_m = 0.1
        if i % 7 == 2:
            lum.photometry = tilted
        lums.append(lum)
    lums.append(Luminaire([0.1, 2.0, 1.5], [1, 0, 0], 800.0))       # a wall light
    slab = np.array([[[1.5, 1.0, 2.0], [3.5, 1.0, 2.0], [3.5, 3.0, 2.0]],
                     [[1.5, 1.0, 2.0], [3.5, 3.0, 2.0], [1.5, 3.0, 2.0]]])
    bvh = BVH(np.concatenate([scene.triangles, slab]))
    pts, nrm = model.patch_points()
    room = model.rooms[0]
    p, n = pts[room.sl] + nrm[room.sl] * 1e-4, nrm[room.sl]
    want = _reference(room.patches, p, n, lums, bvh, occlusion)
    assert np.abs(want).max() > 1.0           # the correction matters in this room
    from invrad_wb.core.forward import nearfield as NF
    monkeypatch.setattr(NF, "NEAR_FIELD_BLOCK", 5)                    # several blocks
    # the distributions' ratio at the representative point, as the reference takes it
    # (its average over the patch: test_near_wall_light.py)
    monkeypatch.setattr(NF, "NEAR_RATIO_RADII", -1e9)
    got = NF._near_field_correction(room.patches, p, n, lums, bvh, occlusion)
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-9 * np.abs(want).max())
