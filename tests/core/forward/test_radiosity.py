"""Interreflection (radiosity): energy balance, form factors, backends, reuse.

Physics checks: the CIE 171:2006 style closed-room balance (mean interreflected illuminance
``rho Phi / (S (1 - rho))``), form-factor row sums in closed rooms, catalogue closed forms
for a differential element and a rectangle, and the behaviour of occluders, rooms, virtual
work planes and reuse. OpenCL tests are skipped when no OpenCL device exists.
"""
import numpy as np
import pytest

from invrad_wb import constants as C
from invrad_wb.core.synthetic import generate
from invrad_wb.core.forward import radiosity as R
from invrad_wb.core.model.luminaires import Luminaire
from invrad_wb.core.forward.render import render, scene_bvh
from invrad_wb.core.model.scene import Scene
from invrad_wb.errors import DeviceError, SettingsError

BACKENDS = ["numpy", pytest.param("opencl", marks=pytest.mark.opencl)]
FAST = "auto"                  # OpenCL where a device is usable, else the numpy twins


def vertex_areas(scene):
    """(n,) area represented by each vertex (a third of its faces), m^2."""
    w = np.zeros(len(scene.vertices))
    np.add.at(w, scene.faces.reshape(-1), np.repeat(scene.face_areas / 3.0, 3))
    return w


def plane_means(scene, values):
    """Area-weighted mean of vertex values on each plane, (n_planes,)."""
    w = vertex_areas(scene)
    vp = scene.vertex_plane
    return np.array([np.sum(w[vp == k] * values[vp == k]) / np.sum(w[vp == k])
                     for k in range(len(scene.planes))])


# ---------------------------------------------------------------------------- 1. CIE 171
@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("rho", [0.5, 0.7])
def test_closed_cube_mean_interreflection(rho, backend):
    """Point luminaire at the centre of a closed diffuse cube (CIE 171:2006 style)."""
    scene = generate.box_room(size=(4.0, 4.0, 4.0), reflectance=rho)
    flux = 1000.0
    total, direct, indirect = render(scene, [Luminaire([2, 2, 2], [0, 0, -1], flux)],
                                     backend=backend, return_parts=True)
    w = vertex_areas(scene)
    area = scene.face_areas.sum()
    expected = rho * flux / (area * (1.0 - rho))
    mean = np.sum(w * indirect) / area
    assert mean == pytest.approx(expected, rel=0.05)
    assert np.sum(w * direct) == pytest.approx(flux, rel=0.01)   # all flux lands
    # the four walls are alike by symmetry
    means = plane_means(scene, indirect)
    walls = [k for k, p in enumerate(scene.planes) if abs(p.normal[2]) < 0.5]
    assert len(walls) == 4
    assert np.ptp(means[walls]) < 0.01 * means[walls].mean()


@pytest.mark.parametrize("rho", [0.5, 0.7])
def test_closed_cube_each_face(rho):
    """Six luminaires facing +-x, +-y, +-z: every face gets the same mean, rho Phi/(S(1-rho))."""
    scene = generate.box_room(size=(4.0, 4.0, 4.0), reflectance=rho)
    flux = 500.0
    lums = [Luminaire([2, 2, 2], n, flux) for n in np.vstack([np.eye(3), -np.eye(3)])]
    _, _, indirect = render(scene, lums, backend=FAST, return_parts=True)
    expected = rho * 6 * flux / (scene.face_areas.sum() * (1.0 - rho))
    np.testing.assert_allclose(plane_means(scene, indirect), expected, rtol=0.02)


def test_face_means_converge_with_patch_size():
    """Face means of an asymmetric case barely change when the patches are refined."""
    scene = generate.box_room(size=(4.0, 4.0, 4.0), reflectance=0.6)
    lums = [Luminaire([1.2, 2.0, 3.0], [0.3, 0.0, -1.0], 1000.0)]
    parts = [render(scene, lums, backend=FAST, patch_size=ps, return_parts=True)[2]
             for ps in (None, 0.2)]
    coarse, fine = (plane_means(scene, p) for p in parts)
    np.testing.assert_allclose(coarse, fine, rtol=0.02)


# ---------------------------------------------------------------------------- 2. row sums
@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("make", [lambda: generate.box_room(size=(6.0, 4.0, 3.0)),
                                  lambda: generate.sloped_room(cell=0.25)],
                         ids=["box", "sloped"])
def test_form_factor_rows_sum_to_one_in_closed_room(make, backend):
    scene = make()
    model = R.RadiosityModel(scene, backend=backend, occlusion=False)
    rows = model.vertex_gather().matrix().sum(axis=1)
    np.testing.assert_allclose(rows, 1.0, atol=0.02)
    np.testing.assert_allclose(model.rooms[0].F.sum(axis=1), 1.0, atol=0.02)
    # corners and edges are among the receivers: vertices on 3 and on 2 planes
    n_planes = np.sum([np.abs(p.signed_distance(scene.vertices)) < 1e-6
                       for p in scene.planes], axis=0)
    assert np.any(n_planes == 3) and np.any(n_planes == 2)
    np.testing.assert_allclose(rows[n_planes == 3], 1.0, atol=0.02)


# ---------------------------------------------------------------------------- 3. analytic
def f_parallel_corner(a, b, c):
    """Element on the normal through a corner of a parallel a x b rectangle at distance c."""
    x, y = a / c, b / c
    return (x / np.sqrt(1 + x * x) * np.arctan(y / np.sqrt(1 + x * x))
            + y / np.sqrt(1 + y * y) * np.arctan(x / np.sqrt(1 + y * y))) / (2 * np.pi)


def f_perpendicular_corner(a, b, c):
    """Element in a plane perpendicular to an a x b rectangle that meets it along the
    rectangle's edge of length a; the element lies at distance c from that edge, opposite
    one end of it; b is the rectangle's extent away from the element's plane."""
    x, y = a / c, b / c
    s = np.sqrt(1 + y * y)
    return (np.arctan(x) - np.arctan(x / s) / s) / (2 * np.pi)


def rectangle_patch(corner, eu, ev, cells=4):
    """One patch: the rectangle corner + [0,1] eu + [0,1] ev as a grid of triangles whose
    front (emitting side) is eu x ev."""
    corner, eu, ev = (np.asarray(x, dtype=float) for x in (corner, eu, ev))
    s = np.linspace(0.0, 1.0, cells + 1)
    tris = []
    for i in range(cells):
        for j in range(cells):
            a = corner + s[i] * eu + s[j] * ev
            b = corner + s[i + 1] * eu + s[j] * ev
            c = corner + s[i + 1] * eu + s[j + 1] * ev
            d = corner + s[i] * eu + s[j + 1] * ev
            tris += [[a, b, c], [a, c, d]]
    n = np.cross(eu, ev)
    return R.PatchSet(np.array(tris), np.zeros(len(tris), int), [0], [n / np.linalg.norm(n)])


@pytest.mark.parametrize("backend", BACKENDS)
def test_point_to_rectangle_against_closed_forms(backend):
    a, b, c = 2.0, 1.0, 1.5
    up = [0.0, 0.0, 1.0]
    cases = []
    # parallel rectangle above, receiver under a corner / under the centre
    par = rectangle_patch([0, 0, c], [0, b, 0], [a, 0, 0])          # front faces -z
    cases.append((par, [0, 0, 0], up, f_parallel_corner(a, b, c)))
    cases.append((par, [a / 2, b / 2, 0], up, 4 * f_parallel_corner(a / 2, b / 2, c)))
    # perpendicular rectangle in the plane y = d, x in [0, a], z in [0, h], facing -y
    aa, h, d = 1.3, 0.9, 0.7
    per = rectangle_patch([0, d, 0], [aa, 0, 0], [0, 0, h])
    cases.append((per, [0, 0, 0], up, f_perpendicular_corner(aa, h, d)))
    # the same rectangle reaching below the receiver's horizon: only the upper part counts
    low = rectangle_patch([0, d, -h], [aa, 0, 0], [0, 0, 2 * h])
    cases.append((low, [0, 0, 0], up, f_perpendicular_corner(aa, h, d)))
    # a receiver on the rectangle's own edge line (a room edge): the limit from inside
    cases.append((per, [aa / 2, d, 0], up, 2 * f_perpendicular_corner(aa / 2, h, 1e-9)))
    for ps, p, m, ref in cases:
        assert ps.radius[0] * C.RADIOSITY_NEAR_FACTOR > np.linalg.norm(ps.centroid[0] - p)
        f = R.form_factor_matrix([p], [m], [-1], ps, backend=backend)[0, 0]
        assert f == pytest.approx(ref, rel=0.01), (p, ref)


@pytest.mark.parametrize("backend", BACKENDS)
def test_far_field_against_closed_form(backend):
    """A small patch far away uses the point approximation; it stays within 1 %."""
    side, c = 0.2, 2.0
    ps = rectangle_patch([-side / 2, -side / 2, c], [0, side, 0], [side, 0, 0])
    p = np.array([[0.0, 0.0, 0.0], [0.3, 0.1, 0.0]])
    far = np.linalg.norm(ps.centroid[0] - p, axis=1)
    assert np.all(far > (C.RADIOSITY_NEAR_FACTOR + C.RADIOSITY_NEAR_BLEND) * ps.radius[0])
    f = R.form_factor_matrix(p, [[0, 0, 1]] * 2, [-1, -1], ps, backend=backend)[:, 0]
    # second receiver: the rectangle spans [-0.4, -0.2] x [-0.2, 0] relative to it
    ref = [4 * f_parallel_corner(side / 2, side / 2, c),
           f_parallel_corner(0.4, 0.2, c) - f_parallel_corner(0.2, 0.2, c)]
    np.testing.assert_allclose(f, ref, rtol=0.01)


def test_exact_formula_matches_quadrature():
    """The clipped contour integral against brute-force quadrature, a tilted triangle."""
    tri = np.array([[[0.2, 0.5, -0.4], [1.1, 0.9, 0.8], [-0.3, 1.2, 0.6]]])
    n = np.cross(tri[0, 1] - tri[0, 0], tri[0, 2] - tri[0, 0])
    if n @ (np.zeros(3) - tri[0, 0]) < 0:          # make it face the receiver
        tri = tri[:, ::-1]
    m = np.array([0.0, 0.3, 1.0]) / np.linalg.norm([0.0, 0.3, 1.0])
    f = R.point_triangle_form_factor(np.zeros((1, 3)), m[None], tri)[0]
    k = 1500
    u, v = np.meshgrid((np.arange(k) + 0.5) / k, (np.arange(k) + 0.5) / k)
    keep = u + v < 1
    u, v = u[keep], v[keep]
    t = tri[0]
    x = t[0] + u[:, None] * (t[1] - t[0]) + v[:, None] * (t[2] - t[0])
    nt = np.cross(t[1] - t[0], t[2] - t[0])
    da = np.linalg.norm(nt) / (2 * len(u))      # area per sample
    nt /= np.linalg.norm(nt)
    r2 = np.einsum("ij,ij->i", x, x)
    ci = np.maximum(x @ m, 0) / np.sqrt(r2)
    cj = np.maximum(-(x @ nt), 0) / np.sqrt(r2)
    assert f == pytest.approx(np.sum(ci * cj / (np.pi * r2)) * da, rel=2e-3)


# ---------------------------------------------------------------------------- 4. backends
@pytest.mark.opencl
@pytest.mark.parametrize("make", [generate.pillar_room, generate.l_room],
                         ids=["pillar", "L"])
def test_opencl_matches_numpy(make):
    scene = make()
    models = {b: R.RadiosityModel(scene, backend=b, patch_size=0.5)
              for b in ("numpy", "opencl")}
    a, b = models["numpy"], models["opencl"]
    ra, rb = a.rooms[0], b.rooms[0]
    assert ra.vis is not None and (ra.vis == 0).any()          # the room occludes
    np.testing.assert_array_equal(ra.vis, rb.vis)
    np.testing.assert_allclose(rb.F, ra.F, rtol=1e-4, atol=1e-6)
    ga, gb = a.vertex_gather().matrix(), b.vertex_gather().matrix()
    np.testing.assert_allclose(gb, ga, rtol=2e-3, atol=2e-4)
    direct = np.random.default_rng(3).uniform(0, 500, len(scene.vertices))
    ia, ib = a.indirect_at_vertices(direct), b.indirect_at_vertices(direct)
    np.testing.assert_allclose(ib, ia, rtol=1e-3, atol=1e-3 * ia.max())


# ---------------------------------------------------------------------------- 5. behaviour
@pytest.mark.parametrize("backend", BACKENDS)
def test_black_room_has_no_interreflection(backend):
    scene = generate.box_room(size=(4.0, 3.0, 3.0), reflectance=0.0)
    _, direct, indirect = render(scene, [Luminaire([2, 1.5, 2.9], [0, 0, -1], 1000.0)],
                                 backend=backend, return_parts=True)
    assert direct.max() > 0
    assert np.all(indirect == 0)


def partition_room():
    """6 x 4 x 3 m room with a partition at x = 3 leaving gaps at one side and the top."""
    mb = generate.MeshBuilder(0.25)
    generate.add_prism_room(mb, [(0, 0), (6, 0), (6, 4), (0, 4)], [(0, 0, 6, 4)], height=3.0)
    generate.add_box_occluder(mb, (2.9, 0.05, 0.0), (3.1, 3.4, 2.6), skip_bottom=True)
    return mb.scene()


@pytest.mark.parametrize("backend", BACKENDS)
def test_occluder_reduces_indirect_behind_it(backend):
    scene = partition_room()
    x = scene.vertices[:, 0]
    direct = np.where(x < 2.5, 300.0, 0.0)       # light only the left part of the room
    lit = {}
    for occ in (True, False):
        model = R.RadiosityModel(scene, backend=backend, occlusion=occ, patch_size=0.5)
        lit[occ] = model.indirect_at_vertices(direct)
        assert not occ or model.n_rays > 0
    far_wall = np.isclose(x, 6.0) & (scene.vertex_normals[:, 0] < -0.9)
    assert lit[True][far_wall].mean() < 0.6 * lit[False][far_wall].mean()
    near_wall = np.isclose(x, 0.0) & (scene.vertex_normals[:, 0] > 0.9)
    assert lit[True][near_wall].mean() > 0.9 * lit[False][near_wall].mean()


@pytest.mark.parametrize("make", [generate.pillar_room, generate.l_room, partition_room],
                         ids=["pillar", "L", "partition"])
def test_blocker_faces_give_the_scene_bvh_answer(make):
    scene = make()
    model = R.RadiosityModel(scene, backend=FAST, patch_size=0.6)
    room = model.rooms[0]
    assert 0 < len(room.blockers) < len(scene.faces) // 4
    vis, _ = R.patch_visibility(room.patches, scene_bvh(scene), FAST)
    np.testing.assert_array_equal(room.vis, vis)
    box = R.RadiosityModel(generate.box_room(cell=0.5), backend=FAST)
    assert len(box.rooms[0].blockers) == 0 and box.rooms[0].vis is None and box.n_rays == 0


@pytest.mark.parametrize("backend", BACKENDS)
def test_render_adds_indirect_to_direct(backend):
    scene = generate.box_room(size=(5.0, 4.0, 3.0))
    lums = [Luminaire([2.5, 2.0, 2.9], [0, 0, -1], 2000.0)]
    total, direct, indirect = render(scene, lums, backend=backend, return_parts=True)
    np.testing.assert_allclose(total, direct + indirect)
    assert np.all(indirect > 0)           # a closed room: every vertex sees lit surfaces
    ceiling = scene.vertex_normals[:, 2] < -0.9
    assert np.all(direct[ceiling] == 0) and indirect[ceiling].min() > 0
    only_direct = render(scene, lums, backend=backend, interreflection=False)
    np.testing.assert_allclose(only_direct, direct)


@pytest.mark.parametrize("make", [lambda: generate.l_room(cell=0.3),
                                  lambda: generate.pillar_room(cell=0.3)])
def test_pairs_on_one_side_of_every_blocker_plane_are_not_cast(make, monkeypatch):
    """Patch pairs whose ray ends lie on the same side of every plane of the blockers are
    visible without a ray: the visibility is the one of every pair cast, with fewer rays."""
    from invrad_wb.core.forward import visibility as V
    from invrad_wb.core.geometry.bvh import BVH
    scene = make()
    model = R.RadiosityModel(scene, backend=FAST, patch_size=0.6, occlusion=False)
    room = model.rooms[0]
    bvh = BVH(scene.triangles[model._blocker_faces(room)])
    vis, rays = V.patch_visibility(room.patches, bvh, FAST)
    monkeypatch.setattr(V, "SIDE_PLANES_MAX", 0)          # every facing pair cast
    every, all_rays = V.patch_visibility(room.patches, bvh, FAST)
    assert (every == 0).sum() > 0.02 * every.size          # the blockers block
    np.testing.assert_array_equal(vis, every)
    assert rays < 0.9 * all_rays


def test_rooms_are_independent():
    scene, origins = generate.floor_of_rooms(rooms=((3.0, 3.0), (3.0, 3.0)), cell=0.3)
    lums = [Luminaire(origins[0] + [1.5, 1.5, 2.9], [0, 0, -1], 1000.0)]
    _, _, indirect = render(scene, lums, backend=FAST, return_parts=True)
    vroom = np.zeros(len(scene.vertices), int)
    vroom[scene.faces.reshape(-1)] = np.repeat(scene.face_room, 3)
    assert indirect[vroom == 0].min() > 0
    assert np.all(indirect[vroom == 1] == 0)


def test_virtual_work_plane_receives_but_does_not_reflect():
    box = generate.box_room(size=(4.0, 4.0, 3.0), cell=0.25)
    wp = generate.MeshBuilder(0.25).quad([0.5, 0.5, 0.75], [3.5, 0.5, 0.75],
                                         [3.5, 3.5, 0.75], [0.5, 3.5, 0.75],
                                         inward=[0, 0, 1])
    wv, wf = np.concatenate(wp._v), np.concatenate(wp._f)
    m_box = len(box.faces)
    scene = Scene(np.vstack([box.vertices, wv]), np.vstack([box.faces, wf + len(box.vertices)]),
                  face_reflectance=np.r_[box.face_reflectance, np.full(len(wf), 0.5)],
                  face_virtual=np.r_[np.zeros(m_box, bool), np.ones(len(wf), bool)])

    def direct(sc):
        v = sc.vertices
        return 100.0 + 50.0 * v[:, 0] + 20.0 * v[:, 2]

    with_wp = R.RadiosityModel(scene, backend=FAST)
    plain = R.RadiosityModel(box, backend=FAST)
    assert np.all(with_wp.patch_reflectance[with_wp.patch_virtual] == 0)
    ind = with_wp.indirect_at_vertices(direct(scene))
    ref = plain.indirect_at_vertices(direct(box))
    wp_vertices = np.unique(scene.faces[scene.face_virtual])
    assert ind[wp_vertices].min() > 0
    # the box's surfaces get exactly what they get without the work plane
    face_mean = ind[scene.faces[:m_box]].mean(axis=1)
    np.testing.assert_allclose(face_mean, ref[box.faces].mean(axis=1), rtol=1e-5)


# ---------------------------------------------------------------------------- 6. reuse
@pytest.mark.parametrize("backend", BACKENDS)
def test_reuse_matches_fresh_model(backend):
    scene = generate.pillar_room(cell=0.25)
    model = R.RadiosityModel.for_scene(scene, backend=backend, patch_size=0.6)
    assert R.RadiosityModel.for_scene(scene, backend=backend, patch_size=0.6) is model
    rng = np.random.default_rng(7)
    e1 = rng.uniform(0, 400, model.n_patches)
    e2 = rng.uniform(0, 100, model.n_patches)
    b1, b2 = model.solve(e1), model.solve(e2)
    b12 = model.solve(np.stack([e1, e2], axis=1))
    np.testing.assert_allclose(b12, np.stack([b1, b2], axis=1), rtol=1e-9)
    np.testing.assert_allclose(model.solve(2 * e1 + 3 * e2), 2 * b1 + 3 * b2, rtol=1e-4)
    assert np.all(b1 >= model.patch_reflectance * e1 - 1e-9)
    # receivers anywhere: face centroids of the pillar room
    pts = scene.face_centroids
    op = model.gather(pts, scene.face_normals, model.face_patch)
    g1, g2 = op(b1), op(b2)
    fresh = R.RadiosityModel(scene, backend=backend, patch_size=0.6)
    fop = fresh.gather(pts, scene.face_normals, fresh.face_patch)
    np.testing.assert_allclose(fresh.solve(e2), b2, rtol=1e-6)
    np.testing.assert_allclose(fop(fresh.solve(e1)), g1, rtol=1e-5)
    np.testing.assert_allclose(op(np.stack([b1, b2], 1)), np.stack([g1, g2], 1), rtol=1e-5)
    np.testing.assert_allclose(op.matrix() @ b2, g2, rtol=1e-4)
    # vertex chain = patch mean -> solve -> vertex gather
    direct = rng.uniform(0, 300, len(scene.vertices))
    chain = model.vertex_gather()(model.solve(model.patch_direct_from_vertices(direct)))
    np.testing.assert_allclose(model.indirect_at_vertices(direct), chain)


def _dense_solution(model, e, rho=None):
    """B = rho (E + F B) per room by numpy.linalg.solve of (I - rho F) B = rho E."""
    rho = model.patch_reflectance if rho is None else rho
    out = np.zeros_like(e)
    for room in model.rooms:
        r = rho[room.sl]
        a = np.eye(room.patches.n) - r[:, None] * room.F
        out[room.sl] = np.linalg.solve(a, (r[:, None] if e.ndim == 2 else r) * e[room.sl])
    return out


def test_direct_solve_matches_dense_solve_and_jacobi(monkeypatch):
    """The kept LU factors give numpy.linalg.solve's answer of B = rho (E + F B) (two
    rooms, ceiling/walls/floor 0.7/0.5/0.2, one and several right-hand sides); Jacobi
    (larger rooms, or reflectances changed on the model) agrees to its tolerance."""
    scene, _ = generate.floor_of_rooms(rooms=((3.0, 2.5), (2.5, 2.0)), height=2.5, cell=0.25)
    scene = generate.with_reflectances(scene)
    model = R.RadiosityModel(scene, backend=FAST, patch_size=0.5)
    assert len(model.rooms) == 2
    rng = np.random.default_rng(3)
    e = rng.uniform(0.0, 500.0, (model.n_patches, 3))
    exact = _dense_solution(model, e)
    b = model.solve(e[:, 0])
    assert model.last_iterations == 0                          # no sweep: direct
    np.testing.assert_allclose(b, exact[:, 0], rtol=1e-10, atol=1e-9)
    factors = [room.lu for room in model.rooms]
    assert all(f is not None for f in factors)
    np.testing.assert_allclose(model.solve(e), exact, rtol=1e-10, atol=1e-9)
    assert all(room.lu is f for room, f in zip(model.rooms, factors))   # made once
    # the balance itself: B = rho (E + F B) per room
    for room in model.rooms:
        rho = model.patch_reflectance[room.sl]
        np.testing.assert_allclose(b[room.sl], rho * (e[room.sl, 0] + room.F @ b[room.sl]),
                                   rtol=1e-10, atol=1e-9)
    # Jacobi where the factors do not apply, to its relative tolerance
    monkeypatch.setattr(C, "RADIOSITY_DIRECT_MAX_PATCHES", 0)
    jac = R.RadiosityModel(scene, backend=FAST, patch_size=0.5)
    bj = jac.solve(e)
    assert jac.last_iterations > 5
    assert np.max(np.abs(bj - exact)) < 1e-4 * np.max(np.abs(exact))
    monkeypatch.undo()
    # reflectances changed on the model for a while (a design's openings): iterated with
    # the new ones, the kept factors again once they are restored
    rho = model.patch_reflectance
    changed = rho * np.where(np.arange(model.n_patches) % 3 == 0, 0.5, 1.0)
    try:
        model.patch_reflectance = changed
        bc = model.solve(e[:, 1])
        assert model.last_iterations > 0
    finally:
        model.patch_reflectance = rho
    ref = _dense_solution(model, e[:, 1:2], changed)[:, 0]
    assert np.max(np.abs(bc - ref)) < 1e-4 * np.max(np.abs(ref))
    assert np.max(np.abs(bc - exact[:, 1])) > 1e-2 * np.max(np.abs(ref))
    np.testing.assert_allclose(model.solve(e[:, 1]), exact[:, 1], rtol=1e-10, atol=1e-9)
    assert model.last_iterations == 0



def test_lu_factors_and_solves_run_blas_on_one_thread(monkeypatch):
    """The radiosity's LU factors (and their solves) are made with every BLAS on one
    thread, also scipy's, loaded after a room limited numpy's (a thread count changes the
    factors' last bits); the threads outside are as they were afterwards."""
    threadpoolctl = pytest.importorskip("threadpoolctl")
    pytest.importorskip("scipy.linalg")

    def threads():
        return sorted({d["num_threads"] for d in threadpoolctl.threadpool_info()
                       if d["user_api"] == "blas"})
    lu_factor, lu_solve, one_thread = R._lapack()
    seen = []

    def spy(fn):
        def wrapped(*a, **kw):
            seen.append((fn.__name__, threads()))
            return fn(*a, **kw)
        return wrapped
    monkeypatch.setattr(R, "_LAPACK", [spy(lu_factor), spy(lu_solve), one_thread])
    scene = generate.with_reflectances(generate.box_room(size=(3.0, 2.5, 2.5), cell=0.5))
    model = R.RadiosityModel(scene, backend=FAST, patch_size=0.5)
    with threadpoolctl.threadpool_limits(limits=2, user_api="blas"):
        outside = threads()
        if outside in ([], [1]):
            # [] where threadpoolctl finds no BLAS it knows (FreeCAD 1.0's Debian root:
            # numpy on Debian's generic libblas), so neither the limit nor its effect can
            # be seen
            pytest.skip("no BLAS here that threadpoolctl sees runs more than one thread")
        b = model.solve(np.full(model.n_patches, 100.0))
        assert threads() == outside
    assert [name for name, _ in seen] == ["lu_factor", "lu_solve"]
    assert all(t == [1] for _, t in seen), seen
    assert model.last_iterations == 0 and np.all(b > 0)

def test_gather_streams_when_the_matrix_is_too_big(monkeypatch):
    scene = generate.box_room(size=(3.0, 3.0, 3.0), cell=0.3)
    model = R.RadiosityModel(scene, backend=FAST)
    b = model.solve(np.full(model.n_patches, 100.0))
    stored = model.gather(scene.vertices, scene.vertex_normals, model.vertex_patch)
    monkeypatch.setattr(C, "RADIOSITY_GATHER_MAX_MB", 0)
    monkeypatch.setattr(C, "RADIOSITY_CL_CHUNK_MB", 0)     # and one row per chunk
    streamed = model.gather(scene.vertices, scene.vertex_normals, model.vertex_patch)
    assert all(blk[2] is None for blk in streamed._blocks)
    np.testing.assert_allclose(streamed(b), stored(b), rtol=1e-5)
    rechunked = R.RadiosityModel(scene, backend=FAST)
    np.testing.assert_allclose(rechunked.rooms[0].F, model.rooms[0].F, rtol=1e-12)


def test_patch_direct_is_area_weighted_mean():
    scene = generate.box_room(size=(3.0, 2.0, 2.5), cell=0.25)
    model = R.RadiosityModel(scene, backend="numpy", patch_size=0.7)
    v = scene.vertices
    lux = 10.0 + v @ [3.0, -2.0, 5.0]              # linear: exact for the face means
    e = model.patch_direct_from_vertices(lux)
    cen = scene.face_centroids
    lin = 10.0 + cen @ [3.0, -2.0, 5.0]
    a = scene.face_areas
    ref = np.bincount(model.face_patch, a * lin) / np.bincount(model.face_patch, a)
    np.testing.assert_allclose(e, ref, rtol=1e-12)
    np.testing.assert_allclose(model.patch_area.sum(), a.sum())
    assert np.all(np.bincount(model.face_patch) > 0)


def test_default_patch_count_and_sizes():
    scene = generate.box_room(size=(6.0, 4.0, 3.0), cell=0.1)
    model = R.RadiosityModel(scene, backend="numpy", occlusion=False)
    assert 0.8 * C.RADIOSITY_TARGET_PATCHES < model.n_patches < 1.2 * C.RADIOSITY_TARGET_PATCHES
    tiny = generate.box_room(size=(1.0, 1.0, 1.0), cell=0.25)
    m2 = R.RadiosityModel(tiny, backend="numpy", occlusion=False)
    assert m2.room_patch_size[0] >= max(C.RADIOSITY_MIN_PATCH_M, 0.25)
    # representative points lie on their patches' planes
    for room in model.rooms:
        ps = room.patches
        d = np.einsum("ij,ij->i", ps.point - ps.centroid, ps.normal)
        np.testing.assert_allclose(d, 0.0, atol=1e-9)


# ---------------------------------------------------------------------------- errors
def test_bad_input_is_refused():
    scene = generate.box_room(size=(3.0, 3.0, 3.0), cell=0.5)
    for bad in (0.0, -1.0, float("nan"), "big"):
        with pytest.raises(SettingsError):
            R.RadiosityModel(scene, backend="numpy", patch_size=bad)
    model = R.RadiosityModel(scene, backend="numpy")
    with pytest.raises(ValueError):
        model.patch_direct_from_vertices(np.zeros(3))
    with pytest.raises(ValueError):
        model.solve(np.zeros(model.n_patches + 1))
    with pytest.raises(ValueError):
        model.gather(np.zeros((2, 3)), np.zeros((2, 3)), [0])


def test_numpy_backend_needs_no_opencl(monkeypatch):
    monkeypatch.setenv("INVRAD_OPENCL", "0")               # every get_env() now raises
    with pytest.raises(DeviceError, match="INVRAD_OPENCL=0"):
        R.get_env()
    scene = generate.pillar_room(cell=0.3)
    model = R.RadiosityModel(scene, backend="numpy", patch_size=0.8)
    assert model.n_rays > 0
    assert model.indirect_at_vertices(np.full(len(scene.vertices), 100.0)).min() > 0


@pytest.mark.parametrize("where, pos, normal", [
    ("downlight 0.1 m from two walls", [0.1, 0.1, 2.5], [0, 0, -1]),
    ("downlight 0.1 m from a wall", [2.5, 0.1, 2.5], [0, 0, -1]),
    ("wall light 0.1 m under the ceiling", [2.5, 0.0, 2.4], [0, 1, 0]),
    ("downlight in the middle", [2.5, 2.0, 2.5], [0, 0, -1]),
    ("pendant", [2.5, 2.0, 1.8], [0, 0, -1]),
])
def test_patch_direct_light_keeps_the_flux_of_a_luminaire_near_a_surface(where, pos, normal):
    # in a closed room all of a luminaire's flux lands on its surfaces: the patches' mean
    # direct light times their areas must add up to it. Patch means of vertex values (what
    # the radiosity used before) lose 24 % near one wall and 43 % in a corner
    scene = generate.with_reflectances(generate.box_room(size=(5.0, 4.0, 2.5), cell=0.3))
    model = R.RadiosityModel(scene, backend="numpy")
    lum = Luminaire(pos, normal, 2000.0)
    got = model.patch_direct([lum]) @ model.patch_area
    assert got == pytest.approx(2000.0, rel=0.015), where
    # a luminaire of another room lights none of this one's patches
    other = Luminaire(pos, normal, 2000.0, room=7)
    assert not np.any(model.patch_direct([other]))


def test_patch_direct_light_follows_shadows_and_the_distribution():
    from invrad_wb.core.forward.direct import direct_illuminance
    # far from the luminaire the patch light is the direct light at its sample point,
    # with the photometry and the scene's shadows
    scene = generate.with_reflectances(generate.box_room(size=(5.0, 4.0, 2.5), cell=0.3))
    model = R.RadiosityModel(scene, backend="numpy")
    lum = Luminaire([2.5, 2.0, 2.5], [0, 0, -1], 2000.0)
    pts, nrm = model.patch_points()
    sample = direct_illuminance(pts + nrm * 1e-4, nrm, [lum], occlusion=False,
                                backend="numpy")
    got = model.patch_direct([lum])
    d = np.linalg.norm(model.patch_centroid - lum.position, axis=1)
    far = d > 1.0
    np.testing.assert_allclose(got[far], sample[far], rtol=1e-9, atol=1e-9)
    # a slab under the luminaire shadows the floor: its patches get (almost) nothing
    from invrad_wb.core.geometry.bvh import BVH
    slab = np.array([[[1.5, 1.0, 2.0], [3.5, 1.0, 2.0], [3.5, 3.0, 2.0]],
                     [[1.5, 1.0, 2.0], [3.5, 3.0, 2.0], [1.5, 3.0, 2.0]]])
    shadowed = model.patch_direct([lum], bvh=BVH(slab), occlusion=True)
    under = (model.patch_normal[:, 2] > 0.9) & (np.abs(model.patch_centroid[:, 0] - 2.5) < 0.5) \
        & (np.abs(model.patch_centroid[:, 1] - 2.0) < 0.5)
    assert under.any() and np.all(shadowed[under] == 0.0)
    assert got[under].min() > 50.0


def test_patch_stats_in_blocks_equal_whole():
    """The patches' area, centroid, representative point and radius computed a block of
    triangles at a time (bounded temporaries on rooms of millions of faces) are the same
    numbers, bit for bit, as computed over every triangle at once."""
    from invrad_wb.core.forward.patches import _cluster_stats
    rng = np.random.default_rng(3)
    tri = rng.standard_normal((2000, 3, 3))
    cl = rng.integers(0, 40, len(tri))
    cl[:40] = np.arange(40)
    whole = _cluster_stats(tri, cl, 40, block=len(tri))
    for block in (1, 7, 512):
        got = _cluster_stats(tri, cl, 40, block=block)
        assert all(np.array_equal(a, b) for a, b in zip(whole, got))
    # a patch of two triangles: its area, centroid and the corner farthest from it
    sq = np.array([[[0, 0, 0], [1, 0, 0], [1, 1, 0]], [[0, 0, 0], [1, 1, 0], [0, 1, 0.]]])
    area, cen, _pt, radius, _rep = _cluster_stats(sq, np.array([0, 0]), 1, block=1)
    assert area[0] == pytest.approx(1.0) and np.allclose(cen[0], [0.5, 0.5, 0])
    assert radius[0] == pytest.approx(np.sqrt(0.5))
