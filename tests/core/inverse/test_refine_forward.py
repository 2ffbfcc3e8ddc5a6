"""The refinement's forward model as the optimisers use it (inverse/refine.py): visibility
masks remembered per luminaire position, several luminaires evaluated at once the same as
one at a time."""
import numpy as np

from invrad_wb.core.geometry.bvh import BVH, segments_occluded_numpy
from invrad_wb.core.inverse.refine import Light, RefineProblem


def _problem():
    """A 4 x 4 m floor of receivers and a 1 m tall screen standing on it at x = 2."""
    x, y = np.meshgrid(np.linspace(0.1, 3.9, 20), np.linspace(0.1, 3.9, 20), indexing="ij")
    pts = np.c_[x.ravel(), y.ravel(), np.zeros(x.size)]
    nrm = np.tile([0.0, 0.0, 1.0], (len(pts), 1))
    screen = BVH(np.array([[[2.0, 0.0, 0.0], [2.0, 4.0, 0.0], [2.0, 0.0, 1.0]],
                           [[2.0, 4.0, 0.0], [2.0, 4.0, 1.0], [2.0, 0.0, 1.0]]]))
    calls = []

    def occluded(p, q):
        calls.append(len(p))
        return segments_occluded_numpy(screen, p, q)
    prob = RefineProblem(positions=pts, normals=nrm, target=np.ones(len(pts)), flux=1000.0,
                         area=np.ones(len(pts)), bvh=screen, occluded_fn=occluded)
    return prob, calls


def _light(x, y, z=1.2):
    return Light("free", np.array([x, y, z]), np.array([0.0, 0.0, -1.0]), 0)


def test_a_luminaire_that_has_not_moved_casts_no_new_rays():
    prob, calls = _problem()
    L = _light(1.0, 2.0)
    vis = prob.visibility(L)
    # the screen shades the whole far side of the floor (its top at 1 m hides the floor
    # up to x = 7 m from a luminaire at 1.2 m), not the near one
    far = prob.positions[:, 0] > 2.0
    assert vis[~far].all() and not vis[far].any()
    rays = prob.stats["visibility_rays"]
    assert len(calls) == 1 and rays == len(prob.positions)
    again = prob.visibility(L.copy())                 # another object, the same place
    assert again is vis and len(calls) == 1 and prob.stats["visibility_rays"] == rays
    assert prob.stats["visibility_reused"] == 1
    assert not vis.flags.writeable                    # shared: nobody may change it
    moved = prob.visibility(_light(1.0 + 1e-9, 2.0))  # moved at all: computed afresh
    assert len(calls) == 2 and np.array_equal(moved, vis)
    other = prob.visibility(_light(3.0, 2.0))
    assert len(calls) == 3 and not np.array_equal(other, vis)


def test_the_mask_memory_is_bounded():
    prob, calls = _problem()
    prob.VIS_CACHE_SIZE = 4
    for i in range(10):
        prob.visibility(_light(0.5 + 0.1 * i, 2.0))
    assert len(prob._vis_cache) == 4
    prob.visibility(_light(0.5, 2.0))                 # the oldest was dropped: recomputed
    assert len(calls) == 11


def test_many_luminaires_at_once_equal_one_at_a_time():
    prob, _ = _problem()
    lights = [_light(1.0, 2.0), _light(3.0, 1.0, 2.0), _light(2.5, 3.5, 0.8)]
    lights[1].flux_scale = 1.7
    vis = [prob.visibility(L) for L in lights]
    E, dE = prob.lights_of(lights, vis, with_grad=True)
    assert E.shape == (3, len(prob.positions)) and dE.shape == E.shape + (3,)
    for i, L in enumerate(lights):
        e, de = prob.light_of(L, vis[i], with_grad=True)
        np.testing.assert_array_equal(e, E[i])
        np.testing.assert_array_equal(de, dE[i])
        # lambertian: F cos_l cos_s / (pi r^2), 0 where the screen is between
        d = prob.positions - L.position
        r2 = (d * d).sum(1)
        ref = (L.flux_scale * 1000.0 * np.maximum(d @ L.normal, 0) * np.maximum(-d[:, 2], 0)
               / (np.pi * r2 * r2)) * vis[i]
        np.testing.assert_allclose(E[i], ref, rtol=1e-12, atol=1e-12)
