"""Verification report: metrics on analytic cases, images, HTML/CSV, atomic output.

Achieved light is rendered with ``interreflection=False`` so that the expected values are
analytic (a lambertian point luminaire over a floor, CIE 171 style).
"""
import csv
import json
import math
import os

import numpy as np
import pytest

from invrad_wb.core.synthetic import generate as g
from invrad_wb.core.output import images as im
from invrad_wb.core.output import report as R
from invrad_wb.core.output import figures as FG
from invrad_wb.core.output import metrics as M
from invrad_wb.core.output import room_figures as RF
from invrad_wb.core.model.luminaires import Luminaire
from invrad_wb.core.forward.render import render
from invrad_wb.core.output.report import build_report, describe_plane, room_metrics
from invrad_wb.errors import SceneError

H = 2.5          # luminaire height over the floor (m)
F = 3000.0       # flux (lm)


def _floor(size=4.0, cell=0.1):
    return g.MeshBuilder(cell).quad([0, 0, 0], [size, 0, 0], [size, size, 0], [0, size, 0],
                                    inward=[0, 0, 1]).scene()


def _analytic(points, pos, flux):
    """E = F h^2 / (pi r^4) of a downward lambertian point luminaire on a floor (lx)."""
    d = points - np.asarray(pos)
    r2 = np.einsum("ij,ij->i", d, d)
    return flux * d[:, 2] ** 2 / (np.pi * r2 ** 2)


def _render(scene, pos, flux):
    return render(scene, [Luminaire(pos, [0, 0, -1], flux)], interreflection=False,
                  backend="numpy")


def _corner_rect_fraction(a, b, h):
    """Fraction of a downward lambertian point source's flux falling on an a x b
    rectangle with one corner below the source (form factor, closed form)."""
    A, B = a / h, b / h
    return (A / math.sqrt(1 + A * A) * math.atan(B / math.sqrt(1 + A * A))
            + B / math.sqrt(1 + B * B) * math.atan(A / math.sqrt(1 + B * B))) / (2 * math.pi)


def _midpoint_integral(scene, faces, values):
    """Edge-midpoint quadrature: exact for quadratics over each triangle. Returns the
    integral of ``values(corner_values)`` given per corner -> per midpoint."""
    c = values[scene.faces[faces]]
    mids = 0.5 * (c + c[:, [1, 2, 0]])
    return mids, scene.face_areas[faces]


# ---------------------------------------------------------------------------- metrics
def test_perfect_match_has_zero_error_and_analytic_em_emin_u0():
    s = _floor()
    pos = [2.0, 2.0, H]
    target = _analytic(s.vertices, pos, F)
    m = room_metrics(s, target, target.copy())
    assert m["rmse_pct"] == 0 and m["mae_pct"] == 0 and m["max_dev_lux"] == 0
    assert m["max_dev_where"] == "" and np.isnan(m["max_dev_point"]).all()
    assert m["within_tol_pct"] == pytest.approx(100.0)
    assert m["n_faces"] == len(s.faces) and m["area_m2"] == pytest.approx(16.0)
    # Emax right below the luminaire, Emin in the corners: analytic values at vertices
    assert m["target_emax"] == pytest.approx(F / (np.pi * H ** 2), rel=1e-12)
    r2 = 2 * 2.0 ** 2 + H ** 2
    assert m["target_emin"] == pytest.approx(F * H ** 2 / (np.pi * r2 ** 2), rel=1e-12)
    # Em = flux on the floor / area (closed-form form factor); linear interpolation on a
    # 0.1 m mesh integrates it to well within 0.2 %
    em = 4 * F * _corner_rect_fraction(2.0, 2.0, H) / 16.0
    assert m["target_em"] == pytest.approx(em, rel=2e-3)
    assert m["target_u0"] == pytest.approx(m["target_emin"] / m["target_em"])
    assert m["target_u0"] == pytest.approx(F * H ** 2 / (np.pi * r2 ** 2) / em, rel=2e-3)
    # the forward solver reproduces the analytic target
    achieved = _render(s, pos, F)
    m = room_metrics(s, target, achieved)
    assert m["rmse_pct"] < 1e-3 and abs(m["bias_pct"]) < 1e-3
    assert m["u0"] == pytest.approx(m["target_u0"], rel=1e-5)


def test_half_flux_is_fifty_percent_too_dark_everywhere():
    s = _floor()
    pos = [2.0, 2.0, H]
    target = _analytic(s.vertices, pos, F)
    achieved = _render(s, pos, F / 2)
    m = room_metrics(s, target, achieved)
    assert m["bias_pct"] == pytest.approx(-50.0, abs=1e-3)
    assert m["mae_pct"] == pytest.approx(50.0, abs=1e-3)
    assert m["within_tol_pct"] == 0.0
    assert m["max_dev_lux"] < 0 and m["max_dev_pct"] == pytest.approx(-50.0, abs=1e-3)
    # largest deviation in lux where the target is highest: right below the luminaire
    assert m["max_dev_point"][:2] == pytest.approx([2.0, 2.0], abs=1e-9)
    assert m["max_dev_where"] == "floor at (2.00, 2.00) m"
    # RMSE = sqrt(mean (E - T)^2) / mean T, against an independent exact quadrature
    faces = np.arange(len(s.faces))
    mids, area = _midpoint_integral(s, faces, achieved - target)
    ref = np.sqrt((area * (mids ** 2).mean(axis=1)).sum() / area.sum()) / m["target_em"]
    assert m["rmse_pct"] == pytest.approx(100 * ref, rel=1e-6)
    assert m["rmse_pct"] > 50.0          # a uniform -50 % weighs the bright centre more


def test_misplaced_brighter_luminaire_deviation_sign_and_place():
    s = _floor()
    target = _analytic(s.vertices, [2.0, 2.0, H], F)
    achieved = _render(s, [3.0, 1.0, H], 1.5 * F)
    m = room_metrics(s, target, achieved)
    assert m["max_dev_lux"] > 0                              # too bright ...
    # ... near the misplaced luminaire, pushed away from the target's centre (where the
    # target falls off): the analytic argmax of E - T
    diff = _analytic(s.vertices, [3.0, 1.0, H], 1.5 * F) - target
    best = s.vertices[np.argmax(diff)]
    assert m["max_dev_point"] == pytest.approx(best.tolist(), abs=1e-9)
    assert np.linalg.norm(best[:2] - [3.0, 1.0]) < 0.5
    assert np.linalg.norm(best[:2] - [2.0, 2.0]) > np.sqrt(2)
    assert m["max_dev_where"] == f"floor at ({best[0]:.2f}, {best[1]:.2f}) m"
    assert m["max_dev_lux"] == pytest.approx(diff.max(), rel=1e-5)
    assert m["max_dev_pct"] == pytest.approx(100 * diff.max() / target[np.argmax(diff)],
                                             rel=1e-5)
    # the darkest point is the corner farthest from the moved luminaire
    assert m["emin_point"][:2] == pytest.approx([0.0, 4.0])
    # mean absolute deviation integrates |E - T| exactly over each triangle even where it
    # changes sign: compare with a dense sub-triangle sampling
    d = (achieved - target)[s.faces]
    B = M._sub_barycentric(24)
    dense = (s.face_areas * np.abs(d @ B.T).mean(axis=1)).sum() / 16.0
    assert m["mae_lux"] == pytest.approx(dense, rel=2e-3)
    assert M._abs_integral(np.array([[1.0, -1.0, 0.0]]), np.array([1.0]))[0] == \
        pytest.approx(1 / 3)        # |f| of a linear field through 0: 2 x (1/2 x 1/3)


def test_shade_targets_are_reported_apart():
    s = _floor()
    x = s.vertices[:, 0]
    target = np.where(x <= 2.0 + 1e-9, 300.0, 0.0)
    lum = [3.5, 2.0, H]
    achieved = _render(s, lum, F)
    m = room_metrics(s, target, achieved)
    shade_faces = np.all(target[s.faces] == 0, axis=1)
    assert m["n_shade_faces"] == int(shade_faces.sum()) > 0
    assert m["shade_area_m2"] == pytest.approx(s.face_areas[shade_faces].sum())
    assert m["shade_max_lux"] == pytest.approx(F / (np.pi * H ** 2), rel=1e-5)
    assert m["shade_max_where"] == "floor at (3.50, 2.00) m"
    assert 0 < m["shade_mean_lux"] < m["shade_max_lux"]
    # Em and U0 over the lit faces only (the lit/shade edge does not drag them down)
    assert m["target_em"] == pytest.approx(300.0) and m["target_u0"] == pytest.approx(1.0)
    assert m["n_transition_faces"] > 0
    # deviation images: shade points in % of a reference (the room's mean target)
    d = R.relative_deviation(target, achieved, 300.0)
    sh = target == 0
    assert np.allclose(d[sh], achieved[sh] / 300.0)
    assert np.allclose(d[~sh], achieved[~sh] / 300.0 - 1.0)
    # a spot's rim (targets of a few lux): judged against 10 % of the reference, not
    # against its own few lux, so that spill light there is no +1000 % ring
    rim = np.array([300.0, 60.0, 30.0, 5.0, 0.5, 0.0, np.nan])
    got = np.array([300.0, 90.0, 60.0, 35.0, 30.5, 15.0, 80.0])
    d = R.relative_deviation(rim, got, 300.0)
    np.testing.assert_allclose(d[:6], [0.0, 0.5, 1.0, 1.0, 1.0, 0.05])
    assert np.isnan(d[6])
    # no reference: plain (E - T) / T
    np.testing.assert_allclose(R.relative_deviation(rim[:5], got[:5], np.nan),
                               [0.0, 0.5, 1.0, 6.0, 60.0])
    # light deep in the shade changes the shade metrics only
    deep = x > 2.2
    brighter = achieved.copy()
    brighter[deep] += 100.0
    m2 = room_metrics(s, target, brighter)
    for k in ("target_em", "em", "rmse_pct", "emin", "max_dev_lux"):
        assert m2[k] == m[k], k
    assert m2["shade_max_lux"] == pytest.approx(m["shade_max_lux"] + 100.0)
    # a set with shade only has no lit metrics
    m3 = room_metrics(s, target, achieved, faces=np.flatnonzero(shade_faces))
    assert np.isnan(m3["em"]) and m3["n_lit_faces"] == 0 and m3["shade_max_lux"] > 0


def test_faces_without_target_are_ignored_and_subsets_work():
    s = _floor()
    target = _analytic(s.vertices, [2.0, 2.0, H], F)
    target[s.vertices[:, 1] > 3.0 + 1e-9] = np.nan
    achieved = target * 1.2
    has = np.all(np.isfinite(target[s.faces]), axis=1)
    m = room_metrics(s, target, achieved)
    assert m["n_faces"] == int(has.sum()) and m["area_m2"] == pytest.approx(12.0)
    assert m["bias_pct"] == pytest.approx(20.0) and m["mae_pct"] == pytest.approx(20.0)
    sub = np.flatnonzero(s.face_centroids[:, 0] < 1.0)
    ms = room_metrics(s, target, achieved, faces=sub)
    assert ms["area_m2"] == pytest.approx(3.0)
    assert ms["target_em"] < m["target_em"]               # the edge strip is darker
    with pytest.raises(SceneError, match="vertices"):
        room_metrics(s, target[:-1], achieved)
    bad = achieved.copy()
    bad[0] = np.nan
    with pytest.raises(SceneError, match="achieved"):
        room_metrics(s, target, bad)


def test_walls_are_described_by_where_they_stand():
    s = g.box_room((5, 4, 3), cell=0.5)
    words = sorted(describe_plane(p, 0.0) for p in s.planes)
    assert words == ["ceiling", "floor", "wall x = 0.00 m (facing +x)",
                     "wall x = 5.00 m (facing -x)", "wall y = 0.00 m (facing +y)",
                     "wall y = 4.00 m (facing -y)"]
    wall = [p for p in s.planes if p.normal[0] < -0.9][0]
    assert R.describe_point(s, wall, [5.0, 1.5, 2.0]) == \
        "wall x = 5.00 m (facing -x) at y = 1.50 m, 2.00 m above the floor"


# ---------------------------------------------------------------------------- images
def test_colour_scales():
    rgb = im.false_colour(np.array([0.0, 50.0, 100.0, 250.0, np.nan]), 0, 100)
    assert tuple(rgb[0]) == (68, 1, 84) and tuple(rgb[2]) == (253, 231, 37)
    assert tuple(rgb[3]) == (253, 231, 37)                    # above the scale: clipped
    assert tuple(rgb[4]) == im.NAN_GREY
    assert tuple(im.false_colour(np.array([0.0]), 0, 100, shade=True)[0]) == im.SHADE_BLACK
    lum = rgb[:3].astype(float) @ [0.299, 0.587, 0.114]
    assert np.all(np.diff(lum) > 0)                            # brighter = lighter
    d = im.diverging(np.array([-1.0, -0.25, 0.0, 0.25, 1.0, np.nan]), 0.5)
    assert d[0, 2] > d[0, 0] and d[4, 0] > d[4, 2]            # blue dark, red bright
    assert np.all(d[2] > 240)                                   # white on target
    assert d[1, 2] > d[1, 0] and d[3, 0] > d[3, 2]
    assert tuple(d[5]) == im.NAN_GREY
    assert [im.nice_max(v) for v in (0.7, 180, 250, 1234)] == [0.8, 200, 250, 1500]
    # the report's figures use matplotlib's viridis: the same colours at the ends
    cmap = FG.lux_cmap()
    assert np.allclose(np.array(cmap(0.0)[:3]) * 255, (68, 1, 84), atol=1)
    assert np.allclose(np.array(cmap(1.0)[:3]) * 255, (253, 231, 37), atol=1)
    assert cmap(1.5) == cmap(1.0)                             # above the scale: top colour
    # and the deviation colours are the report's deviation figures' (matplotlib's RdBu_r)
    t = np.clip(0.5 + np.array([-1.0, -0.25, 0.0, 0.25, 1.0]), 0.0, 1.0)
    assert np.allclose(d[:5] / 255.0, FG.deviation_cmap()(t)[:, :3], atol=0.5 / 255)


def test_unfolded_box_net_geometry_and_hot_spot():
    s = g.box_room((6, 4, 3), cell=0.25, reflectance=0.0)
    lum = [4.5, 1.0, 3.0]
    E = _render(s, lum, F)
    r = im.unfolded_raster(s, 0, metres_per_pixel=0.05)
    assert r.layout == "box net"
    # net: 3 + 6 + 3 m wide; wall + floor + wall + ceiling = 3 + 4 + 3 + 4 m tall; 10 px
    # margins
    assert r.shape == (round(14 / 0.05) + 20, round(12 / 0.05) + 20)
    kind = {p.index: describe_plane(p, 0.0) for p in s.planes}

    def at(x, y):                       # net coordinates (m) -> what the pixel shows
        c = int((x - r.x0) / r.metres_per_pixel)
        rr = int((r.y1 - y) / r.metres_per_pixel)
        return kind.get(int(r.plane[rr, c]), "background")

    assert at(3.0, 2.0) == "floor"
    assert at(3.0, -1.5) == "wall y = 0.00 m (facing +y)"      # folded out below
    assert at(3.0, 5.5) == "wall y = 4.00 m (facing -y)"       # and above
    assert at(-1.5, 2.0) == "wall x = 0.00 m (facing +x)"
    assert at(7.5, 2.0) == "wall x = 6.00 m (facing -x)"
    assert at(3.0, 9.0) == "ceiling"                            # beyond the top wall
    assert at(-1.5, -1.5) == "background"
    # every plane drawn once, at its true area
    for p in s.planes:
        assert (r.plane == p.index).sum() * 0.05 ** 2 == pytest.approx(p.area, rel=0.03)
    # the floor pixel under the luminaire is the brightest floor pixel, in the top colour
    floor = [p for p in s.planes if p.normal[2] > 0.9][0]
    c, rr = r.pixel_of(np.array([[lum[0], lum[1], 0.0]]), floor.index)[0]
    vals = r.sample(E)
    on_floor = r.plane == floor.index
    top = float(np.nanmax(vals[on_floor]))          # walls near the luminaire are brighter
    img = im.false_colour(vals, 0, top)
    hot = img[int(rr), int(c)]
    assert hot[0] > 200 and hot[1] > 200 and hot[2] < 90         # yellow
    assert vals[int(rr), int(c)] >= top * 0.99
    cold = img[int(r.pixel_of(np.array([[0.2, 3.8, 0.0]]), floor.index)[0][1]),
               int(r.pixel_of(np.array([[0.2, 3.8, 0.0]]), floor.index)[0][0])]
    assert cold[2] > cold[1] and cold[0] < 100                  # dark blue-purple
    # the sampled field is the linear interpolation of the vertex values
    assert vals[int(rr), int(c)] == pytest.approx(F / (np.pi * 3.0 ** 2), rel=0.03)


@pytest.mark.parametrize("make", [
    lambda: g.pillar_room((6, 4, 3), cell=0.25),
    lambda: g.l_room((6, 5, 3), cut=(3, 2.5), cell=0.25),
    lambda: g.sloped_room((6, 4), cell=0.25)])
def test_unfolded_layout_never_overlaps_planes(make):
    s = make()
    r = im.unfolded_raster(s, 0, metres_per_pixel=0.05)
    for p in s.planes:
        assert (r.plane == p.index).sum() * 0.05 ** 2 == pytest.approx(p.area, rel=0.06), \
            describe_plane(p)


def test_plan_view_shows_the_work_plane_over_the_floor():
    s, virt = _room_with_work_plane()
    r = im.plan_raster(s, 0, metres_per_pixel=0.05)
    wp = [p for p in s.planes if p.is_virtual][0]
    floor = [p for p in s.planes if p.normal[2] > 0.9 and not p.is_virtual][0]
    mid = r.pixel_of(np.array([[3.0, 2.0, 0.8]]), wp.index)[0].astype(int)
    edge = r.pixel_of(np.array([[0.2, 0.2, 0.0]]), floor.index)[0].astype(int)
    assert r.plane[mid[1], mid[0]] == wp.index
    assert r.plane[edge[1], edge[0]] == floor.index


def test_png_and_exr_round_trip_and_refuse_bad_input(tmp_path):
    grey = (np.arange(12, dtype=np.uint8) * 20).reshape(3, 4)
    p = im.save_png(str(tmp_path / "g.png"), grey)
    back = im.read_image(p)
    assert back.shape == (3, 4, 1) and np.array_equal(np.round(back[..., 0] * 255), grey)
    rgb = np.zeros((5, 7, 3))
    rgb[2, 3] = (1.0, 0.5, 0.0)
    back = im.read_image(im.save_png(str(tmp_path / "c.png"), rgb))
    assert np.array_equal(np.round(back[2, 3] * 255), [255, 128, 0])
    vals = np.array([[1.5, np.nan], [1e5, 0.0]])
    e = im.save_exr(str(tmp_path / "v.exr"), np.stack([vals, -vals], 2), ["target", "d"])
    back = im.read_image(e)
    import OpenImageIO as oiio
    names = list(oiio.ImageInput.open(e).spec().channelnames)
    assert sorted(names) == ["d", "target"]       # EXR stores channels sorted by name
    assert back.shape == (2, 2, 2)
    assert np.allclose(back[..., names.index("target")], vals, equal_nan=True)
    assert np.allclose(back[..., names.index("d")], -vals, equal_nan=True)
    h = im.read_image(im.save_exr(str(tmp_path / "h.exr"), vals[:1], half=True))
    assert h[0, 0, 0] == 1.5 and np.isnan(h[0, 1, 0])
    assert oiio.ImageInput.open(str(tmp_path / "h.exr")).spec().format == oiio.HALF
    with pytest.raises(ValueError):
        im.save_png(str(tmp_path / "bad.png"), np.zeros((4, 4, 7), np.uint8))
    with pytest.raises(ValueError):
        im.save_png(str(tmp_path / "bad.png"), np.full((4, 4), 300))
    assert sorted(os.listdir(tmp_path)) == ["c.png", "g.png", "h.exr", "v.exr"]


# ---------------------------------------------------------------------------- the report
def _room_with_work_plane(cell=0.25):
    mb = g.MeshBuilder(cell)
    g.add_prism_room(mb, [(0, 0), (6, 0), (6, 4), (0, 4)], [(0, 0, 6, 4)], height=3.0,
                     reflectance=0.0)
    n_room = sum(len(f) for f in mb._f)
    mb.quad([0.5, 0.5, 0.8], [5.5, 0.5, 0.8], [5.5, 3.5, 0.8], [0.5, 3.5, 0.8],
            inward=[0, 0, 1], reflectance=0.0)
    virt = np.zeros(sum(len(f) for f in mb._f), bool)
    virt[n_room:] = True
    return mb.scene(face_virtual=virt), virt


def _report_case():
    s, _ = _room_with_work_plane()
    lums = [Luminaire([1.5, 2.0, 3.0], [0, 0, -1], 4000.0, room=0, score=0.7),
            Luminaire([4.5, 2.0, 3.0], [0, 0, -1], 4000.0, room=0, score=0.4)]
    E = render(s, lums, interreflection=False, backend="numpy")
    vp = s.vertex_plane
    target = np.full(len(s.vertices), np.nan)
    wp = [p for p in s.planes if p.is_virtual][0]
    target[vp == wp.index] = 400.0
    screen = [p for p in s.planes if p.normal[0] < -0.9][0]        # wall x = 6 stays dark
    on = (vp == screen.index) & (s.vertices[:, 1] > 1) & (s.vertices[:, 1] < 3) \
        & (s.vertices[:, 2] > 1) & (s.vertices[:, 2] < 2.5)
    target[on] = 0.0
    return s, lums, target, E


def test_report_html_csv_json_and_images(tmp_path):
    s, lums, target, E = _report_case()
    out = tmp_path / "rep"
    evil = '<script>alert("x")</script> & co'
    desk = np.flatnonzero((s.face_centroids[:, 2] > 0.7) & (s.face_centroids[:, 0] < 2.0))
    paths = build_report(s, target, E, lums, str(out), room_names=[evil],
                         title="Run <1>", extra={"interreflection": False, "<b>": "<i>"},
                         groups=[(0, "desk <A>", desk)])
    page = open(paths.html, encoding="utf-8").read()
    assert "<script" not in page and "&lt;b&gt;" in page
    from markupsafe import escape
    assert "&lt;script&gt;alert(" in page and str(escape(evil)) in page
    assert "Run &lt;1&gt;" in page and "&lt;i&gt;" in page
    m = paths.metrics[0]
    parts = {p["part"]: p["metrics"] for p in paths.rooms[0]["parts"]}
    wp = parts["work plane"]
    assert wp["target_em"] == pytest.approx(400.0)
    for v in (R.fmt_lux(m["em"]), R.fmt_lux(wp["em"]), R.fmt_pct(m["rmse_pct"]),
              R.fmt_ratio(wp["u0"]), R.fmt_lux(m["shade_max_lux"])):
        assert v in page
    assert m["shade_max_lux"] > 0 and "wall x = 6.00 m" in m["shade_max_where"]
    assert "data:image/png;base64," in page                     # self-contained
    # files
    for f in ("room0_plan.png", "room0_surfaces.png", "room0_deviation.png",
              "room0_unfolded.exr", "room0_plan.exr", "rooms.csv", "surfaces.csv",
              "luminaires.csv", "metrics.json", "index.html", "report.pdf"):
        assert (out / f).is_file(), f
    assert not [f for f in os.listdir(out) if f.startswith(".")]
    # rooms.csv: one row per room, same numbers as the metrics
    rows = list(csv.DictReader(open(paths.rooms_csv, encoding="utf-8")))
    assert len(rows) == 1 and rows[0]["name"] == evil
    for k in ("target_em", "em", "emin", "u0", "rmse_pct", "mae_pct", "max_dev_lux",
              "shade_max_lux", "within_tol_pct", "area_m2"):
        assert float(rows[0][k]) == m[k], k
    assert [float(rows[0][f"max_dev_{a}_m"]) for a in "xyz"] == m["max_dev_point"]
    assert rows[0]["max_dev_where"] == m["max_dev_where"]
    assert rows[0]["target_u0"] == "" or float(rows[0]["target_u0"]) == m["target_u0"]
    surf = list(csv.DictReader(open(paths.surfaces_csv, encoding="utf-8")))
    wrow = [r for r in surf if r["part"] == "work plane"][0]
    assert float(wrow["em"]) == wp["em"] and float(wrow["u0"]) == wp["u0"]
    drow = [r for r in surf if r["part"] == "desk <A>"][0]
    assert float(drow["area_m2"]) == pytest.approx(1.5 * 3.0)     # x 0.5..2, y 0.5..3.5
    assert float(drow["em"]) == parts["desk <A>"]["em"]
    assert "desk &lt;A&gt;" in page
    lum = list(csv.DictReader(open(paths.luminaires_csv, encoding="utf-8")))
    assert [float(r["x_m"]) for r in lum] == [1.5, 4.5]
    assert [float(r["flux_lm"]) for r in lum] == [4000.0, 4000.0]
    assert float(lum[1]["score"]) == 0.4 and lum[0]["room_name"] == evil
    # the page: one luminaire table for one room, facing in words, no internal score
    assert page.count("<table class=\"lums\">") == 1 and "All luminaires" not in page
    assert "<td>down</td>" in page and "score" not in page and "-0.00" not in page
    data = json.load(open(paths.metrics_json, encoding="utf-8"))
    assert data["rooms"][0]["metrics"]["em"] == m["em"]
    assert data["scale"]["rooms"]["0"] == paths.scale["rooms"][0] >= 400
    # a cover, a page per room, an appendix; the room's name on its page and figures
    assert page.count('<section class="room"') == 1 and "Technical appendix" in page
    assert page.count("<figure") == 3
    png = im.read_image(out / "room0_plan.png")
    assert png.shape[2] in (3, 4) and png.shape[1] > 900        # page width at 150 dpi


def test_value_grid_and_scale_of_a_room(tmp_path):
    s = g.box_room((4, 3, 2.5), cell=0.25, reflectance=0.0)
    lums = [Luminaire([1.0, 1.0, 2.5], [0, 0, -1], 2000.0)]
    E = render(s, lums, interreflection=False, backend="numpy")
    paths = build_report(s, E, E, lums, str(tmp_path), write_exr=False, pdf=False)
    # one scale per room: a round top above the highest target
    assert paths.scale["rooms"][0] == paths.rooms[0]["lux_max"] == im.nice_max(E.max())
    # the value grid: EN 12464-1 spacing p = 0.2 * 5^log10(4) = 0.527 m -> 8 x 6 cells
    # of 0.5 m, values at the cell centres close to the analytic illuminance
    floor = [p for p in s.planes if p.normal[2] > 0.9][0]
    pts, vals, cell = RF.value_grid(s, floor, E)
    assert len(pts) == 48 and cell == pytest.approx([0.5, 0.5])
    assert pts.min(axis=0) == pytest.approx([0.25, 0.25])
    exact = _analytic(np.c_[pts, np.zeros(len(pts))], [1.0, 1.0, 2.5], 2000.0)
    assert vals == pytest.approx(exact, rel=0.02)
    # a perfect match is on target everywhere
    page = open(paths.html, encoding="utf-8").read()
    assert "equals the target everywhere" in page
    # (the ceiling gets no direct light: a 0 lx target there, kept dark)
    v = paths.rooms[0]["verdict"]
    assert (v["em"], v["u0"], v["shade"], v["ok"]) == (True, True, True, True)


def test_verdict_judges_em_u0_and_shade():
    base = {"target_em": 500.0, "em": 500.0, "target_u0": 0.5, "u0": 0.5,
            "n_shade_faces": 0, "shade_max_lux": float("nan")}
    assert M.verdict(base)["ok"] is True
    assert M.verdict(dict(base, em=390.0))["em"] is False           # -22 %: out of +-20 %
    assert M.verdict(dict(base, em=610.0))["em"] is False
    assert M.verdict(dict(base, u0=0.41))["u0"] is True             # >= 0.8 x 0.5
    assert M.verdict(dict(base, u0=0.39))["ok"] is False
    # a uniform target asks for U0 0.7 (EN 12464-1's highest class), not 0.8
    uni = dict(base, target_u0=1.0, u0=0.72)
    assert M.verdict(uni)["u0"] is True and M.verdict(uni)["u0_required"] == 0.7
    assert M.verdict(dict(uni, u0=0.69))["u0"] is False
    dark = dict(base, n_shade_faces=3, shade_max_lux=120.0)
    assert M.verdict(dark)["shade"] is False and M.verdict(dark)["ok"] is False
    assert M.verdict(dict(dark, shade_max_lux=90.0))["shade"] is True
    none = {"target_em": float("nan"), "em": float("nan"), "target_u0": float("nan"),
            "u0": float("nan"), "n_shade_faces": 0}
    assert M.verdict(none)["ok"] is None


def test_iso_levels_are_round_and_include_the_target():
    assert FG.iso_levels(np.array([120.0, 480.0])) == [200.0, 300.0, 400.0]
    assert FG.iso_levels(np.array([120.0, 480.0]), 350.0) == [200.0, 300.0, 350.0, 400.0]
    # a level within 30 % of a step of the target gives way to it
    assert FG.iso_levels(np.array([120.0, 480.0]), 320.0) == [200.0, 320.0, 400.0]
    assert FG.iso_levels(np.array([5.0, 5.0])) == []


@pytest.mark.slow
def test_report_is_atomic(tmp_path, monkeypatch):
    s = g.box_room((4, 3, 2.5), cell=0.5, reflectance=0.0)
    lums = [Luminaire([2.0, 1.5, 2.5], [0, 0, -1], 2000.0)]
    E = render(s, lums, interreflection=False, backend="numpy")
    out = tmp_path / "rep"
    build_report(s, E, E, lums, str(out))
    before = {f: open(out / f, "rb").read() for f in os.listdir(out)}
    calls = []
    real = im.save_exr

    def failing(path, *a, **kw):
        calls.append(path)
        if len(calls) == 2:
            raise OSError("disk full")
        return real(path, *a, **kw)

    monkeypatch.setattr(im, "save_exr", failing)
    with pytest.raises(OSError, match="disk full"):
        build_report(s, E, E * 2, lums, str(out))
    after = {f: open(out / f, "rb").read() for f in os.listdir(out)}
    assert after == before                     # nothing replaced, nothing left behind
    fresh = tmp_path / "fresh"
    calls.clear()
    with pytest.raises(OSError):
        build_report(s, E, E * 2, lums, str(fresh))
    assert os.listdir(fresh) == []
    # a failing text write (after all images) also leaves the old report
    monkeypatch.setattr(im, "save_exr", real)

    orig = R._Staging.text

    def broken(self, name, text):
        if name == "index.html":
            raise OSError("no space")
        return orig(self, name, text)

    monkeypatch.setattr(R._Staging, "text", broken)
    with pytest.raises(OSError, match="no space"):
        build_report(s, E, E * 3, lums, str(out))
    assert {f: open(out / f, "rb").read() for f in os.listdir(out)} == before


def test_bad_input_is_refused(tmp_path):
    s = g.box_room((4, 3, 2.5), cell=0.5)
    E = np.zeros(len(s.vertices))
    with pytest.raises(SceneError, match="vertices"):
        build_report(s, E[:-1], E, [], str(tmp_path / "a"))
    with pytest.raises(ValueError, match="lux_range"):
        build_report(s, E, E, [], str(tmp_path / "b"), lux_range=(10, 5))


def test_facing_is_said_in_words_and_never_minus_zero():
    assert R.facing_text([0.0, -0.0, -1.0]) == "down"
    assert R.facing_text([1e-9, 0.0, 2.0]) == "up"
    assert R.facing_text([-1.0, 0.0, 0.0]) == "-x"
    assert R.facing_text([-0.001, 0.6, -0.8]) == "+0.00, +0.60, -0.80"


def test_light_next_to_a_luminaire_is_drawn_at_its_true_size():
    """The octagonal saturated blob (FZK-Haus, Schlafzimmer): a wall luminaire 0.2 m below
    the ceiling lights the ceiling with a peak between the vertices of a coarse mesh. The
    pictures' display mesh splits such faces and takes the exact direct light there: the
    area shown above 1000 lx matches the exact field's; the raw vertex field shows none."""
    from invrad_wb.core.forward.render import scene_bvh
    from invrad_wb.core.forward.direct import direct_illuminance_numpy
    from invrad_wb.core.geometry.raster import locate_points
    s = g.box_room((4, 3, 2.5), cell=0.5, reflectance=0.0)
    lum = Luminaire([3.98, 1.5, 2.3], [-1, 0, 0], 2000.0, room=0)
    E = render(s, [lum], interreflection=False, backend="numpy")
    ceiling = [p for p in s.planes if p.normal[2] < -0.9][0]
    xy = np.stack(np.meshgrid(np.linspace(2.5, 3.99, 150), np.linspace(0.5, 2.5, 200)),
                  -1).reshape(-1, 2)
    exact = direct_illuminance_numpy(np.c_[xy, np.full(len(xy), 2.5)],
                                     np.tile([0, 0, -1.0], (len(xy), 1)), [lum],
                                     bvh=scene_bvh(s))

    def shown(mesh):
        tri = mesh.tri[mesh.plane == ceiling.index]
        t, b = locate_points(mesh.xyz[tri][:, :, :2], xy)
        assert (t >= 0).all()
        return np.einsum("kj,kj->k", b, mesh.achieved[tri][t])

    raw = RF.display_mesh(s, 0, E, E, 1000.0, np.nan)
    fine = RF.display_mesh(s, 0, E, E, 1000.0, np.nan, [lum], backend="numpy")
    assert raw.n_split == 0 and fine.n_split > 0
    B = exact >= 1000.0
    assert B.sum() > 1000                                     # a real bright patch
    assert (shown(raw) >= 1000.0).sum() == 0                   # the vertices miss it
    A = shown(fine) >= 1000.0
    assert (A & B).sum() / (A | B).sum() > 0.9                 # its true shape and size
    # the scene's own vertices keep their values (the metrics' field is untouched)
    verts = np.unique(s.faces[s.face_room == 0])
    assert np.array_equal(fine.achieved[:len(verts)], E[verts])


def _two_rooms_one_wall():
    """Two rooms sharing a zero-thickness wall at x = 4 (as IFC spaces of an open kitchen
    and living room meet: back-to-back boundary faces), a downlight in room 1."""
    s, _ = g.floor_of_rooms(rooms=((4.0, 3.0), (4.0, 3.0)), wall=0.0, cell=0.25,
                            reflectance=0.0)
    return s, Luminaire([6.0, 1.5, 2.9], [0, 0, -1], 3000.0, room=1)


def test_room_pictures_hold_only_their_own_room():
    """The saw-tooth strip between Küche and Wohnen: each room's plan is drawn from its own
    faces only, so two rooms' pictures never cover the same floor."""
    from invrad_wb.core.geometry.raster import locate_points
    s, lum = _two_rooms_one_wall()
    E = render(s, [lum], interreflection=False, backend="numpy")
    xy = np.stack(np.meshgrid(np.linspace(0.013, 7.987, 300), np.linspace(0.013, 2.987, 101)),
                  -1).reshape(-1, 2)
    covered = []
    for r in (0, 1):
        mesh = RF.display_mesh(s, r, E, E, 100.0, np.nan, [lum], backend="numpy")
        ups = [p.index for p in s.planes if p.room == r and p.normal[2] > 0.9]
        tri = mesh.tri[np.isin(mesh.plane, ups)]
        covered.append(locate_points(mesh.xyz[tri][:, :, :2], xy)[0] >= 0)
    assert not (covered[0] & covered[1]).any()
    assert (covered[0] | covered[1]).all()                    # and together the whole floor


def test_light_does_not_leak_through_a_shared_wall():
    # a vertex on a zero-thickness wall shared by two rooms lies in the other room's
    # boundary plane (the shadow ray's hit is within RAY_EPS of its end): it took the other
    # room's direct light (the saw-tooth strip along Kueche/Wohnen on FZK-Haus) until a
    # luminaire with a room lit only its room (render._direct_by_room)
    s, lum = _two_rooms_one_wall()
    assert lum.room is not None
    E = render(s, [lum], interreflection=False, backend="numpy")
    floor = [p for p in s.planes if p.room == 0 and p.normal[2] > 0.9][0]
    v = np.unique(s.faces[floor.faces])
    x = s.vertices[v, 0]
    assert E[v][np.abs(x - 3.75) < 1e-9].max() == 0.0         # a cell inside: dark
    assert E[v][np.abs(x - 4.0) < 1e-9].max() == 0.0          # on the wall: was 52 lx


def test_an_open_border_is_named_and_not_drawn_as_a_wall():
    """A room's side that opens into another room (virtual, no target, no surface) is an
    'open border', not a 'work plane', and the unfolded net leaves it out."""
    from invrad_wb.core.model.scene import Scene
    s = g.box_room((6, 4, 3), cell=0.5, reflectance=0.5)
    side = np.abs(s.face_centroids[:, 0] - 6.0) < 1e-9            # the wall x = 6
    o = Scene(s.vertices, s.faces, face_room=s.face_room, face_reflectance=s.face_reflectance,
              face_virtual=side)
    (open_plane,) = [p for p in o.planes if p.is_virtual]
    assert describe_plane(open_plane, 0.0) == "open border"
    r = im.unfolded_raster(o, 0, metres_per_pixel=0.05)
    assert not np.any(r.plane == open_plane.index)
    drawn = {int(k) for k in np.unique(r.plane) if k >= 0}
    assert drawn == {p.index for p in o.planes if not p.is_virtual}
