"""Photometry: EULUMDAT and IES files of our own making with analytic distributions."""
import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest

from invrad_wb.errors import LuminaireError, SettingsError
from invrad_wb.core.forward.direct import direct_illuminance
from invrad_wb.core.model.luminaires import Luminaire, load_luminaires
from invrad_wb.core.model.photometry import Photometry, integrate, read_photometry
from invrad_wb.core.model.scene import plane_basis
from repo_paths import PHOTOMETRY, ROOT, TESTS

DATA = PHOTOMETRY
PTS = np.array([[0, 0, 0], [1, 0, 0], [2, 1, 0], [0.5, -1.5, 0], [3, 3, 0.5]], float)
UP = np.tile([0.0, 0.0, 1.0], (len(PTS), 1))


def f(name):
    return os.path.join(DATA, name)


@pytest.mark.parametrize("name", ["lambertian.ldt", "lambertian.ies"])
def test_a_lambertian_file_reproduces_the_lambertian_model(name):
    p = read_photometry(f(name))
    assert p.flux_lm == pytest.approx(1000.0, rel=0.01)
    lum = [Luminaire([0, 0, 2.5], [0, 0, -1], 3000.0)]
    ref = direct_illuminance(PTS, UP, lum, backend="numpy")
    lum[0].photometry = p
    got = direct_illuminance(PTS, UP, lum, backend="numpy")
    assert np.allclose(got, ref, rtol=0.01)
    # and the textbook value under the luminaire: F / (pi h^2)
    assert got[0] == pytest.approx(3000 / (math.pi * 2.5 ** 2), rel=0.01)


def test_spot_on_axis_and_flux():
    p = read_photometry(f("spot.ies"))
    assert p.flux_lm == pytest.approx(2000.0, rel=0.01)
    # I(0) = F (n + 1) / (2 pi), n = 10; E = I / h^2 under it
    e = direct_illuminance(PTS[:1], UP[:1], [Luminaire([0, 0, 3], [0, 0, -1], 2000.0,
                                                       photometry=p)], backend="numpy")
    assert e[0] == pytest.approx(2000 * 11 / (2 * math.pi) / 9.0, rel=0.01)
    # a narrow beam puts less light beside it than a lambertian one
    lam = direct_illuminance(PTS[2:3], UP[2:3], [Luminaire([0, 0, 3], [0, 0, -1], 2000.0)],
                             backend="numpy")
    side = direct_illuminance(PTS[2:3], UP[2:3], [Luminaire([0, 0, 3], [0, 0, -1], 2000.0,
                                                           photometry=p)], backend="numpy")
    assert side[0] < 0.8 * lam[0]


def test_asymmetric_c_planes_follow_the_luminaire_frame():
    p = read_photometry(f("asymmetric.ies"))
    assert p.flux_lm == pytest.approx(1500.0, rel=0.01)
    n = np.array([0.0, 0.0, -1.0])
    u, v = plane_basis(n)
    g = math.radians(30)
    towards_c0 = math.sin(g) * u + math.cos(g) * n
    towards_c180 = -math.sin(g) * u + math.cos(g) * n
    pts = np.array([[0, 0, 3.0]]) + 3.0 / math.cos(g) * np.array([towards_c0, towards_c180])
    e = direct_illuminance(pts, np.tile([0, 0, 1.0], (2, 1)),
                           [Luminaire([0, 0, 3], n, 1500.0, photometry=p)], backend="numpy")
    assert e[0] / e[1] == pytest.approx(3.0, rel=0.02)      # (1 + 0.5) / (1 - 0.5)


def test_tables_integrate_to_one_lumen_per_lumen():
    for name in ("lambertian.ldt", "spot.ies", "asymmetric.ies"):
        assert integrate(read_photometry(f(name)).table) == pytest.approx(1.0, rel=1e-9)
    assert integrate(Photometry.lambertian().table) == pytest.approx(1.0, rel=1e-9)


@pytest.mark.opencl
def test_opencl_adds_photometric_luminaires_like_the_twin():
    p = read_photometry(f("asymmetric.ies"))
    lums = [Luminaire([1, 1, 3], [0, 0, -1], 1500.0, photometry=p),
            Luminaire([2, 0, 3], [0, 0, -1], 2000.0)]
    a = direct_illuminance(PTS, UP, lums, backend="numpy")
    b = direct_illuminance(PTS, UP, lums, backend="opencl")
    assert np.allclose(a, b, rtol=1e-3, atol=1e-3)


@pytest.mark.parametrize("name, words", [("broken.ldt", "not a valid EULUMDAT"),
                                         ("nothing.ies", "cannot read photometry"),
                                         ("text.ies", "not a valid IES"),
                                         ("lamp.xyz", ".ldt or IES")])
def test_bad_photometry_files_name_the_file(tmp_path, name, words):
    path = f(name) if name == "broken.ldt" else str(tmp_path / name)
    if name in ("text.ies", "lamp.xyz"):
        open(path, "w").write("this is not photometry\n")
    with pytest.raises(LuminaireError) as e:
        read_photometry(path)
    assert words in str(e.value) and name in str(e.value) and "\n" not in str(e.value)


def test_luminaires_json_carries_its_photometry(tmp_path):
    src = open(f("spot.ies")).read()
    (tmp_path / "spot.ies").write_text(src)
    (tmp_path / "l.json").write_text(json.dumps({"luminaires": [
        {"position": [0, 0, 3], "flux_lm": 2000, "photometry": "spot.ies"}]}))
    lums = load_luminaires(tmp_path / "l.json")
    assert lums[0].photometry.flux_lm == pytest.approx(2000, rel=0.01)
    assert lums[0].to_dict()["photometry"].endswith("spot.ies")


def test_design_spec_refuses_a_photometry_file_that_does_not_parse():
    from invrad_wb.core.design.spec import spec_from_dict
    with pytest.raises(SettingsError, match="broken.ldt.*not a valid EULUMDAT"):
        spec_from_dict({"catalogue": [{"name": "A", "flux_lm": 1000, "watts": 8,
                                       "photometry": "broken.ldt"}],
                        "rooms": {"0": {"room_type": "office"}}}, base_dir=DATA)


def test_design_uses_the_distribution():
    from invrad_wb.core.design.design import design_room
    from invrad_wb.core.design.spec import spec_from_dict
    from invrad_wb.core.synthetic import generate as g
    sc = g.with_reflectances(g.box_room(size=(8.0, 6.0, 4.0), cell=0.4))
    out = {}
    for ph in (None, "spot.ies"):
        e = {"name": "X", "flux_lm": 2000, "watts": 15, **({"photometry": ph} if ph else {})}
        sp = spec_from_dict({"catalogue": [e], "rooms": {"0": {"work_plane": {
            "lux": 300, "u0": 0.4}}}}, base_dir=DATA)
        rd = design_room(sc, sp, 0)
        assert rd.compliant
        out[ph] = rd
    # a narrow beam sends more of its flux onto the work plane: fewer luminaires
    assert len(out["spot.ies"].luminaires) < len(out[None].luminaires)
    assert all(lum.photometry is not None for lum in out["spot.ies"].luminaires)


def test_cli_render_with_a_lambertian_file_matches_the_default(tmp_path):
    from invrad_wb.core.io.sceneio import read_scene
    (tmp_path / "l.json").write_text(json.dumps({"luminaires": [
        {"position": [3, 2, 3], "normal": [0, 0, -1], "flux_lm": 3000}]}))
    office = os.path.join(ROOT, "examples", "office.ply")
    outs = []
    for extra in ([], ["--photometry", f("lambertian.ldt")]):
        out = tmp_path / f"o{len(outs)}.ply"
        cp = subprocess.run([sys.executable, "-m", "invrad_wb", "render", office,
                             "--luminaires", "l.json", "-o", str(out),
                             "--no-interreflection", *extra], cwd=tmp_path,
                            capture_output=True, text=True, timeout=300)
        assert cp.returncode == 0, cp.stderr
        outs.append(read_scene(out).vertex_targets())
    lit = outs[0] > 5
    assert np.allclose(outs[1][lit], outs[0][lit], rtol=0.01)


@pytest.mark.slow
@pytest.mark.parametrize("name,rho", [("spot.ies", 0.0), ("asymmetric.ies", 0.5)])
def test_locate_refines_with_the_distribution(name, rho):
    """Luminaires with a narrow beam or asymmetric C-planes: the lambertian refinement
    misses them (by more than the 50 cm match radius); with the file's distribution in the
    refinement (and its interreflection model) both are found within 1 cm."""
    from invrad_wb.core.forward.render import render
    from invrad_wb.core.inverse.locate import locate
    from invrad_wb.core.synthetic import generate as g
    from invrad_wb.core.synthetic.scenarios import match
    ph = read_photometry(f(name))
    scene = g.box_room((6, 4, 3), cell=0.1, reflectance=rho)
    true = [Luminaire([2.0, 1.5, 3.0], [0, 0, -1], 2000.0, photometry=ph),
            Luminaire([4.2, 2.6, 3.0], [0, 0, -1], 2000.0, photometry=ph)]
    scene = scene.with_vertex_lux(render(scene, true, interreflection=rho > 0))
    m = match(locate(scene, 2000.0, photometry=ph).luminaires, true)
    assert m["found"] == m["true"] == 2 and m["spurious"] == 0, m
    assert m["max_error_cm"] < 1.0, m
    assert match(locate(scene, 2000.0).luminaires, true)["found"] < 2


def _vote_case():
    import sys
    sys.path.insert(0, os.path.join(TESTS, "core", "inverse"))      # test_locate's cases
    import test_locate as T
    s = T._small_case()
    pts = T.voting_points(s, density=30)
    canvas = T.build_canvas(s, 0, pixel=0.15, dummy_spacing=0.3)
    W = T.vote_weights(canvas, pts, pts.lux, "illumination")
    return T, canvas, pts, W


@pytest.mark.parametrize("name", ["spot.ies", "asymmetric.ies"])
def test_photometric_votes_opencl_matches_numpy_twin(name):
    pytest.importorskip("pyopencl")
    from invrad_wb.core.accel.device import opencl_available
    if not opencl_available():
        pytest.skip("no OpenCL device")
    from invrad_wb.core.inverse.votes import cast_exact_numpy, cast_exact_opencl, vote_profile
    T, canvas, pts, W = _vote_case()
    prof = vote_profile(read_photometry(f(name)))
    a = cast_exact_numpy(canvas, pts, W, pts.lux, 2000.0, profile=prof)
    b = cast_exact_opencl(canvas, pts, W, pts.lux, 2000.0, profile=prof)
    assert a.sum() > 100 and abs(a.sum() - b.sum()) < 1e-3 * a.sum()
    T.assert_same_votes_up_to_pixel_borders(canvas, a, b)
    lam = cast_exact_numpy(canvas, pts, W, pts.lux, 2000.0)
    assert np.abs(a - lam).sum() > 0.05 * lam.sum()       # the distribution changes the votes


def test_a_lambertian_distribution_votes_like_the_lambertian_model():
    from invrad_wb.core.inverse.votes import cast_exact_numpy, vote_profile
    from invrad_wb.core.model.photometry import Photometry
    T, canvas, pts, W = _vote_case()
    a = cast_exact_numpy(canvas, pts, W, pts.lux, 2000.0)
    b = cast_exact_numpy(canvas, pts, W, pts.lux, 2000.0,
                         profile=vote_profile(Photometry.lambertian()))
    # the same contours, up to the profile table's interpolation (1/4 degree)
    assert abs(a.sum() - b.sum()) < 2e-3 * a.sum()
    assert np.abs(a - b).max() < 0.3


def test_narrow_beam_votes_peak_on_the_luminaires():
    """The votes use the file's distribution: the raw peaks (no refinement) of two
    narrow-beam downlights lie on them; lambertian votes put them a metre away."""
    from invrad_wb.core.forward.render import render
    from invrad_wb.core.inverse import locate as L
    from invrad_wb.core.synthetic import generate as g
    ph = read_photometry(f("spot.ies"))
    scene = g.box_room((6, 4, 3), cell=0.1, reflectance=0.0)
    true = [Luminaire([2.0, 1.5, 3.0], [0, 0, -1], 2000.0, photometry=ph),
            Luminaire([4.2, 2.6, 3.0], [0, 0, -1], 2000.0, photometry=ph)]
    scene = scene.with_vertex_lux(render(scene, true, interreflection=False))

    def raw_errors(**kw):
        r = L.locate(scene, 2000.0, photometry=ph, refine=False, threshold=64, **kw)
        P = np.array([p.position for run in r.rooms for p in run.peaks])
        return [float(np.min(np.linalg.norm(P - t.position, axis=1))) for t in true]
    assert max(raw_errors()) < 0.05
    from invrad_wb.core.inverse import locate_problem as LP     # where votes are cast
    lambertian = LP.vote_profile
    try:
        LP.vote_profile = lambda photometry: None
        assert min(raw_errors()) > 0.5
    finally:
        LP.vote_profile = lambertian


def test_rectangular_luminous_opening_is_read_along_its_axes(tmp_path):
    """The luminous opening's length and width, along the luminaire's C0 and C90 axes:
    IES LM-63 gives length along 0-180 degrees; EULUMDAT length along the longitudinal
    C90-C270 axis; a round opening (IES negative dimensions, EULUMDAT width 0) has none."""
    src = PHOTOMETRY
    with open(os.path.join(src, "lambertian.ies")) as fh:
        ies = fh.read()
    assert " 2 0.1 0.1 0.05" in ies
    (tmp_path / "panel.ies").write_text(ies.replace(" 2 0.1 0.1 0.05", " 2 0.3 1.2 0.05"))
    (tmp_path / "round.ies").write_text(ies.replace(" 2 0.1 0.1 0.05", " 2 -0.2 -0.2 0.05"))
    p = read_photometry(str(tmp_path / "panel.ies"))
    assert p.luminous_extent_m == pytest.approx((1.2, 0.3))
    assert p.luminous_area_m2 == pytest.approx(0.36)
    assert read_photometry(str(tmp_path / "round.ies")).luminous_extent_m is None
    with open(os.path.join(src, "lambertian.ldt"), newline="") as fh:
        lines = fh.read().split("\r\n")
    assert lines[15:17] == ["100", "0"]           # luminous area: length 100 mm, round
    assert read_photometry(os.path.join(src, "lambertian.ldt")).luminous_extent_m is None
    lines[15:17] = ["1200", "300"]
    (tmp_path / "panel.ldt").write_bytes("\r\n".join(lines).encode())
    p = read_photometry(str(tmp_path / "panel.ldt"))
    assert p.luminous_extent_m == pytest.approx((0.3, 1.2))
    assert p.luminous_area_m2 == pytest.approx(0.36)
