"""Aimed luminaires (issue 23): the light of a luminaire whose photometric axis is tilted
away from its mounting surface's normal, against the point-source formula
``E = I(gamma, C) cos(incidence) / d^2``, and the frame its photometry turns with."""
import os

import numpy as np
import pytest

from invrad_wb.core.forward.direct import direct_illuminance_numpy
from invrad_wb.core.forward.render import render
from invrad_wb.core.model import aiming
from invrad_wb.core.model.luminaires import Luminaire, luminaire_from_dict
from invrad_wb.core.model.photometry import read_photometry
from invrad_wb.core.synthetic import generate
from invrad_wb.errors import LuminaireError
from repo_paths import PHOTOMETRY

PHOT = PHOTOMETRY
DOWN = np.array([0.0, 0.0, -1.0])


def _points(rng, n=400):
    """Receivers on the floor (z = 0, up) and on the wall x = 5 (facing -x)."""
    floor = np.column_stack([rng.uniform(0, 5, n), rng.uniform(0, 4, n), np.zeros(n)])
    wall = np.column_stack([np.full(n, 5.0), rng.uniform(0, 4, n), rng.uniform(0, 2.5, n)])
    nf = np.tile([0.0, 0.0, 1.0], (n, 1))
    nw = np.tile([-1.0, 0.0, 0.0], (n, 1))
    return np.vstack([floor, wall]), np.vstack([nf, nw])


def _formula(points, normals, position, aim, c0, intensity):
    """E = I(gamma, C) cos(incidence) / d^2, written out from the definitions."""
    d = points - position
    dist = np.linalg.norm(d, axis=1)
    w = d / dist[:, None]
    gamma = np.arccos(np.clip(w @ aim, -1, 1))
    u = c0 - aim * (c0 @ aim)
    u /= np.linalg.norm(u)
    v = np.cross(aim, u)
    c = np.arctan2(w @ v, w @ u)
    inc = np.maximum(-np.einsum("ij,ij->i", normals, w), 0.0)
    return intensity(gamma, c) * inc / dist ** 2


def _as_filed(f, step_deg, period=None):
    """``f`` (radians -> value) as the test files sample it (every ``step_deg``) and
    invrad interpolates it (linearly): the exact reference for the frame."""
    if period:
        grid = np.radians(np.arange(0.0, 360.0 + step_deg / 2, step_deg))
        return lambda x: np.interp(np.mod(x, 2 * np.pi), grid, f(grid))
    grid = np.radians(np.arange(0.0, 180.0 + step_deg / 2, step_deg))
    return lambda x: np.interp(x, grid, f(grid))


def test_tilt_and_pan_round_trip():
    for tilt, pan in [(0.0, 0.0), (15.0, 10.0), (42.0, 200.0), (60.0, 359.0), (70.0, 90.0)]:
        for m in (DOWN, np.array([1.0, 0, 0]), np.array([0, 0, 1.0])):
            a = aiming.aim_from_tilt_pan(m, tilt, pan)
            t, p = aiming.tilt_pan(a, m)
            assert t == pytest.approx(tilt, abs=1e-9)
            if tilt:
                assert (p - pan + 180) % 360 - 180 == pytest.approx(0.0, abs=1e-9)
            ab = aiming.aim_offset(m, a)
            np.testing.assert_allclose(aiming.aim_of_offset(m, ab), a, atol=1e-12)
    # clamped to the largest tilt
    a = aiming.aim_of_offset(DOWN, [10.0, 0.0], max_tilt_deg=70.0)
    assert aiming.tilt_pan(a, DOWN)[0] == pytest.approx(70.0)


@pytest.mark.parametrize("tilt, pan", [(15.0, 0.0), (40.0, 30.0), (60.0, 250.0)])
def test_tilted_spot_against_the_point_source_formula(tilt, pan):
    """spot.ies is I = F (n + 1) / (2 pi) cos^n(gamma), n = 10."""
    phot = read_photometry(os.path.join(PHOT, "spot.ies"))
    flux, n = 1500.0, 10
    pos = np.array([1.2, 1.8, 2.5])
    aim = aiming.aim_from_tilt_pan(DOWN, tilt, pan)
    lum = Luminaire(pos, aim, flux, photometry=phot, c0=aiming.aimed_c0(DOWN, aim))
    pts, nrm = _points(np.random.default_rng(3))
    got = direct_illuminance_numpy(pts, nrm, [lum], occlusion=False)
    # the file samples gamma every 5 degrees and invrad interpolates linearly
    shape = _as_filed(lambda g: np.maximum(np.cos(g), 0) ** n, 5.0)
    want = _formula(pts, nrm, pos, aim, lum.c0,
                    lambda g, c: flux * (n + 1) / (2 * np.pi) * shape(g))
    lit = want > 0.05 * want.max()
    assert lit.sum() > 20
    np.testing.assert_allclose(got[lit], want[lit], rtol=0.01)
    assert np.all(got[~lit] < 0.07 * want.max())
    # the brightest point is near where the axis meets the floor or the wall
    t_floor = -pos[2] / aim[2]
    t_wall = (5.0 - pos[0]) / aim[0] if aim[0] > 0 else np.inf
    hit = pos + min(t_floor, t_wall) * aim
    best = pts[np.argmax(got)]
    if 0 <= hit[0] <= 5 and 0 <= hit[1] <= 4:
        assert np.linalg.norm(best - hit) < 0.25 * min(t_floor, t_wall)


def test_asymmetric_distribution_turns_with_the_tilt():
    """asymmetric.ies: I = F (n + 1) / (2 pi) cos^n(gamma) (1 + 0.5 cos C), n = 2; its
    C = 0 side follows the mounted C = 0 axis carried by the tilt."""
    phot = read_photometry(os.path.join(PHOT, "asymmetric.ies"))
    flux = 1500.0
    pos = np.array([2.5, 2.0, 2.5])
    aim = aiming.aim_from_tilt_pan(DOWN, 45.0, 120.0)
    c0 = aiming.aimed_c0(DOWN, aim)
    lum = Luminaire(pos, aim, flux, photometry=phot, c0=c0)
    pts, nrm = _points(np.random.default_rng(4))
    got = direct_illuminance_numpy(pts, nrm, [lum], occlusion=False)
    shape = _as_filed(lambda g: np.maximum(np.cos(g), 0) ** 2, 5.0)
    side = _as_filed(lambda c: 1 + 0.5 * np.cos(c), 15.0, period=True)
    want = _formula(pts, nrm, pos, aim, c0,
                    lambda g, c: flux * 3 / (2 * np.pi) * shape(g) * side(c))
    lit = want > 0.05 * want.max()
    np.testing.assert_allclose(got[lit], want[lit], rtol=0.01)
    # the luminaire's own plane_basis frame (no c0) puts the bright side elsewhere
    other = direct_illuminance_numpy(pts, nrm, [Luminaire(pos, aim, flux, photometry=phot)],
                                     occlusion=False)
    assert np.max(np.abs(other[lit] / want[lit] - 1)) > 0.2
    # the C = 0 axis is continuous in the tilt (plane_basis of the aim is not: it turns
    # its reference at 25.8 degrees off vertical)
    for pan in (0.0, 70.0, 160.0):
        a1 = aiming.aim_from_tilt_pan(DOWN, 25.0, pan)
        a2 = aiming.aim_from_tilt_pan(DOWN, 27.0, pan)
        u1, u2 = aiming.aimed_c0(DOWN, a1), aiming.aimed_c0(DOWN, a2)
        assert np.degrees(np.arccos(np.clip(u1 @ u2, -1, 1))) < 2.5
        assert abs(u1 @ a1) < 1e-12 and abs(u2 @ a2) < 1e-12


def test_render_of_a_tilted_spot_in_a_room():
    """The whole forward path (render, direct part) at a room's vertices."""
    phot = read_photometry(os.path.join(PHOT, "spot.ies"))
    scene = generate.box_room((5.0, 4.0, 2.5), cell=0.25, reflectance=0.5)
    pos = np.array([2.0, 2.05, 2.5])
    aim = aiming.aim_from_tilt_pan(DOWN, 60.0, 0.0)      # at the wall x = 5, 0.77 m up
    lum = Luminaire(pos, aim, 2000.0, photometry=phot, c0=aiming.aimed_c0(DOWN, aim))
    total, direct, _ = render(scene, [lum], return_parts=True, backend="numpy")
    shape = _as_filed(lambda g: np.maximum(np.cos(g), 0) ** 10, 5.0)
    far = np.linalg.norm(scene.vertices - pos, axis=1) > 0.05
    want = np.zeros(len(scene.vertices))
    want[far] = _formula(scene.vertices[far], scene.vertex_normals[far], pos, aim, lum.c0,
                         lambda g, c: 2000.0 * 11 / (2 * np.pi) * shape(g))
    lit = want > 0.05 * want.max()
    np.testing.assert_allclose(direct[lit], want[lit], rtol=0.01)
    wall = scene.vertices[:, 0] > 5.0 - 1e-9
    assert wall[np.argmax(direct)]                          # the spot is on the wall
    assert np.all(total >= direct - 1e-9)


def test_c0_in_json():
    d = {"position": [1, 2, 3], "normal": [0.5, 0, -0.866], "flux_lm": 800,
         "c0": [0.866, 0, 0.5]}
    lum = luminaire_from_dict(d)
    np.testing.assert_allclose(luminaire_from_dict(lum.to_dict()).c0, lum.c0)
    with pytest.raises(LuminaireError, match="c0 must not be parallel"):
        luminaire_from_dict({**d, "c0": [0.5, 0, -0.866]})
    assert "c0" not in luminaire_from_dict({**d, "c0": None}).to_dict()


# ---------------------------------------------------------------- locate --aim free
from invrad_wb.core.inverse.locate import LocateSettings, locate  # noqa: E402
from invrad_wb.errors import SettingsError  # noqa: E402


def test_aim_settings():
    assert LocateSettings().aim == "fixed"
    assert LocateSettings.from_dict({"aim": "free", "max_tilt_deg": 50}).max_tilt_deg == 50
    with pytest.raises(SettingsError, match="aim must be one of"):
        LocateSettings.from_dict({"aim": "tilted"})
    with pytest.raises(SettingsError, match="max_tilt_deg"):
        LocateSettings.from_dict({"aim": "free", "max_tilt_deg": 95})


def test_cli_aim_options():
    from invrad_wb.cli import build_parser
    from invrad_wb.cli.locate import _settings_from_args
    args = build_parser().parse_args(["locate", "scene.ply", "--flux", "1000", "-o", "r.json",
                                      "--aim", "free", "--max-tilt", "55"])
    s = _settings_from_args(args)
    assert (s.aim, s.max_tilt_deg) == ("free", 55.0)


@pytest.fixture(scope="module")
def spot_room():
    """A ceiling spot aimed 35 degrees at a wall beside a downlight (direct light)."""
    phot = read_photometry(os.path.join(PHOT, "spot.ies"))
    scene = generate.box_room((4.0, 3.0, 2.7), cell=0.1, reflectance=0.0)
    aim = aiming.aim_from_tilt_pan(DOWN, 35.0, 180.0)        # towards the wall x = 0
    true = [Luminaire([1.3, 1.6, 2.7], aim, 1200.0, photometry=phot,
                      c0=aiming.aimed_c0(DOWN, aim)),
            Luminaire([2.9, 1.4, 2.7], DOWN, 1200.0, photometry=phot)]
    lux = render(scene, true, interreflection=False, backend="numpy")
    return scene.with_vertex_lux(lux), true, phot


def _check_found(found, true, flux_tol=None):
    assert len(found) == len(true), [L.to_dict() for L in found]
    for t in true:
        f = min(found, key=lambda L: np.linalg.norm(L.position - t.position))
        assert np.linalg.norm(f.position - t.position) < 0.05
        assert np.degrees(np.arccos(np.clip(f.normal @ t.normal, -1, 1))) < 2.0
        if flux_tol:
            assert f.flux_lm == pytest.approx(t.flux_lm, rel=flux_tol)
        tilt, _ = aiming.tilt_pan(t.normal, DOWN)
        assert f.extra["tilt_deg"] == pytest.approx(tilt, abs=2.0)


@pytest.mark.slow
def test_locate_aim_free_finds_a_tilted_spot(spot_room):
    scene, true, phot = spot_room
    res = locate(scene, 1200.0, LocateSettings(aim="free", indirect="none"),
                 photometry=phot, backend="numpy")
    _check_found(res.luminaires, true)
    # the result's normal is the aim, with the photometry's C = 0 axis turned with it
    spot = max(res.luminaires, key=lambda L: L.extra["tilt_deg"])
    assert spot.c0 is not None and abs(spot.c0 @ spot.normal) < 1e-9
    assert spot.to_dict()["normal"] == [round(float(x), 6) for x in spot.normal]


@pytest.mark.slow
def test_locate_aim_fixed_keeps_luminaires_facing_their_surface(spot_room):
    """The default cannot explain the spot: every luminaire faces straight down."""
    scene, true, phot = spot_room
    res = locate(scene, 1200.0, LocateSettings(indirect="none", overlap_levels=1),
                 photometry=phot, backend="numpy")
    assert all(L.normal @ DOWN > 0.999 or L.extra.get("mount") == "pendant"
               for L in res.luminaires)
    assert all("tilt_deg" not in L.extra for L in res.luminaires)


def test_symmetric_beam_against_the_photometry_and_its_gradients():
    """The refinement's batched light of aimed symmetric spots (aimlight) gives the
    bilinear table's light, and analytic position and aim gradients equal to central
    differences."""
    from invrad_wb.core.inverse.aimlight import SymmetricBeam
    from invrad_wb.core.model.scene import plane_basis
    phot = read_photometry(os.path.join(PHOT, "spot.ies"))
    pts, nrm = _points(np.random.default_rng(5), 600)
    beam = SymmetricBeam(phot.table[0], pts, nrm)
    C = np.array([[1.2, 1.8, 2.5], [3.0, 1.0, 2.5]])
    m = DOWN
    ab = np.array([[0.4, -0.3], [-0.2, 0.6]])
    N = np.array([aiming.aim_of_offset(m, x) for x in ab])
    flux = np.array([1500.0, 700.0])
    E, G = beam.light(C, N, flux, with_grad=True)
    for i in range(2):
        u, v = plane_basis(N[i])
        d = pts - C[i]
        r2 = np.einsum("ij,ij->i", d, d)
        w = d / np.sqrt(r2)[:, None]
        cs = np.maximum(-np.einsum("ij,ij->i", nrm, w), 0.0)
        ref = flux[i] * phot.intensity_per_lm(np.stack([w @ u, w @ v, w @ N[i]], 1)) * cs / r2
        np.testing.assert_allclose(E[i], np.where(cs > 1e-9, ref, 0.0), rtol=1e-9,
                                   atol=1e-9 * ref.max())
    h = 1e-6
    fd = np.stack([(beam.light(C + h * e, N, flux) - beam.light(C - h * e, N, flux)) / (2 * h)
                   for e in np.eye(3)], axis=-1)
    assert np.abs(G - fd).max() <= 1e-5 * np.abs(fd).max()
    J = aiming.aim_of_offset_jacobian(m, ab[0])
    ga = beam.aim_grad(C[0], N[0], flux[0], J)
    fa = np.stack([(beam.light(C[:1], aiming.aim_of_offset(m, ab[0] + h * e)[None], flux[0])[0]
                    - beam.light(C[:1], aiming.aim_of_offset(m, ab[0] - h * e)[None],
                                 flux[0])[0]) / (2 * h) for e in np.eye(2)], axis=1)
    assert np.abs(ga - fa).max() <= 1e-5 * np.abs(fa).max()
    # asked without a gradient batch before it (nothing kept from one): the same
    fresh = SymmetricBeam(phot.table[0], pts, nrm)
    np.testing.assert_allclose(fresh.aim_grad(C[0], N[0], flux[0], J), ga, rtol=1e-12,
                               atol=1e-12 * np.abs(ga).max())


@pytest.mark.parametrize("name", ["spot.ies", "asymmetric.ies"])
def test_footprint_scorer_light_against_the_direct_renderer(name):
    """The footprint search's batched light of many aimed luminaires (matrix products, and
    for a symmetric beam a table over sin(gamma / 2)) gives the direct renderer's light
    (no occlusion) of each luminaire: within 0.2 % of its brightest point."""
    from types import SimpleNamespace
    from invrad_wb.core.inverse.aim import _Scorer
    phot = read_photometry(os.path.join(PHOT, name))
    pts, nrm = _points(np.random.default_rng(11), 300)
    k = len(pts)
    prob = SimpleNamespace(positions=pts, normals=nrm, target=np.ones(k),
                           log_target=np.zeros(k), indirect=np.zeros(k),
                           w_area=np.ones(k), eps_lux=1.0, robust_scale=1.0, flux=1300.0,
                           photometry=phot)
    scorer = _Scorer(prob)
    assert (scorer.sym is not None) == (name == "spot.ies")
    rng = np.random.default_rng(2)
    C = np.column_stack([rng.uniform(0.5, 4.5, 6), rng.uniform(0.5, 3.5, 6), np.full(6, 2.6)])
    N = np.array([aiming.aim_from_tilt_pan(DOWN, t, p)
                  for t, p in zip(rng.uniform(0, 60, 6), rng.uniform(0, 360, 6))])
    got = scorer.direct(C, N, np.tile(DOWN, (6, 1)))
    for i in range(6):
        lum = Luminaire(C[i], N[i], 1300.0, photometry=phot, c0=aiming.aimed_c0(DOWN, N[i]))
        want = direct_illuminance_numpy(pts, nrm, [lum], occlusion=False)
        np.testing.assert_allclose(got[i], want, rtol=0, atol=2e-3 * want.max())


def test_polish_map_test_agrees_with_the_canvas():
    """The pattern search's test of many points at once (aim._on_map) says what
    VoteCanvas.map_contains says of each, inside, on the border of and off a room's
    surfaces (a sloped ceiling: walls whose top edge cuts pixels, where the face test
    decides)."""
    from invrad_wb.core.inverse.aim import _on_map
    from invrad_wb.core.inverse.votemaps import build_canvas
    mb = generate.MeshBuilder(0.25)
    generate.add_prism_room(mb, [(0, 0), (4, 0), (4, 3), (0, 3)], [(0, 0, 4, 3)],
                            height=2.5, slope=(0.2, 0.1), reflectance=0.5)
    canvas = build_canvas(mb.scene(), 0, pixel=0.1, dummy=False)
    rng = np.random.default_rng(4)
    by_face_test = 0
    for k, m in enumerate(canvas.maps):
        if m.kind != "surface":
            continue
        nu, nv = m.shape
        q = np.column_stack([rng.uniform(-0.3, nu * m.pixel + 0.3, 1000),
                             rng.uniform(-0.3, nv * m.pixel + 0.3, 1000)])
        P = m.origin + q[:, :1] * m.u + q[:, 1:] * m.v
        want = np.array([canvas.map_contains(k, p) for p in P])
        np.testing.assert_array_equal(_on_map(canvas, k, P), want)
        i, j = (np.floor(q / m.pixel).astype(int)).T
        on = (i >= 0) & (i < nu) & (j >= 0) & (j < nv)
        by_face_test += int(np.sum(m.mask[i[on], j[on]] & ~want[on]))
    assert by_face_test > 0       # points on a valid pixel that the face test rejects
