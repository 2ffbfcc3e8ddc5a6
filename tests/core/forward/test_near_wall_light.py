"""A luminaire with an intensity distribution near a wall lights the wall's patches far
from evenly (grazing at the top, steeply below): the patches' direct light takes the
distribution's ratio to a Lambertian emitter averaged over each patch near it, not at its
representative point (which put 15 % too little light on the wall of this box)."""
import numpy as np
import pytest

from invrad_wb.core.forward import radiosity as R
from invrad_wb.core.forward.direct import direct_illuminance
from invrad_wb.core.model.luminaires import Luminaire
from invrad_wb.core.model.photometry import Photometry
from invrad_wb.core.synthetic import generate


def _downlight(n=4.0):
    """I ~ cos^n(gamma): a narrow downlight (the bench catalogue's DL-1200N)."""
    g = np.radians(np.arange(181))
    return Photometry(np.tile(np.maximum(np.cos(g), 0.0) ** n, (361, 1)), name="cos4")


def _wall_flux_reference(lum, size, h=0.01):
    """lm on the wall x = 0 of the box: direct light on a 1 cm grid."""
    y, z = np.arange(h / 2, size[1], h), np.arange(h / 2, size[2], h)
    Y, Z = np.meshgrid(y, z)
    P = np.c_[np.full(Y.size, 1e-4), Y.ravel(), Z.ravel()]
    N = np.tile([1.0, 0.0, 0.0], (len(P), 1))
    return float(direct_illuminance(P, N, [lum], backend="numpy").sum() * h * h)


@pytest.mark.parametrize("patch", [0.3, 0.2])
def test_patch_light_of_a_downlight_next_to_a_wall_adds_up(patch):
    size = (4.0, 3.0, 2.6)
    scene = generate.with_reflectances(generate.box_room(size=size, cell=0.15))
    model = R.RadiosityModel(scene, backend="numpy", patch_size=patch)
    lum = Luminaire([0.22, 1.5, 2.6], [0, 0, -1], 1200.0, photometry=_downlight())
    flux = model.patch_direct([lum], None, False, "numpy") * model.patch_area
    wall = (np.abs(model.patch_normal[:, 0] - 1.0) < 1e-9) & (model.patch_centroid[:, 0]
                                                              < 1e-6)
    ref = _wall_flux_reference(lum, size)
    assert flux[wall].sum() == pytest.approx(ref, rel=0.03)
    # every lumen lands on the box (the point ratio lost 6 %)
    assert flux.sum() == pytest.approx(1200.0, rel=0.015)
    assert np.all(flux >= 0.0)


def test_a_lambertian_distribution_matches_the_lambertian_point():
    """The average ratio of a cosine distribution to the Lambertian point is 1: its patch
    light is the point emitter's (whose patch means are exact)."""
    scene = generate.with_reflectances(generate.box_room(size=(4.0, 3.0, 2.6), cell=0.3))
    model = R.RadiosityModel(scene, backend="numpy")
    at = [0.22, 1.5, 2.6]
    lam = Luminaire(at, [0, 0, -1], 1200.0, photometry=Photometry.lambertian())
    point = Luminaire(at, [0, 0, -1], 1200.0)
    a = model.patch_direct([lam], None, False, "numpy")
    b = model.patch_direct([point], None, False, "numpy")
    np.testing.assert_allclose(a, b, rtol=2e-3, atol=1e-6 * b.max())
