"""Verification report: metrics on analytic cases, images, HTML/CSV, atomic output."""
import csv
import os

import numpy as np
import pytest

from invrad_wb.core import generate as g
from invrad_wb.core import images as im
from invrad_wb.core.luminaires import Luminaire
from invrad_wb.core.render import render
from invrad_wb.core.report import build_report, room_metrics, describe_plane


def _room():
    s = g.box_room((4, 3, 2.5), cell=0.25, reflectance=0.0)
    lums = [Luminaire([2.0, 1.5, 2.5], [0, 0, -1], 2000.0)]
    lux = render(s, lums, interreflection=False, backend="numpy")
    return s, lums, lux


def test_metrics_of_a_perfect_match():
    s, lums, lux = _room()
    floor = [p for p in s.planes if p.normal[2] > 0.9][0]
    tgt = np.full(len(s.vertices), np.nan)
    fv = np.unique(s.faces[floor.faces])
    tgt[fv] = lux[fv]
    m = room_metrics(s, tgt, lux)
    assert m["n_faces"] == len(floor.faces)
    assert m["rmse_pct"] == pytest.approx(0, abs=1e-9)
    assert m["em"] == pytest.approx(m["target_em"])
    # the brightest floor face is right below the luminaire: E ~ F / (pi h^2)
    assert m["emax"] == pytest.approx(2000 / (np.pi * 2.5 ** 2), rel=0.03)
    assert m["u0"] == pytest.approx(m["emin"] / m["em"])
    assert "floor" in describe_plane(floor)


def test_largest_deviation_is_found_where_it_is():
    s, lums, lux = _room()
    wrong = render(s, [Luminaire([3.5, 2.5, 2.5], [0, 0, -1], 2000.0)], interreflection=False,
                   backend="numpy")
    floor = [p for p in s.planes if p.normal[2] > 0.9][0]
    m = room_metrics(s, lux, wrong, faces=floor.faces)
    # the largest deviation is either too bright under the misplaced luminaire or too
    # dark under the right place, and the sign says which
    where = np.array(m["max_dev_point"][:2])
    spot = [3.5, 2.5] if m["max_dev_lux"] > 0 else [2.0, 1.5]
    assert np.linalg.norm(where - spot) < 0.6
    assert "floor at x" in m["max_dev_where"]
    assert m["em"] < m["target_em"]          # light lost into the corner walls


def test_shade_metrics():
    s, lums, lux = _room()
    ceiling = [p for p in s.planes if p.normal[2] < -0.9][0]
    tgt = np.full(len(s.vertices), np.nan)
    tgt[np.unique(s.faces[ceiling.faces])] = 0.0
    m = room_metrics(s, tgt, lux + 7.0)
    assert m["shade_max_lux"] == pytest.approx(7.0)
    assert np.isnan(m["em"])


def test_false_colour_and_diverging_scales():
    rgb = im.false_colour(np.array([0.0, 50.0, 100.0, np.nan]), 0, 100)
    assert tuple(rgb[0]) == (68, 1, 84) and tuple(rgb[2]) == (253, 231, 37)
    assert tuple(rgb[3]) == im.NAN_GREY
    d = im.diverging(np.array([-1.0, 0.0, 1.0]), 0.5)
    assert d[0, 2] > d[0, 0] and d[2, 0] > d[2, 2] and np.all(d[1] > 240)


def test_report_files_images_and_escaping(tmp_path):
    s, lums, lux = _room()
    out = tmp_path / "rep"
    paths = build_report(s, lux, lux * 1.1, lums, str(out),
                         room_names=["<script>alert(1)</script>"])
    page = open(paths.html, encoding="utf-8").read()
    assert "&lt;script&gt;" in page and "<script>" not in page
    for f in ("room0_target.png", "room0_achieved.png", "room0_deviation.png",
              "room0_plan_achieved.png", "rooms.csv", "luminaires.csv"):
        assert (out / f).exists(), f
    rows = list(csv.DictReader(open(paths.rooms_csv, encoding="utf-8")))
    assert len(rows) == 1
    assert float(rows[0]["mae_pct"]) == pytest.approx(10.0, rel=1e-6)    # +10 % everywhere
    assert float(rows[0]["max_dev_pct"]) == pytest.approx(10.0, rel=1e-6)
    assert float(rows[0]["em"]) == pytest.approx(1.1 * float(rows[0]["target_em"]))
    lum = list(csv.DictReader(open(paths.luminaires_csv, encoding="utf-8")))
    assert float(lum[0]["z_m"]) == pytest.approx(2.5)
    # the plan view shows the hot spot under the luminaire in the hot colour
    import OpenImageIO as oiio
    buf = oiio.ImageBuf(str(out / "room0_plan_achieved.png"))
    px = buf.get_pixels(oiio.UINT8)
    h, w, _ = px.shape
    centre = px[h // 2, w // 2 - 20]        # beside the ring drawn at the luminaire
    corner = px[16, 16]
    assert centre[1] > corner[1]            # viridis: brighter = more green/yellow


def test_report_writes_are_atomic(tmp_path, monkeypatch):
    s, lums, lux = _room()
    out = tmp_path / "rep"
    build_report(s, lux, lux, lums, str(out))
    before = open(out / "index.html", encoding="utf-8").read()
    import invrad_wb.core.report as R

    def broken(*a, **k):
        raise OSError("disk full")
    monkeypatch.setattr(R, "atomic_write_text", broken)
    with pytest.raises(OSError):
        build_report(s, lux, lux * 2, lums, str(out))
    assert open(out / "index.html", encoding="utf-8").read() == before
    assert not [f for f in os.listdir(out) if f.startswith(".invrad-")]
