"""The background area of a task area (EN 12464-1:2021 4.3.3): a band of 3 m beyond the
immediate surroundings, 1/3 of their Em, U0 0.10; its grid, its requirement (spec key,
default, null), and its verdict against an analytic illuminance."""
import math

import numpy as np
import pytest

from invrad_wb.core.synthetic import generate as g

CAT = [{"name": "DL-3500", "flux_lm": 3500, "watts": 26.0, "dimming": [0.1, 1.0]}]


def _spec(room, cat=CAT):
    from invrad_wb.core.design.spec import spec_from_dict
    return spec_from_dict({"maintenance_factor": 0.8, "catalogue": cat, "rooms": {"0": room}})


def _rect_band_area(w, d, a0, a1):
    """Area of the points of a w x d rectangle whose distance to its sides is in [a0, a1):
    the rectangles shrunk by a0 and by a1, one less the other."""
    shrunk = lambda a: max(w - 2 * a, 0.0) * max(d - 2 * a, 0.0)     # noqa: E731
    return shrunk(a0) - shrunk(a1)


def _rect_distance(xy, w, d):
    x, y = xy[:, 0], xy[:, 1]
    return np.minimum.reduce([x, w - x, y, d - y])


def test_band_of_a_rectangle_is_3_m_beyond_the_surroundings_or_what_remains():
    from invrad_wb.core.design.background import BAND_M, background_grid, band_limits
    from invrad_wb.core.design.room import DesignRoom
    dr = DesignRoom(g.box_room(size=(12.0, 9.0, 2.8), cell=1.0), 0)
    # a task area 4 m in from the walls: surroundings 3.5-4 m, background 0.5-3.5 m
    assert band_limits(4.0) == (0.5, 3.5) and BAND_M == 3.0
    pts, up, w = background_grid(dr, 0.75, 4.0)
    d = _rect_distance(pts[:, :2], 12.0, 9.0)
    assert np.all((d >= 0.5 - 1e-9) & (d < 3.5)) and np.all(up[:, 2] == 1.0)
    assert np.allclose(pts[:, 2], 0.75)
    assert w.sum() == pytest.approx(_rect_band_area(12, 9, 0.5, 3.5), rel=0.01)   # 78 m2
    # two rows at least across the band, every part of it covered: a fine raster of the
    # band lies within a cell of a grid point
    x, y = np.meshgrid(np.linspace(0.01, 11.99, 121), np.linspace(0.01, 8.99, 91))
    fine = np.c_[x.ravel(), y.ravel()]
    fd = _rect_distance(fine, 12.0, 9.0)
    band = fine[(fd >= 0.5) & (fd < 3.5)]
    near = np.min(np.linalg.norm(band[:, None, :] - pts[None, :, :2], axis=2), axis=1)
    assert near.max() < 1.5 * math.sqrt(w.max())
    # a task area 2 m in: the room ends 1.5 m beyond the surroundings; what remains
    pts, _, w = background_grid(dr, 0.75, 2.0)
    assert w.sum() == pytest.approx(_rect_band_area(12, 9, 0.0, 1.5), rel=0.01)  # 54 m2
    assert np.all(_rect_distance(pts[:, :2], 12.0, 9.0) < 1.5)
    # the task area of a whole room (0.5 m border: the surroundings fill it) or with no
    # border: nothing remains
    assert background_grid(dr, 0.75, 0.5) is None
    assert background_grid(dr, 0.75, 0.0) is None


def test_band_of_an_l_shaped_room_rounds_its_inner_corner_and_avoids_a_column():
    from invrad_wb.core.design.background import background_grid
    from invrad_wb.core.design.room import DesignRoom
    # the L: 12 x 9 less its corner [6, 12] x [4.5, 9]; a task area 2.5 m in, the band
    # 0-2 m from the walls (what remains). The part of the L 2 m or more from its walls:
    # the box [2, 10] x [2, 7] less the notch x > 4, y > 2.5, plus, in the notch's corner
    # square [4, 6] x [2.5, 4.5], what lies 2 m or more from the inner corner (6, 4.5)
    dr = DesignRoom(g.l_room(size=(12.0, 9.0, 2.8), cut=(6.0, 4.5), cell=1.0), 0)
    a = 2.0
    inner = (12 - 2 * a) * (9 - 2 * a) - 6.0 * 4.5 + (a * a - math.pi * a * a / 4)
    l_area = 12 * 9 - 6 * 4.5
    pts, _, w = background_grid(dr, 0.75, 2.5)
    assert w.sum() == pytest.approx(l_area - inner, rel=0.01)          # 67.14 m2
    notch = (pts[:, 0] > 6.0) & (pts[:, 1] > 4.5)
    assert not notch.any()
    # a column: no point in it, and the band keeps 0.5 m... from its faces as from walls
    sc = g.pillar_room(size=(12.0, 9.0, 3.0), pillar=((5.6, 4.1), (6.4, 4.9)), cell=0.5)
    dr = DesignRoom(sc, 0)
    pts, _, w = background_grid(dr, 0.75, 4.0)
    inside = ((pts[:, 0] > 5.6) & (pts[:, 0] < 6.4) & (pts[:, 1] > 4.1) & (pts[:, 1] < 4.9))
    assert not inside.any()
    dx = np.maximum.reduce([5.6 - pts[:, 0], pts[:, 0] - 6.4, np.zeros(len(pts))])
    dy = np.maximum.reduce([4.1 - pts[:, 1], pts[:, 1] - 4.9, np.zeros(len(pts))])
    d = np.minimum(_rect_distance(pts[:, :2], 12.0, 9.0), np.hypot(dx, dy))
    assert np.all((d >= 0.5 - 1e-9) & (d < 3.5))
    # the column's own band (within 3.5 m of it, 0.5 m or more) counts too
    assert (np.hypot(dx, dy) < 3.5).any()
    assert w.sum() > _rect_band_area(12, 9, 0.5, 3.5) - 1.0


def test_default_is_a_third_of_the_surroundings_and_the_spec_may_ask_more_or_null():
    from invrad_wb.core.design.background import BACKGROUND_U0, background_lux
    from invrad_wb.core.design.background import background_requirement as req
    from invrad_wb.core.design.cylindrical import surroundings_lux
    assert [background_lux(x) for x in (750, 500, 300, 200, 100)] == pytest.approx(
        [500 / 3, 100.0, 200 / 3, 50.0, 100 / 3])
    assert all(background_lux(x) == pytest.approx(surroundings_lux(x) / 3)
               for x in (1000, 400, 150, 50))
    q = req(None, 500)
    assert (q.lux, q.u0) == (100.0, 0.10) and BACKGROUND_U0 == 0.10
    assert "EN 12464-1:2021" in q.source
    assert req(False, 500) is None                           # null: no limit
    q = req((None, 0.2), 500)
    assert (q.lux, q.u0, q.source) == (100.0, 0.2, "spec")
    q = req((150.0, 0.1), 500)
    assert (q.lux, q.u0, q.source) == (150.0, 0.1, "spec")
    q = req((50.0, 0.05), 500)                               # never less than the minimum
    assert (q.lux, q.u0) == (100.0, 0.10) and "raised" in q.source


def test_spec_key_background_parsed_checked_and_kept_by_the_document_side():
    from invrad_wb.app.design import spec_from_data
    from invrad_wb.errors import SettingsError
    wp = {"work_plane": {"lux": 500, "u0": 0.6}}
    assert _spec(wp).room_spec(0).background is None
    assert _spec({**wp, "background": None}).room_spec(0).background is False
    assert _spec({**wp, "background": {"lux": 120}}).room_spec(0).background == (120.0, 0.1)
    assert _spec({**wp, "background": {"u0": 0.3}}).room_spec(0).background == (None, 0.3)
    for bad, words in (({"lux": -5}, "background.lux"), ({"u0": 2}, "background.u0"),
                       ({"lx": 100}, "unknown key 'lx'"), (100, "expected an object")):
        with pytest.raises(SettingsError, match=words.replace(".", r"\.")):
            _spec({**wp, "background": bad})
    # a FreeCAD targets file's rooms keep the key (not dropped as an unknown target key)
    spec = spec_from_data({"catalogue": CAT, "rooms": {"Office": {
        "work_plane": 500, "background": None}}}, "t.json", ".")
    assert spec.room_spec("x", "Office").background is False


def _black_box(size, cell):
    return g.with_reflectances(g.box_room(size=size, cell=cell), 0.0, 0.0, 0.0)


def test_requirement_judged_against_the_inverse_square_law_of_a_point_source():
    """No interreflection (black room): the design model's background figures are a
    lambertian point source's ``E = Phi h^2 / (pi r^4)`` at the band's points, weighted
    by area; the verdict follows the requirement either side of them."""
    from invrad_wb.core.design.background import background_grid, with_background
    from invrad_wb.core.design.evaluate import RoomModel
    from invrad_wb.core.design.room import DesignRoom
    from invrad_wb.core.design.search import Metrics
    from invrad_wb.core.design.spec import SurfaceRequirement
    from invrad_wb.core.model.luminaires import Luminaire
    size = (10.0, 8.0, 3.0)
    sc = _black_box(size, 1.0)
    dr = DesignRoom(sc, 0)
    rs = _spec({"work_plane": {"lux": 500, "u0": 0.6, "margin_m": 3.0}}).room_spec(0)
    req = rs.work_plane
    surfaces = {}
    rd = type("RD", (), {})()
    rs = with_background(rs, dr, req, surfaces, rd)
    assert rd.background_words is None and set(surfaces) == {"background"}
    assert rs.surfaces["background"].lux == pytest.approx(100.0)
    pts, _, w = surfaces["background"]
    assert np.allclose(pts, background_grid(dr, 0.75, 3.0)[0])
    wp, _ = dr.grid(req.height_m, req.margin_m)
    model = RoomModel(sc, dr, wp, 1.0, "numpy", surfaces=surfaces)
    src, flux = np.array([5.0, 4.0, 2.99]), 20000.0
    lux, direct = model.exact([Luminaire(src, [0, 0, -1.0], flux)])
    met = Metrics.of(lux, direct, model.layout)
    h = src[2] - pts[:, 2]
    r2 = np.sum((pts - src) ** 2, axis=1)
    e = flux * h * h / (np.pi * r2 * r2)
    em = float(np.sum(w * e) / w.sum())
    got_em, got_min, got_u0 = met.surfaces["background"]
    assert got_em == pytest.approx(em, rel=1e-3)
    assert got_min == pytest.approx(e.min(), rel=1e-3)
    assert got_u0 == pytest.approx(e.min() / em, rel=2e-3)
    ok = lambda lx, u0: met.surface_ok({"background": SurfaceRequirement(lx, u0)})  # noqa
    assert ok(0.99 * em, 0.99 * e.min() / em) == {"background": True}
    assert ok(1.01 * em, 0.10) == {"background": False}
    assert ok(0.5 * em, 1.01 * e.min() / em) == {"background": False}


def test_designed_room_meets_serves_and_reports_its_background():
    """A 5 x 4 m room whose task area is 1.5 m in from the walls: the background (0-1 m
    from the walls) is judged, served by the design (asked for more, the design gives
    more), and reported in the room summary and the JSON; a whole-room task area and
    ``null`` say why there is none."""
    from dataclasses import replace
    from invrad_wb.core.design.background import with_background
    from invrad_wb.core.design.design import design_room
    from invrad_wb.core.design.room import DesignRoom
    from invrad_wb.core.output.design_report import summary_rows
    sc = g.with_reflectances(g.box_room(size=(5.0, 4.0, 2.8), cell=0.8))
    room = {"work_plane": {"lux": 300, "u0": 0.4, "margin_m": 1.5}}
    rd = design_room(sc, _spec(room), 0, backend="numpy")
    q = rd.surface_reqs["background"]
    assert q.lux == pytest.approx(200 / 3) and q.u0 == 0.10
    em, _, u0 = rd.metrics.surfaces["background"]
    assert rd.verdicts["background"] == (em >= q.lux and u0 >= 0.10)
    assert rd.compliant
    row = next(r for r in summary_rows(rd) if r["item"] == "background area")
    assert row["verdict"] == "pass" and row["required"] == "Em >= 66.67 lx, U0 >= 0.10"
    from invrad_wb.core.output.design_report import _surface_text
    assert _surface_text(rd, "background") == f"{em:.0f} / {u0:.2f}"      # rooms.csv
    d = rd.to_dict()
    assert d["surfaces"]["background"]["required"]["lux"] == pytest.approx(200 / 3)
    assert d["pass"]["background"] is True and "background" not in d
    # a background asked beyond what the design gives: the design serves it (brighter)
    strict = design_room(sc, _spec({**room, "background": {"lux": 1.3 * em}}), 0,
                         backend="numpy")
    assert strict.compliant and strict.metrics.surfaces["background"][0] >= 1.3 * em
    # the usual task area (the room less 0.5 m) leaves none; null asks for none
    dr = DesignRoom(sc, 0)
    for wp, extra, words in (({"lux": 300, "u0": 0.4}, {}, "none"),
                             (room["work_plane"], {"background": None}, "no limit")):
        rs = _spec({"work_plane": wp, **extra}).room_spec(0)
        surfaces, none = {}, type("RD", (), {})()
        assert with_background(rs, dr, rs.work_plane, surfaces, none) is rs
        assert not surfaces and none.background_words.startswith(words)
        shown = replace(rd, surface_reqs={k: v for k, v in rd.surface_reqs.items()
                                          if k != "background"},
                        background_words=none.background_words)
        row = next(r for r in summary_rows(shown) if r["item"] == "background area")
        assert row["verdict"] == "-" and row["achieved"] == none.background_words
        assert shown.to_dict()["background"] == {"judged": False,
                                                 "why": none.background_words}
