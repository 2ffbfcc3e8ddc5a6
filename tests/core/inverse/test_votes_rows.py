"""The exact-vote kernel's row test (``no_vote_in_row`` in ``kernels/votes_exact.cl``)
skips only pairs that give no vote: the votes are those of the kernel without it, bit for
bit, on maps of every orientation, with points on every surface (some grazing a map's row),
illuminances from far below to far above what a luminaire can give, occluders and shade
points, and fine and coarse pixels."""
import numpy as np
import pytest

from invrad_wb.core.geometry.bvh import BVH
from invrad_wb.core.inverse import votes
from invrad_wb.core.inverse.locate import occluding_faces
from invrad_wb.core.inverse.sampling import voting_points
from invrad_wb.core.inverse.votemaps import build_canvas
from invrad_wb.core.synthetic import generate as g


def _both(canvas, pts, W, lux, flux, monkeypatch, **kw):
    with_test = votes.cast_exact_opencl(canvas, pts, W, lux, flux, **kw)
    monkeypatch.setattr(votes, "ROW_TEST", False)
    without = votes.cast_exact_opencl(canvas, pts, W, lux, flux, **kw)
    monkeypatch.setattr(votes, "ROW_TEST", True)
    return with_test, without


@pytest.mark.opencl
@pytest.mark.parametrize("pixel", [0.05, 0.3])
def test_row_test_leaves_every_vote_as_it_was(monkeypatch, pixel):
    s = g.pillar_room((4, 3, 2.6), pillar=((1.9, 1.3), (2.2, 1.6)), cell=0.25)
    s = s.with_vertex_lux(np.ones(len(s.vertices)))      # targets everywhere
    pts = voting_points(s, density=30)
    canvas = build_canvas(s, 0, pixel=pixel, dummy_spacing=0.5)
    rng = np.random.default_rng(7)
    # 1e-3 .. 1e4 lx for 1000 lm: most pairs far from any contour, some on one
    lux = 10.0 ** rng.uniform(-3, 4, len(pts))
    lux[rng.random(len(pts)) < 0.01] = 0.0                    # shade points
    W = votes.vote_weights(canvas, pts, lux, "illumination")
    assert (W > 0).sum() > 10_000
    a, b = _both(canvas, pts, W, lux, 1000.0, monkeypatch)
    assert np.count_nonzero(a) > 0.05 * a.size
    assert np.array_equal(a, b)
    occ = BVH(s.triangles[occluding_faces(s)])
    shade = pts.subset(lux == 0)
    a, b = _both(canvas, pts, W, lux, 1000.0, monkeypatch, bvh=occ, shade=shade,
                 shade_limit_lux=300.0)
    assert np.count_nonzero(a) > 0 and np.array_equal(a, b)
