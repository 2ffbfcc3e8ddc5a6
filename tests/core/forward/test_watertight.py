"""Shadow rays are watertight: a ray through an edge or a vertex that triangles of a closed
mesh share never passes, in the float32 kernel (kernels/bvh.h) as in its float64 numpy twin
(Moller-Trumbore, used before, let such rays through both triangles)."""
import numpy as np
import pytest

from invrad_wb.core.geometry.bvh import BVH, segments_occluded_bruteforce, segments_occluded_numpy
from invrad_wb.core.model.luminaires import Luminaire
from invrad_wb.core.synthetic import generate as g


def _through_edges_and_vertices(scene, centre):
    """Segments from ``centre`` (inside) through every mesh vertex and edge midpoint of the
    closed room ``scene`` to twice as far (outside)."""
    tri = scene.triangles
    edges = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    aim = np.concatenate([scene.vertices, edges.mean(axis=1)])
    aim = np.unique(aim, axis=0)
    p = np.broadcast_to(centre, aim.shape)
    return p, centre + 2.0 * (aim - centre)


def _occluded_opencl():
    from invrad_wb.core.accel.clenv import opencl_available
    if not opencl_available():
        pytest.skip("no OpenCL device")
    from invrad_wb.core.forward.occlusion import segments_occluded_opencl
    return segments_occluded_opencl


@pytest.fixture(scope="module")
def box():
    scene = g.box_room((1.3, 0.9, 0.7), cell=0.1)
    # an off-grid centre: the rays cross the walls at shared edges and vertices only
    return scene, BVH(scene.triangles), np.array([0.6137, 0.3821, 0.2904])


def test_no_ray_through_a_shared_edge_or_vertex_leaves_the_box_numpy(box):
    scene, bvh, c = box
    p, q = _through_edges_and_vertices(scene, c)
    assert len(p) > 1500
    assert segments_occluded_numpy(bvh, p, q).all()
    # the brute-force reference uses the same test
    assert segments_occluded_bruteforce(scene.triangles, p[::25], q[::25]).all()


@pytest.mark.opencl
def test_no_ray_through_a_shared_edge_or_vertex_leaves_the_box_opencl(box):
    occluded = _occluded_opencl()
    scene, bvh, c = box
    p, q = _through_edges_and_vertices(scene, c)
    assert occluded(bvh, p, q).all()


@pytest.mark.opencl
def test_the_l_room_wall_keeps_the_other_wings_light_out():
    # l_room, 0.1 m mesh: the ray from the wing's light to (6, 1.2, 0.6) crosses both walls
    # of the cut-out corner on mesh edges; the float32 kernel let 9.6 lx of 3000 lm through
    from invrad_wb.core.forward.direct import direct_illuminance
    _occluded_opencl()
    scene = g.l_room((6, 5, 3), cut=(3, 2.5), cell=0.1, reflectance=0.0)
    bvh = BVH(scene.triangles)
    pts = np.array([[6.0, 1.2, 0.6], [6.0, 1.4, 0.6], [4.0, 2.3, 0.0], [3.0, 3.8, 0.0]])
    nrm = np.array([[-1.0, 0, 0], [-1.0, 0, 0], [0, 0, 1.0], [0, 0, 1.0]])
    wing = Luminaire([1.5, 3.8, 3.0], [0, 0, -1], 3000.0)
    main = Luminaire([4.5, 1.2, 3.0], [0, 0, -1], 3000.0)
    for backend in ("opencl", "numpy"):
        e = direct_illuminance(pts, nrm, [wing], bvh=bvh, backend=backend)
        assert np.all(e[:3] == 0.0), (backend, e)
        e = direct_illuminance(pts, nrm, [main], bvh=bvh, backend=backend)
        assert e[3] == 0.0 and np.all(e[:3] > 10.0), (backend, e)    # the lit side
