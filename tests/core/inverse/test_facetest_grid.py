"""FaceTest's cell grid gives the same (point, triangle) pairs as testing every bounding box."""
import numpy as np
import pytest

from invrad_wb.core.inverse.votemaps import FaceTest


def _brute(ft, q, tol):
    near = np.all((ft.lo[None] <= (q + tol)[:, None]) & (ft.hi[None] >= (q - tol)[:, None]),
                  axis=2)
    return np.nonzero(near)


@pytest.mark.parametrize("n_tri", [0, 1, 2, 60, 2000])
def test_box_pairs_are_every_bounding_box_hit(n_tri):
    rng = np.random.default_rng(n_tri)
    if n_tri == 2:       # two big triangles (a plain rectangle) over the whole range
        tri = np.array([[[-5, -5], [5, -5], [5, 5]], [[-5, -5], [5, 5], [-5, 5]]], float)
    else:
        tri = rng.uniform(-5, 5, (n_tri, 1, 2)) + rng.uniform(-0.3, 0.3, (n_tri, 3, 2))
    ft = FaceTest(tri, np.zeros((4, 4), bool), (0.0, 0.0), 0.1)
    q = rng.uniform(-6, 6, (400, 2))
    q[0] = np.nan
    if n_tri:            # on the boxes' edges and just beyond the tolerance
        tol = 1e-9
        q = np.concatenate([q, ft.lo, ft.hi, ft.lo - tol, ft.hi + tol,
                            ft.lo - 3 * tol, ft.hi + 3 * tol])
    for tol in (1e-9, 0.05):
        want = _brute(ft, q, tol)
        got = ft._box_pairs(q, tol)
        assert np.array_equal(want[0], got[0]) and np.array_equal(want[1], got[1])
        assert len(got[0]) > 0 or n_tri == 0
