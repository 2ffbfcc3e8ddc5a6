"""Task areas given explicitly (the desks, a counter): the spec's rectangles and polygons
with their one-line errors, each area's EN 12464-1 grid, the immediate surroundings and the
background derived from them, an area's Em against the inverse-square law, and a room
designed for and reported per task area."""
import math

import numpy as np
import pytest

from invrad_wb.core.synthetic import generate as g
from invrad_wb.errors import SettingsError

CAT = [{"name": "DL-3500", "flux_lm": 3500, "watts": 26.0, "dimming": [0.1, 1.0]}]


def _spec(room, cat=CAT):
    from invrad_wb.core.design.spec import spec_from_dict
    return spec_from_dict({"maintenance_factor": 0.8, "catalogue": cat, "rooms": {"0": room}},
                          source="d.json")


def _wp(areas, **kw):
    return {"work_plane": {"lux": 500, "u0": 0.6, "task_areas": areas, **kw}}


def test_spec_reads_rectangles_and_polygons_and_turns_them_counter_clockwise():
    from invrad_wb.core.geometry.polygon import polygon_area
    wp = _spec(_wp([{"name": "desks", "rect": [1, 1, 3, 2]},
                    {"name": "counter", "polygon": [[4, 1], [4, 3], [5, 3], [5, 1], [4, 1]],
                     "lux": 300}])).room_spec(0).work_plane
    desks, counter = wp.task_areas
    assert desks.polygon == ((1, 1), (3, 1), (3, 2), (1, 2)) and desks.lux is None
    assert counter.lux == 300 and len(counter.polygon) == 4     # the closing point dropped
    assert polygon_area(counter.polygon) == pytest.approx(2.0)  # clockwise given, turned
    d = wp.to_dict()
    assert "margin_m" not in d and d["task_areas"][0] == {"name": "desks",
                                                          "rect": [1, 1, 3, 2]}
    # a room type's Em and U0 on the task areas
    wp = _spec({"room_type": "office", "work_plane": {
        "task_areas": [{"name": "t", "rect": [0, 0, 1, 1]}]}}).room_spec(0).work_plane
    assert wp.lux == 500 and len(wp.task_areas) == 1


@pytest.mark.parametrize("areas, extra, words", [
    ([{"name": "a", "polygon": [[0, 0], [1, 0]]}], {}, "task_areas.a.polygon: [[0, 0], [1, 0]]:"
     " a polygon needs at least 3 points"),
    ([{"name": "a", "polygon": [[0, 0], [1, 1], [2, 2]]}], {}, "task_areas.a.polygon:"
     " [[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]] has zero area"),
    ([{"name": "bow", "polygon": [[0, 0], [2, 2], [2, 0], [0, 2]]}], {},
     "task_areas.bow.polygon: edges 1 and 3 cross: the polygon intersects itself"),
    ([{"name": "a", "rect": [2, 1, 1, 3]}], {}, "task_areas.a.rect: [2, 1, 1, 3] has no"
     " area"),
    ([{"name": "a", "rect": [0, 0, 1]}], {}, "task_areas.a.rect: [0, 0, 1]: give [x0, y0,"
     " x1, y1]"),
    ([{"name": "a", "rect": [0, 0, 1, 1], "polygon": [[0, 0], [1, 0], [0, 1]]}], {},
     "task_areas.a: give either \"rect\""),
    ([{"name": "a", "rect": [0, 0, 1, 1]}, {"name": "a", "rect": [2, 2, 3, 3]}], {},
     "task_areas.a: the name 'a' is used twice"),
    ([{"name": "a", "rect": [0, 0, 1, 1]}], {"margin_m": 0.5},
     "work_plane.margin_m: give either margin_m"),
    ([], {}, "task_areas: []: give a non-empty list"),
    ([{"name": "a", "rect": [0, 0, 1e-9, 1]}], {}, "task_areas.a.rect: [0, 0, 1e-09, 1] has"
     " zero area (under 1e-06 m2)"),
    ([{"name": "a", "polygon": [[0, 0], [1, 0], [1, 0], [1, 1], [0, 1]]}], {},
     None),                                       # a repeated corner: a simple square
    ([{"name": "a", "polygon": [[0, 0], [1, 0], [1, 0], [0, 0]]}], {}, "task_areas.a.polygon:"
     " [[0, 0], [1, 0], [1, 0], [0, 0]]: a polygon needs at least 3 distinct points"),
    ([{"name": "desk.1", "rect": [0, 0, 1, 0]}], {}, "task_areas.0.rect: [0, 0, 1, 0] has no"
     " area"),                                    # a dotted name: its index in the key
    ([{"name": "Desk 1.2", "rect": [0, 0, 1, 1]}], {}, None),   # a FreeCAD label: a name
    ([{"name": "a", "rect": [0, 0, 1, 1], "depth": 2}], {}, "unknown key 'depth'"),
])
def test_spec_refuses_bad_task_areas_in_one_line_naming_key_and_value(areas, extra, words):
    if words is None:
        (a,) = _spec(_wp(areas, **extra)).room_spec(0).work_plane.task_areas
        assert a.polygon == ((0, 0), (1, 0), (1, 1), (0, 1))
        return
    with pytest.raises(SettingsError) as e:
        _spec(_wp(areas, **extra))
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith("d.json: rooms.0.work_plane.")
    assert words in msg


def _room(size=(8.0, 6.0, 2.8), cell=1.0, black=False):
    sc = g.box_room(size=size, cell=cell)
    return g.with_reflectances(sc, 0.0, 0.0, 0.0) if black else g.with_reflectances(sc)


def _rect_distance(xy, rect):
    """Distance of plan points to an axis-aligned rectangle (0 inside)."""
    x0, y0, x1, y1 = rect
    dx = np.maximum.reduce([x0 - xy[:, 0], np.zeros(len(xy)), xy[:, 0] - x1])
    dy = np.maximum.reduce([y0 - xy[:, 1], np.zeros(len(xy)), xy[:, 1] - y1])
    return np.hypot(dx, dy)


def test_task_cells_surroundings_and_background_of_two_rectangles():
    from invrad_wb.core.design import en12464
    from invrad_wb.core.design.room import DesignRoom
    from invrad_wb.core.design.taskareas import band_cells, task_cells
    dr = DesignRoom(_room(), 0)
    rects = ([1.5, 1.5, 3.9, 3.1], [5.5, 4.0, 6.7, 4.7])     # desks, counter (8 x 6 room)
    areas = _spec(_wp([{"name": "desks", "rect": rects[0]},
                       {"name": "counter", "rect": rects[1]}])).room_spec(0).work_plane.task_areas
    for a, r in zip(areas, rects):
        pts, up, w = task_cells(dr, 0.75, a)
        w_, h_ = r[2] - r[0], r[3] - r[1]
        assert w.sum() == pytest.approx(w_ * h_)                    # the whole area
        assert np.all(_rect_distance(pts[:, :2], r) == 0) and np.allclose(pts[:, 2], 0.75)
        assert np.all(up[:, 2] == 1)
        # EN 12464-1 spacing of the area's own longer side
        ns, nt = en12464.grid_counts(w_, h_)
        assert len(pts) == ns * nt and math.sqrt(w[0]) <= en12464.grid_spacing(w_) + 1e-9
    d = lambda p: np.minimum(_rect_distance(p[:, :2], rects[0]),      # noqa: E731
                             _rect_distance(p[:, :2], rects[1]))
    pts, _, w = band_cells(dr, 0.75, areas, 0.0, 0.5, 0.25)
    assert np.all((d(pts) > 0) & (d(pts) <= 0.5 + 1e-9))
    # both 0.5 m bands (rounded corners), apart and within the room: perimeter r + pi r^2
    ring = sum(2 * (r[2] - r[0] + r[3] - r[1]) * 0.5 + math.pi * 0.25 for r in rects)
    assert w.sum() == pytest.approx(ring, rel=0.02)
    # split by the nearest area (surroundings at each area's own Table-3 level): the two
    # parts make up the band, each cell nearer its own area
    parts = [band_cells(dr, 0.75, areas, 0.0, 0.5, 0.25, only=[i]) for i in (0, 1)]
    assert sum(p[2].sum() for p in parts) == pytest.approx(w.sum(), rel=1e-9)
    for i, (p, _, _) in enumerate(parts):
        assert np.all(_rect_distance(p[:, :2], rects[i]) <= _rect_distance(p[:, :2],
                                                                           rects[1 - i]))
    bg, _, wb = band_cells(dr, 0.75, areas, 0.5, 3.5, 1.5)
    assert np.all((d(bg) > 0.5) & (d(bg) <= 3.5 + 1e-9))
    # the room less the task areas less their surroundings: all within 3.5 m here
    tasks = sum((r[2] - r[0]) * (r[3] - r[1]) for r in rects)
    assert wb.sum() == pytest.approx(48.0 - tasks - ring, rel=0.03)


def test_a_polygon_task_area_is_judged_on_its_cells_only():
    from invrad_wb.core.design.room import DesignRoom, in_polygon
    from invrad_wb.core.design.taskareas import task_cells
    dr = DesignRoom(_room(), 0)
    ell = [[1, 1], [4, 1], [4, 2], [2, 2], [2, 4], [1, 4]]           # an L counter, 5 m2
    (a,) = _spec(_wp([{"name": "L", "polygon": ell}])).room_spec(0).work_plane.task_areas
    pts, _, w = task_cells(dr, 0.75, a)
    assert in_polygon(a.polygon, pts[:, :2]).all()
    assert w.sum() == pytest.approx(5.0, rel=0.15)


def test_task_area_outside_the_room_is_refused_before_any_work():
    from invrad_wb.core.design.design import design
    sc = _room((5.0, 4.0, 2.8), 1.0)
    spec = _spec(_wp([{"name": "desks", "rect": [1, 1, 2, 2]},
                      {"name": "counter", "polygon": [[4, 3], [5.4, 3], [5.4, 3.6],
                                                      [4, 3.6]]}]))
    with pytest.raises(SettingsError) as e:
        design(sc, spec, backend="numpy")
    msg = str(e.value)
    assert "\n" not in msg and msg.endswith(
        "rooms.0.work_plane.task_areas.counter: crosses the outline of room 0 at (5.00, 3.00)")


@pytest.mark.parametrize("rect, words", [
    ([2, 1, 4, 3], None),              # the pillar (2.8-3.2 x 1.8-2.2) inside the area
    ([2, 1, 5, 3], None),
    ([1, 1.9, 5, 2.1], None),          # a thin strip across the pillar
    ([0, 0, 6, 4], None),              # the whole room, edges along the walls
    ([5, 1, 7, 2], "crosses the outline of room 0 at (6.00, 1.00)"),
    ([0, 0, 7, 4], "crosses the outline of room 0 at (6.00, 0.00)"),   # along a wall, out
    ([7, 1, 8, 2], "lies outside room 0 (its corner (7.00, 1.00)"),
])
def test_task_area_checked_against_the_outer_outline_only_a_column_inside_is_no_fault(
        rect, words):
    from invrad_wb.core.design.taskareas import check_task_areas
    spec = _spec(_wp([{"name": "a", "rect": rect}]))
    sc = g.pillar_room(cell=1.0)
    if words is None:
        check_task_areas(sc, spec, {0: None})
        return
    with pytest.raises(SettingsError) as e:
        check_task_areas(sc, spec, {0: None})
    assert str(e.value).startswith("d.json: rooms.0.work_plane.task_areas.a: " + words)


def test_task_area_crossing_an_l_rooms_notch_is_refused_where_it_crosses():
    from invrad_wb.core.design.taskareas import check_task_areas
    sc = g.l_room(cell=1.0)                # 6 x 5, the notch x > 3, y > 2.5
    for poly in ([[1, 1], [5, 1], [5, 2.5], [3, 2.5], [3, 4.5], [1, 4.5]],  # along the notch
                 [[1, 1], [5, 1], [1, 4]]):    # its long side through the notch's corner
        check_task_areas(sc, _spec(_wp([{"name": "t", "polygon": poly}])), {0: None})
    bad = _spec(_wp([{"name": "t", "polygon": [[4, 1], [5, 1], [4, 3.5]]}]))
    with pytest.raises(SettingsError, match=r"task_areas.t: crosses the outline of room 0"
                       r" at \(4.40, 2.50\)$"):
        check_task_areas(sc, bad, {0: None})


def test_task_area_em_against_the_inverse_square_law_of_a_point_source():
    """No interreflection (black room): a task area's Em and U0 in the design model are a
    lambertian point source's ``E = Phi h^2 / (pi r^4)`` at its own cells, area-weighted;
    the other area's cells do not enter."""
    from invrad_wb.core.design.design import RoomDesign
    from invrad_wb.core.design.evaluate import RoomModel
    from invrad_wb.core.design.room import DesignRoom
    from invrad_wb.core.design.search import Metrics
    from invrad_wb.core.design.taskareas import prepare
    from invrad_wb.core.model.luminaires import Luminaire
    sc = _room((8.0, 6.0, 3.0), 1.0, black=True)
    dr = DesignRoom(sc, 0)
    rs = _spec(_wp([{"name": "desks", "rect": [1.0, 1.0, 3.4, 2.6]},
                    {"name": "counter", "rect": [5.5, 4.0, 6.7, 4.7], "lux": 300,
                     "u0": 0.4}])).room_spec(0)
    surfaces = {}
    rd = RoomDesign(0, "r", rs.work_plane, [])
    pts, rs2, sreq = prepare(rs, dr, rs.work_plane, surfaces, rd)
    assert sreq.lux == 300 and sreq.u0 == 0.0 and not sreq.task_areas
    assert set(surfaces) == {"task area: desks", "task area: counter",
                             "surroundings (desks)", "surroundings (counter)",
                             "background (desks)", "background (counter)"}
    assert rs2.surfaces["task area: counter"].lux == 300
    assert rs2.surfaces["task area: counter"].u0 == 0.4
    assert rs2.surfaces["task area: desks"].u0 == 0.6
    # each area's surroundings from its own Em (Table 3), the background a third of them
    assert rs2.surfaces["surroundings (desks)"].lux == 300           # of 500 lx
    assert rs2.surfaces["surroundings (counter)"].lux == 200         # of 300 lx
    assert rs2.surfaces["background (desks)"].lux == pytest.approx(100)
    assert rs2.surfaces["background (counter)"].lux == pytest.approx(200 / 3)
    model = RoomModel(sc, dr, pts, 1.0, "numpy", surfaces=surfaces)
    src, flux = np.array([2.0, 2.0, 2.99]), 20000.0
    lux, direct = model.exact([Luminaire(src, [0, 0, -1.0], flux)])
    met = Metrics.of(lux, direct, model.layout)
    for name in ("desks", "counter"):
        p, _, w = surfaces[f"task area: {name}"]
        h = src[2] - p[:, 2]
        r2 = np.sum((p - src) ** 2, axis=1)
        e = flux * h * h / (np.pi * r2 * r2)
        em = float(np.sum(w * e) / w.sum())
        got_em, got_min, got_u0 = met.surfaces[f"task area: {name}"]
        assert got_em == pytest.approx(em, rel=1e-3)
        assert got_min == pytest.approx(e.min(), rel=1e-3)
        assert got_u0 == pytest.approx(e.min() / em, rel=2e-3)
    # the desks under the source, the counter far off: two very different Em
    assert met.surfaces["task area: desks"][0] > 5 * met.surfaces["task area: counter"][0]


def test_room_designed_for_and_reported_per_task_area():
    """A 6 x 4 m room with desks at 500 lx and a counter asked for 750 lx: the design
    serves each area on its own cells (the counter gets its 750 lx, which the work plane's
    500 lx would not ask), the verdicts, the room summary, rooms.csv's row and the JSON
    name each area; no U0 is judged over the two together."""
    from invrad_wb.core.design.design import design_room
    from invrad_wb.core.output.design_report import room_rows, summary_rows
    sc = _room((6.0, 4.0, 2.8), 1.0)
    room = _wp([{"name": "desks", "rect": [0.8, 0.8, 3.2, 2.4]},
                {"name": "counter", "rect": [4.4, 2.9, 5.6, 3.6], "lux": 750}])
    rd = design_room(sc, _spec(room), 0, backend="numpy", mixed=False)
    v = rd.verdicts
    assert "Em" not in v and "U0" not in v
    assert v["task area: desks"] and v["task area: counter"] and rd.compliant
    em_d, _, u0_d = rd.metrics.surfaces["task area: desks"]
    em_c, _, u0_c = rd.metrics.surfaces["task area: counter"]
    assert em_d >= 500 and u0_d >= 0.6 and em_c >= 750 and u0_c >= 0.6
    rows = summary_rows(rd)
    assert [r["item"] for r in rows[:2]] == ["task area desks (3.84 m2)",
                                             "task area counter (0.84 m2)"]
    assert rows[1]["required"] == "Em >= 750 lx, U0 >= 0.60" and rows[1]["verdict"] == "pass"
    assert rows[1]["achieved"] == f"Em {em_c:.0f} lx, U0 {u0_c:.2f}"
    # each area's immediate surroundings from its own Em (Table 3: 750 -> 500, 500 -> 300)
    assert [(r["item"], r["required"], r["verdict"]) for r in rows[2:4]] == [
        ("immediate surroundings (counter)", "Em >= 500 lx, U0 >= 0.40", "pass"),
        ("immediate surroundings (desks)", "Em >= 300 lx, U0 >= 0.40", "pass")]
    assert "nearest to counter, of their Em 750 lx" in rows[2]["source"]
    bg = {r["item"]: r["required"] for r in rows if r["item"].startswith("background")}
    assert bg == {"background area (counter)": "Em >= 166.7 lx, U0 >= 0.10",
                  "background area (desks)": "Em >= 100 lx, U0 >= 0.10"}
    result = type("R", (), {"rooms": [rd], "spec": _spec(room)})()
    row = room_rows(result)[0]
    assert row["em_req"] == "500; 750" and row["em"] == f"{em_d:.0f}; {em_c:.0f}"
    assert row["task_areas"].startswith(f"desks: Em {em_d:.0f} lx (>= 500), U0 {u0_d:.2f}")
    assert row["surroundings"].startswith("(counter) ") and "; (desks) " in row["surroundings"]
    d = rd.to_dict()
    assert [a["name"] for a in d["task_areas"]] == ["desks", "counter"]
    assert d["task_areas"][1]["lux"] == 750 and d["task_areas"][1]["pass"] is True
    assert d["task_areas"][1]["em_lux"] == pytest.approx(em_c, abs=0.01)
    assert d["requirement"]["task_areas"][0]["rect"] == [0.8, 0.8, 3.2, 2.4]


def test_the_example_spec_with_task_areas_reads():
    import os
    from invrad_wb.core.design.spec import read_spec
    here = os.path.dirname(os.path.abspath(__file__))
    spec = read_spec(os.path.join(here, "..", "..", "..", "examples",
                                  "office_task_areas.json"))
    wp = spec.room_spec(0).work_plane
    assert [a.name for a in wp.task_areas] == ["desks", "counter"]
    assert wp.lux == 500 and wp.task_areas[1].lux == 300 and wp.height_m == 0.8


def test_task_area_without_head_room_refused_before_any_work_and_a_part_noted():
    from types import SimpleNamespace
    from invrad_wb.core.design.room import DesignRoom
    from invrad_wb.core.design.taskareas import check_task_areas, prepare
    sc = g.sloped_room(size=(6.0, 4.0), low=1.0, high=3.0, cell=1.0)   # 1 m high at x = 0
    bad = _spec(_wp([{"name": "bench", "rect": [0.1, 0.5, 0.5, 3.5]}]))
    with pytest.raises(SettingsError) as e:
        check_task_areas(sc, bad, {0: None})
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith(
        "d.json: rooms.0.work_plane.task_areas.bench: no head room over it: the work plane"
        " at 0.75 m needs the ceiling above")
    assert "it is at most 1.17 m over the area" in msg          # 1 + 2 * 0.5 / 6
    part = _spec(_wp([{"name": "bench", "rect": [0.1, 0.5, 2.1, 3.5]}]))
    check_task_areas(sc, part, {0: None})
    rs = part.room_spec(0)
    rd = SimpleNamespace(notes=[], background_words=None)
    prepare(rs, DesignRoom(sc, 0), rs.work_plane, {}, rd)
    (note,) = [n for n in rd.notes if n.startswith("task area 'bench'")]
    assert note.startswith("task area 'bench': judged on ") and "of 6.00 m2" in note


def test_too_much_light_note_weighs_each_task_area_against_its_own_em():
    from types import SimpleNamespace as NS
    from invrad_wb.core.design.design import _explain
    from invrad_wb.core.design.search import Metrics
    from invrad_wb.core.design.spec import SurfaceRequirement
    req = _spec({"work_plane": {"lux": 200, "u0": 0.4, "task_areas": [
        {"name": "a", "rect": [0, 0, 1, 1], "lux": 500},
        {"name": "b", "rect": [2, 0, 3, 1], "lux": 500}]}}).room_spec(0).work_plane
    a, b = req.task_areas

    def notes(em_a, em_b):
        m = Metrics.__new__(Metrics)
        m.em, m.u0, m.shade_max = 640.0, 0.7, 0.0
        m.surfaces = {a.part: (em_a, 0, 0.7), b.part: (em_b, 0, 0.7)}
        rd = NS(requirement=req, metrics=m, candidate=NS(ok=True, dim=1.0), notes=[],
                ugr=None, ugr_limit=None, verdicts={}, deep_dimming=False,
                luminaires=[], surface_reqs={a.part: SurfaceRequirement(500, 0.6, "s"),
                                             b.part: SurfaceRequirement(500, 0.6, "s")})
        _explain(rd, NS(rs=NS(shade_limit_lux=1.0)), [NS(name="DL", flux_lm=3500)])
        return [n for n in rd.notes if " x the " in n]
    assert notes(640.0, 650.0) == []             # 1.3 x their own 500 lx: no waste to tell
    (n,) = notes(900.0, 800.0)
    assert n.startswith("Em 800 lx on the task area least above its own is 1.6 x the 500 lx")
