"""The vote maps' image filters in numpy (inverse/peaks.py) give scipy.ndimage's numbers
bit for bit (they replaced it so that a command-line run need not import it), and the
peak search does not import scipy.ndimage."""
import subprocess
import sys

import numpy as np
import pytest

from invrad_wb.core.inverse import peaks

ndimage = pytest.importorskip("scipy.ndimage")


def _maps(seed=0):
    """Vote-map-like images: smooth peaks, masked holes, zeros, odd shapes, tiny ones."""
    rng = np.random.default_rng(seed)
    out = []
    for shape in ((1, 1), (1, 7), (5, 1), (3, 4), (17, 23), (64, 41), (120, 97)):
        a = rng.gamma(0.5, 40.0, shape)
        a[rng.random(shape) < 0.3] = 0.0
        out.append(a)
        i, j = np.meshgrid(np.arange(shape[0]), np.arange(shape[1]), indexing="ij")
        out.append(1e3 * np.exp(-((i - shape[0] / 3) ** 2 + (j - shape[1] / 2) ** 2) / 20.0))
    return out


@pytest.mark.parametrize("sigma", [0.5, 1.0, 1.3, 2.0, 3.7])
def test_gaussian_blur_is_scipys_bit_for_bit(sigma):
    r = max(1, int(np.ceil(3 * sigma)))
    for a in _maps():
        for img in (a, (a > 0).astype(np.float64)):
            want = ndimage.gaussian_filter(img, sigma, mode="constant", cval=0.0, radius=r)
            got = peaks.gaussian_blur(img, sigma, r)
            assert got.shape == want.shape and got.dtype == want.dtype
            assert np.array_equal(got.view(np.int64), want.view(np.int64))


@pytest.mark.parametrize("r", [1, 2, 3, 6])
def test_max_filter_and_erosion_are_scipys(r):
    for k, a in enumerate(_maps(1)):
        want = ndimage.maximum_filter(a, footprint=peaks._disk(r), mode="constant",
                                      cval=-np.inf)
        assert np.array_equal(peaks._max_filter(a, r), want)
        mask = a > np.median(a)
        want = ndimage.binary_erosion(mask, structure=np.ones((2 * r + 1,) * 2, bool),
                                      border_value=0)
        got = peaks._erode(mask, r)
        assert got.dtype == bool and np.array_equal(got, want)


def test_max_filter_with_nan_is_scipys():
    a = _maps(2)[9].copy()
    a[3, 4] = np.nan
    want = ndimage.maximum_filter(a, footprint=peaks._disk(2), mode="constant",
                                  cval=-np.inf)
    assert np.array_equal(peaks._max_filter(a, 2), want, equal_nan=True)


def test_masked_blur_keeps_light_inside_the_mask():
    """The normalised blur: a uniform value stays uniform up to the mask's border and
    nothing leaks outside it."""
    mask = np.zeros((20, 30), bool)
    mask[4:16, 5:25] = True
    out = peaks._masked_blur(np.where(mask, 7.0, 123.0), mask, 1.5)
    assert np.allclose(out[mask], 7.0, rtol=1e-12)
    assert np.all(out[~mask] == 0.0)


def test_peak_search_does_not_import_scipy_ndimage():
    code = ("import sys; import invrad_wb.core.inverse.peaks as p, numpy as np;"
            "from invrad_wb.core.inverse.locate import locate;"
            "m = np.zeros((30, 30)); m[10, 12] = 5.0; p._masked_blur(m, m >= 0, 1.0);"
            "p._max_filter(m, 3); p._erode(m > -1, 2);"
            "print('scipy.ndimage' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == "False"
