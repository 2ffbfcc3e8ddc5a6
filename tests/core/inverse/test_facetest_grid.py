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


def _brute_contains(ft, q, tol=1e-9):
    """FaceTest.contains as it was: the box test of every triangle, then barycentric."""
    from invrad_wb.core.geometry.raster import barycentric_2d
    sel = np.flatnonzero(np.all((ft.lo <= q + tol) & (ft.hi >= q - tol), axis=1))
    if len(sel) == 0:
        return False
    b = barycentric_2d(ft.tri[sel], np.broadcast_to(q, (len(sel), 2)))
    return bool(np.any(np.all(b >= -tol, axis=1)))


@pytest.mark.parametrize("n_tri", [0, 2, 60, 600])
def test_contains_by_the_grid_is_the_test_of_every_triangle(n_tri):
    """One point at a time (the mid-air clamp's test) through the grid answers as the test
    of every triangle: random points, the triangles' corners, their edges' midpoints,
    points just off their boxes, a nan, and tolerances from 1e-9 to 0.05; the same as the
    batched contains_all."""
    rng = np.random.default_rng(10 + n_tri)
    if n_tri == 2:       # a plain rectangle: points on its diagonal and border
        tri = np.array([[[-5, -5], [5, -5], [5, 5]], [[-5, -5], [5, 5], [-5, 5]]], float)
    else:
        tri = rng.uniform(-5, 5, (n_tri, 1, 2)) + rng.uniform(-0.3, 0.3, (n_tri, 3, 2))
    ft = FaceTest(tri, np.zeros((4, 4), bool), (0.0, 0.0), 0.1)
    q = [rng.uniform(-6, 6, (300, 2)), np.full((1, 2), np.nan)]
    if n_tri:
        k = rng.choice(n_tri, min(n_tri, 100), replace=False)
        q += [tri[k, 0], (tri[k, 0] + tri[k, 1]) / 2, (tri[k, 1] + tri[k, 2]) / 2,
              ft.lo[k] - 1e-9, ft.hi[k] + 3e-9, np.linspace([-5, -5], [5, 5], 50)]
    q = np.concatenate(q)
    zeros = np.zeros(len(q), np.int64)
    for tol in (1e-9, 1e-6, 0.05):
        want = np.array([_brute_contains(ft, p, tol) for p in q])
        got = np.array([ft.contains(p, 0, 0, tol) for p in q])
        np.testing.assert_array_equal(got, want)
        np.testing.assert_array_equal(ft.contains_all(q, zeros, zeros, tol), want)
        assert want.any() == (n_tri > 0) and not want.all()
