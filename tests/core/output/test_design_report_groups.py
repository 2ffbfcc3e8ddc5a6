"""The design report of a layout dimmed apart (issue 22): the schedule has a row per
(type, output) group that adds up to the design's count and power, the plans letter each
luminaire with its own group, and the deep-dimming note counts luminaires, not the type's
mean. Made-up designs (no search): fast."""
from types import SimpleNamespace

import numpy as np
import pytest

from invrad_wb.core.design.design import DesignResult, RoomDesign, deep_dimming_note
from invrad_wb.core.design.search import Candidate
from invrad_wb.core.design.spec import CatalogueEntry
from invrad_wb.core.model.luminaires import Luminaire
from invrad_wb.core.output import design_report as D

CAT = [CatalogueEntry("DL-1000", 1000.0, 8.5, radius_m=0.3),
       CatalogueEntry("DL-3500", 3500.0, 26.0, radius_m=0.3, dimming=(0.1, 1.0))]


def _room(positions, outputs, types=None, size=(6.0, 4.0), dims=True):
    """A designed room of luminaires at ``positions`` (k, 2) running at ``outputs`` (k,)
    of their type's rated flux; ``dims``: dimmed apart (the programme's per-luminaire
    outputs), else all at one common output."""
    positions, outputs = np.asarray(positions, float), np.asarray(outputs, float)
    types = types or ["DL-3500"] * len(outputs)
    cat = {e.name: e for e in CAT}
    lums = [Luminaire(np.array([p[0], p[1], 2.95]), np.array([0.0, 0.0, -1.0]),
                      cat[t].flux_lm * x, 0.3, room=0, extra={"type": t})
            for p, x, t in zip(positions, outputs, types)]
    rated = np.array([cat[t].watts for t in types])
    watts = float(outputs @ rated)
    geom = SimpleNamespace(positions=np.c_[positions, np.full(len(positions), 2.95)],
                           describe=lambda: "made up")
    cand = Candidate(geom, (1, 1), watts / rated.sum(), watts, 500.0, 0.6, 0.0, True,
                     dims=outputs if dims else None)
    w, h = size
    outline = np.array([[[0, 0], [w, 0]], [[w, 0], [w, h]], [[w, h], [0, h]],
                        [[0, h], [0, 0]]], dtype=float)
    gx, gy = np.meshgrid(np.linspace(0.5, w - 0.5, 8), np.linspace(0.5, h - 0.5, 6))
    pts = np.c_[gx.ravel(), gy.ravel(), np.full(gx.size, 0.75)]
    lux = 500.0 + 50.0 * np.sin(pts[:, 0])
    rd = RoomDesign(0, "office", SimpleNamespace(lux=500.0, u0=0.6), lums, candidate=cand,
                    area_m2=w * h, size_m=(w, h), grid_points=pts, outline=outline,
                    metrics=SimpleNamespace(lux=lux, em=float(lux.mean()),
                                            u0=float(lux.min() / lux.mean()),
                                            emin=float(lux.min()), shade_max=0.0,
                                            surface_ok=lambda reqs: {}),
                    rated_watts=float(rated.sum()))
    return rd


# the office of examples/office_design.json as designed (15 x DL-3500 on a 5 x 3 grid,
# outputs 10 to 100 %, 123.7 W): the centre, the centre row, the middle column, the
# corners and edges of the outer ring
GRID = np.array([(x, y) for y in (1.2, 2.0, 2.8) for x in (1.29, 2.15, 3.0, 3.86, 4.71)])
OUTPUTS = np.array([0.10, 0.111, 0.465, 0.111, 0.10,
                    0.10, 0.892, 1.00, 0.892, 0.10,
                    0.10, 0.111, 0.465, 0.111, 0.10])


def _result(*rooms):
    return DesignResult(list(rooms), SimpleNamespace(catalogue=CAT))


def test_the_schedule_has_a_row_per_output_group_adding_up_to_the_design():
    rd = _room(GRID, OUTPUTS)
    rows = D.schedule_rows(_result(rd))
    # five settings, brightest first, lettered
    assert [(r["group"], r["dim_percent"], r["count"]) for r in rows] == [
        ("A", 100, 1), ("B", 89, 2), ("C", 46, 2), ("D", 11, 4), ("E", 10, 6)]
    assert sum(r["count"] for r in rows) == len(rd.luminaires) == 15
    assert sum(r["watts_total"] for r in rows) == pytest.approx(rd.watts, abs=0.02)
    for r in rows:
        assert r["watts"] == pytest.approx(26.0 * r["dim_percent"] / 100, abs=0.15)
        assert r["flux_lm"] == pytest.approx(3500.0 * r["dim_percent"] / 100, abs=20)
        assert r["watts_total"] == pytest.approx(r["count"] * r["watts"], rel=0.01)
    # the rated (installed) power is every luminaire at full output, as before
    assert rd.rated_watts == pytest.approx(15 * 26.0)


def test_two_types_one_dimmed_apart_and_evenly_dimmed_rooms():
    """A room with two types keeps one unlettered row per type where each is at one level;
    an evenly dimmed room gets no letters and one row per type."""
    types = ["DL-1000"] * 4 + ["DL-3500"] * 4
    pos = np.array([(x, y) for y in (1.0, 3.0) for x in (1.0, 2.5, 3.5, 5.0)])
    mixed = _room(pos, [1.0] * 4 + [0.6] * 4, types, dims=False)
    rows = D.schedule_rows(_result(mixed))
    assert [(r["type"], r["group"], r["count"], r["dim_percent"]) for r in rows] == [
        ("DL-1000", "", 4, 100), ("DL-3500", "", 4, 60)]
    assert sum(r["watts_total"] for r in rows) == pytest.approx(mixed.watts, abs=0.02)
    # the same with the DL-3500 dimmed apart: every group lettered, DL-1000 included
    apart = _room(pos, [1.0] * 4 + [0.6, 0.3, 0.3, 0.6], types)
    rows = D.schedule_rows(_result(apart))
    assert [(r["type"], r["group"], r["count"], r["dim_percent"]) for r in rows] == [
        ("DL-1000", "A", 4, 100), ("DL-3500", "B", 2, 60), ("DL-3500", "C", 2, 30)]
    assert sum(r["watts_total"] for r in rows) == pytest.approx(apart.watts, abs=0.02)


def _group_labels(fig):
    return [t for ax in fig.axes for t in ax.texts if t.get_gid() == "group-label"]


@pytest.mark.parametrize("which", ["room", "dimming", "floor"])
def test_plans_letter_each_luminaire_with_its_own_output(which):
    rd = _room(GRID, OUTPUTS)
    groups = D.output_groups(rd, CAT)
    types = [e.name for e in CAT]
    fig = (D.room_plan_figure(rd, rd.outline, 800.0, types, groups) if which == "room"
           else D.dimming_plan_figure(rd, rd.outline, types, groups) if which == "dimming"
           else D.floor_plan_figure([rd], 0.0, types, CAT))
    labels = _group_labels(fig)
    assert len(labels) == 15
    letter = {g["percent"]: g["label"] for g in groups}
    xy = np.array([lum.position[:2] for lum in rd.luminaires])
    on = []
    for t in labels:
        # written on a luminaire, the letter of that luminaire's own output
        d = np.linalg.norm(xy - np.asarray(t.get_position()), axis=1)
        i = int(np.argmin(d))
        assert d[i] < 1e-9
        on.append(i)
        assert t.get_text() == letter[round(100 * rd.luminaires[i].flux_lm / 3500.0)]
    assert sorted(on) == list(range(15))
    # the key names every group with its output, lm and W
    legend_text = " ".join(x.get_text() for lg in fig.legends for x in lg.get_texts())
    if which != "floor":
        for g in groups:
            assert f"{g['label']}: {g['count']} x DL-3500 at {g['percent']} %" in legend_text


@pytest.mark.parametrize("types", [["DL-1000", "DL-3500"],            # a square
                                   ["a", "b", "c", "DL-3500"]])       # a triangle
def test_labels_of_a_dense_room_do_not_overlap_and_stay_readable(types):
    """A 6 x 4 m room with a luminaire every 0.3 m (an extreme panel array), dimmed apart
    in rings: where letters are written no two letters nor markers overlap, none is
    smaller than 4.5 pt, and each sits on its marker. The room plan's small panel has
    room for letters in squares, not in triangles: then its key sends the reader to the
    commissioning plan, which has them."""
    xs, ys = np.arange(0.45, 5.6, 0.3), np.arange(0.45, 3.6, 0.3)
    pos = np.array([(x, y) for y in ys for x in xs])
    ring = np.minimum.reduce([pos[:, 0] - xs[0], xs[-1] - pos[:, 0], pos[:, 1] - ys[0],
                              ys[-1] - pos[:, 1]]) / 0.3
    out = np.where(ring < 0.5, 0.9, np.where(ring < 1.5, 0.6, 0.25))
    rd = _room(pos, out)
    groups = D.output_groups(rd, CAT)
    assert [g["label"] for g in groups] == ["A", "B", "C"]
    lettered = []
    for make in (lambda: D.room_plan_figure(rd, rd.outline, 800.0, types, groups),
                 lambda: D.dimming_plan_figure(rd, rd.outline, types, groups)):
        fig = make()
        renderer = fig.canvas.get_renderer()
        labels = _group_labels(fig)
        if not labels:
            assert len(types) == 4
            assert "see the commissioning plan" in fig.legends[0].get_title().get_text()
            continue
        assert len(labels) == len(pos)
        boxes = np.array([t.get_window_extent(renderer).extents for t in labels])
        assert min(t.get_fontsize() for t in labels) >= 4.5
        x0, y0, x1, y1 = boxes.T
        over = ((x0[:, None] < x1[None]) & (x0[None] < x1[:, None])
                & (y0[:, None] < y1[None]) & (y0[None] < y1[:, None]))
        np.fill_diagonal(over, False)
        assert not over.any()
        # nor do the markers: closer than their size apart they would touch
        ms = [ln.get_markersize() for ln in fig.axes[0].get_lines()
              if ln.get_gid() == "luminaires"]
        xy = fig.axes[0].transData.transform(pos) * 72.0 / fig.dpi
        d = np.linalg.norm(xy[:, None] - xy[None], axis=2)
        assert np.min(d[np.triu_indices(len(xy), 1)]) > max(ms)
        # each letter's box around its luminaire's marker centre
        ax = labels[0].axes
        c = ax.transData.transform(np.array([t.get_position() for t in labels]))
        assert np.all((x0 <= c[:, 0]) & (c[:, 0] <= x1) & (y0 <= c[:, 1]) & (c[:, 1] <= y1))
        lettered.append(fig)
    # the commissioning plan always, the room plan where squares hold the letters
    assert len(lettered) == (2 if len(types) == 2 else 1)


def test_an_evenly_dimmed_room_reads_as_before():
    rd = _room(GRID, np.full(15, 0.32), dims=False)
    groups = D.output_groups(rd, CAT)
    assert [(g["label"], g["count"], g["percent"]) for g in groups] == [("", 15, 32)]
    fig = D.room_plan_figure(rd, rd.outline, 800.0, [e.name for e in CAT], groups)
    assert not _group_labels(fig)
    assert [x.get_text() for x in fig.legends[0].get_texts()] == ["DL-3500 at 32 %"]
    assert not _group_labels(D.floor_plan_figure([rd], 0.0, [e.name for e in CAT], CAT))
    assert D._output_text(rd) == "32 %"


def test_deep_dimming_counts_each_luminaire_not_the_type_mean():
    # the office: 12 of 15 below 50 %
    rd = _room(GRID, OUTPUTS)
    assert rd.deep_dimming and rd.deep_dimmed() == {"DL-3500": (12, 15)}
    note = deep_dimming_note(rd)
    assert "12 of 15 DL-3500 at 10 to 46 %" in note and "32 %" not in note
    assert D._deep_text(rd) == "12 of 15 DL-3500 below 50 %"
    assert D._output_text(rd).startswith("10 to 100 % (dimmed apart")
    # the type's mean output is 66 %, above the limit, yet 7 luminaires run at 30 %:
    # the type mean hid them
    half = _room(GRID, [1.0] * 8 + [0.3] * 7)
    assert half.candidate.dim > 0.6
    assert half.deep_dimmed() == {"DL-3500": (7, 15)}
    assert "7 of 15 DL-3500 at 30 %" in deep_dimming_note(half)
    # two types, each luminaire at or above 60 % of its own type's rated flux: none
    two = _room(GRID[:8], [1.0] * 4 + [0.6] * 4, ["DL-1000"] * 4 + ["DL-3500"] * 4)
    assert not two.deep_dimming and two.deep_dimmed() == {}
    # evenly dimmed below 50 %: all of them
    even = _room(GRID, np.full(15, 0.32), dims=False)
    assert even.deep_dimmed() == {"DL-3500": (15, 15)}
    assert "all 15 DL-3500 at 32 %" in deep_dimming_note(even)
    assert D._deep_text(even) == "all 15 DL-3500 below 50 %"
    one = _room(GRID[:1], [0.3])
    assert D._deep_text(one) == "the DL-3500 below 50 %"
    assert "the DL-3500 at 30 %" in deep_dimming_note(one)
    # just below the threshold: one decimal, never '50 %' in a note about outputs below 50 %
    near = _room(GRID[:2], [0.4996, 0.4960])
    assert "all 2 DL-3500 at 49.6 to 49.9 %" in deep_dimming_note(near)
    # accents (after the general lighting) are not general lighting: not counted
    acc = _room(np.r_[GRID, [[5.5, 3.5]]], np.r_[np.full(15, 0.8), 0.2], dims=False)
    acc.candidate = Candidate(SimpleNamespace(positions=np.c_[GRID, np.zeros(15)],
                                              describe=lambda: ""), (1, 1), 0.8,
                              0.8 * 15 * 26.0, 500.0, 0.6, 0.0, True)
    assert not acc.deep_dimming
    assert [g["deep"] for g in D.output_groups(acc, CAT)] == [False, False]


def test_the_cli_schedule_csv_and_console_line_give_the_groups():
    import csv
    import io
    from invrad_wb.cli.design import _dimmed_words, schedule_csv
    rd = _room(GRID, OUTPUTS)
    text = schedule_csv(_result(rd))
    assert text.startswith("room,type,count,flux_lm,watts_each,dim,watts_total")
    rows = list(csv.DictReader(io.StringIO(text)))
    assert [(r["group"], int(r["count"]), r["dim"]) for r in rows] == [
        ("A", 1, "1.000"), ("B", 2, "0.892"), ("C", 2, "0.465"), ("D", 4, "0.111"),
        ("E", 6, "0.100")]
    assert sum(float(r["watts_total"]) for r in rows) == pytest.approx(rd.watts, abs=0.02)
    assert _dimmed_words(rd) == ", dimmed apart to 10-100 % (32 % of the rated power)"
    assert _dimmed_words(_room(GRID, np.full(15, 0.32), dims=False)) == ", dimmed to 32 %"
    assert _dimmed_words(_room(GRID, np.ones(15), dims=False)) == ""


def test_the_result_json_gives_each_room_its_groups_and_each_luminaire_its_letter(
        monkeypatch):
    """``DesignResult.to_dict``: per room its dimming groups (the report's letters, counts,
    lm and W each, W total, deep) with its members as indices into the JSON's luminaire
    list; each luminaire of a room dimmed apart carries its group's letter
    (``name_groups``, which the design calls), for the JSON, FreeCAD and the IFC."""
    monkeypatch.setattr(RoomDesign, "to_dict", lambda self: {"name": self.name})
    types = ["DL-1000"] * 4 + ["DL-3500"] * 4
    pos = np.array([(x, y) for y in (1.0, 3.0) for x in (1.0, 2.5, 3.5, 5.0)])
    even = _room(pos, [1.0] * 4 + [0.6] * 4, types, dims=False)
    apart = _room(GRID, OUTPUTS)
    spec = SimpleNamespace(catalogue=CAT, maintenance_factor=0.8)
    res = DesignResult([even, apart], spec)
    res.name_groups()
    d = res.to_dict()
    lums = d["luminaires"]
    assert len(lums) == 8 + 15
    g_even, g_apart = d["rooms"][0]["groups"], d["rooms"][1]["groups"]
    # the evenly dimmed room: one unlettered group per type, its luminaires unlettered
    assert [(g["type"], g["label"], g["count"], g["percent"]) for g in g_even] == [
        ("DL-1000", "", 4, 100), ("DL-3500", "", 4, 60)]
    assert all("dimming_group" not in lums[i] for i in range(8))
    # the room dimmed apart: its five letters, members counted after the first room's 8
    assert [(g["label"], g["percent"], g["count"]) for g in g_apart] == [
        ("A", 100, 1), ("B", 89, 2), ("C", 46, 2), ("D", 11, 4), ("E", 10, 6)]
    assert sorted(i for g in g_apart for i in g["luminaires"]) == list(range(8, 23))
    for g in g_apart:
        for i in g["luminaires"]:
            assert lums[i]["dimming_group"] == g["label"]
            assert apart.luminaires[i - 8].extra["dimming_group"] == g["label"]
            assert round(100 * lums[i]["flux_lm"] / 3500.0) == g["percent"]
        assert g["watts_total"] == pytest.approx(26.0 * sum(
            lums[i]["flux_lm"] / 3500.0 for i in g["luminaires"]), abs=1e-3)
    assert sum(g["watts_total"] for g in g_apart) == pytest.approx(apart.watts, abs=0.01)
    assert [g["deep"] for g in g_apart] == [False, False, True, True, True]


def test_values_of_a_small_task_area_on_a_wide_room_do_not_overlap():
    # a 6 x 4 m office with its task area set in 1.5 m (the office example's spec with
    # "margin_m": 1.5): 7 x 3 points 0.43 m apart on a half-page panel
    rd = _room(GRID, OUTPUTS)
    xs, ys = np.meshgrid(np.linspace(1.7, 4.3, 7), np.linspace(1.6, 2.4, 3))
    rd.grid_points = np.column_stack([xs.ravel(), ys.ravel(), np.full(xs.size, 0.75)])
    rd.metrics.lux = np.linspace(416.0, 590.0, len(rd.grid_points))
    fig = D.room_plan_figure(rd, rd.outline, 800.0, [e.name for e in CAT],
                             D.output_groups(rd, CAT))
    fig.canvas.draw()                                   # measured as drawn
    ax2 = fig.axes[1]
    values = [t for t in ax2.texts if t.get_text().isdigit()]
    renderer = fig.canvas.get_renderer()
    boxes = np.array([t.get_window_extent(renderer).extents for t in values])
    x0, y0, x1, y1 = boxes.T
    gap = 0.1 * np.median(x1 - x0)                      # apart, not merely touching
    over = ((x0[:, None] < x1[None] + gap) & (x0[None] < x1[:, None] + gap)
            & (y0[:, None] < y1[None]) & (y0[None] < y1[:, None]))
    np.fill_diagonal(over, False)
    assert not over.any()
    # a regular lattice of the grid is still shown, from its first point, with at least
    # two rows and half its columns
    shown = np.array([t.get_position() for t in values])
    assert tuple(shown[0][:2]) == tuple(rd.grid_points[0][:2])
    assert len(set(np.round(shown[:, 1], 3))) >= 2
    assert len(set(np.round(shown[:, 0], 3))) >= len(set(np.round(xs.ravel(), 3))) // 2
    assert len(values) < len(rd.grid_points)


def _iso_label_boxes(fig):
    fig.canvas.draw()                                   # measured as drawn
    ax = fig.axes[0]
    labels = [t for t in ax.texts if t.get_text().endswith(" lx")]
    renderer = fig.canvas.get_renderer()
    return ax, labels, np.array([t.get_window_extent(renderer).extents
                                 for t in labels]).reshape(-1, 4)


def test_iso_lux_labels_of_a_small_task_area_do_not_overlap():
    # a 1.6 x 1.2 m task area with a bright spot in a 6 x 4 m room on a half-page panel:
    # matplotlib's clabel, called before the page's layout shrank the panel, put four
    # labels into it, two pairs on top of each other
    row = np.array([(x, 3.2) for x in (1.29, 2.15, 3.0, 3.86, 4.71)])
    rd = _room(row, np.array([1.0, 0.5, 0.3, 0.5, 1.0]))
    xs, ys = np.meshgrid(np.linspace(0.7, 2.3, 8), np.linspace(0.7, 1.9, 6))
    pts = np.column_stack([xs.ravel(), ys.ravel(), np.full(xs.size, 0.75)])
    rd.grid_points = pts
    d2 = np.sum((pts[:, :2] - [1.5, 1.3]) ** 2, axis=1)
    rd.metrics.lux = 300 + 700 * np.exp(-d2 / 0.3) + 150 * pts[:, 0]
    fig = D.room_plan_figure(rd, rd.outline, 1200.0, [e.name for e in CAT],
                             D.output_groups(rd, CAT))
    ax, labels, boxes = _iso_label_boxes(fig)
    assert len(labels) >= 1                             # the lines still say their level
    x0, y0, x1, y1 = boxes.T
    over = ((x0[:, None] < x1[None]) & (x0[None] < x1[:, None])
            & (y0[:, None] < y1[None]) & (y0[None] < y1[:, None]))
    np.fill_diagonal(over, False)
    assert not over.any()
    # each label on the coloured field (white on the white page is unreadable)
    inv = ax.transData.inverted()
    lo = inv.transform(boxes[:, :2])
    hi = inv.transform(boxes[:, 2:])
    assert np.all(lo >= pts[:, :2].min(axis=0) - 1e-6)
    assert np.all(hi <= pts[:, :2].max(axis=0) + 1e-6)


def test_iso_lux_labels_keep_off_the_luminaire_markers():
    # the office grid of luminaires over a whole-room work plane: no label under a marker
    rd = _room(GRID, OUTPUTS)
    fig = D.room_plan_figure(rd, rd.outline, 800.0, [e.name for e in CAT],
                             D.output_groups(rd, CAT))
    ax, labels, boxes = _iso_label_boxes(fig)
    assert len(labels) >= 1
    at = ax.transData.transform(GRID)
    inside = ((at[:, None, 0] > boxes[None, :, 0]) & (at[:, None, 0] < boxes[None, :, 2])
              & (at[:, None, 1] > boxes[None, :, 1]) & (at[:, None, 1] < boxes[None, :, 3]))
    assert not inside.any()


def test_plan_of_two_task_areas_fits_a_page_and_names_them():
    # desks (7 x 5 cells) and a counter (6 x 4): the union's 13 columns stack the two
    # panels; at 4.2 in each the figure (10.4 in) left the room's heading alone on an
    # empty PDF page
    from invrad_wb.core.design.spec import SurfaceRequirement, TaskArea
    rd = _room(GRID, OUTPUTS)
    desks = TaskArea("desks", ((0.8, 0.8), (3.2, 0.8), (3.2, 2.4), (0.8, 2.4)), rect=True)
    counter = TaskArea("counter", ((4.4, 2.9), (5.6, 2.9), (5.6, 3.6), (4.4, 3.6)), lux=300)
    cells = []
    for a, (nx, ny) in ((desks, (7, 5)), (counter, (6, 4))):
        (x0, y0), (x1, y1) = a.polygon[0], a.polygon[2]
        gx, gy = np.meshgrid(x0 + (np.arange(nx) + 0.5) * (x1 - x0) / nx,
                             y0 + (np.arange(ny) + 0.5) * (y1 - y0) / ny)
        cells.append(np.c_[gx.ravel(), gy.ravel(), np.full(gx.size, 0.8)])
    rd.grid_points = np.concatenate(cells)
    rd.metrics.lux = 300.0 + 100.0 * rd.grid_points[:, 0]
    rd.requirement = SimpleNamespace(lux=500.0, u0=0.6, task_areas=(desks, counter))
    rd.metrics.surfaces = {desks.part: (520.0, 330.0, 0.63), counter.part: (310.0, 240.0, 0.77)}
    rd.surface_reqs = {desks.part: SurfaceRequirement(500.0, 0.6),
                       counter.part: SurfaceRequirement(300.0, 0.6)}
    fig = D.room_plan_figure(rd, rd.outline, 800.0, [e.name for e in CAT],
                             D.output_groups(rd, CAT))
    w, h = fig.get_size_inches()
    assert h <= 8.8                          # with the heading, on one A4 page
    ax, ax2 = fig.axes[:2]
    assert ax.get_title().startswith("desks: Em 520 lx, U0 0.63; counter: Em 310 lx")
    assert {t.get_text() for t in ax2.texts} >= {"desks", "counter"}
    # the values over the dashed outlines: on top of them, each in a white halo
    from matplotlib import colors, patheffects
    values = [t for t in ax2.texts if t.get_text().isdigit()]
    dashed = [ln for ln in ax2.lines if ln.get_linestyle() == "--"]
    assert values and len(dashed) == 2
    for t in values:
        (pe,) = t.get_path_effects()
        assert isinstance(pe, patheffects.withStroke)
        assert colors.to_rgb(pe._gc["foreground"]) == (1.0, 1.0, 1.0)
        assert t.get_zorder() > max(ln.get_zorder() for ln in dashed)


def _level_widths(cs):
    """The line width of each level of a contour set, in any matplotlib (3.10 dropped the
    per-level ``collections``: the set is one Collection with a width per level)."""
    from matplotlib.collections import Collection
    if isinstance(cs, Collection):
        return [float(w) for w in np.ravel(cs.get_linewidth())]
    return [c.get_linewidth()[0] for c in cs.collections]


def test_plan_title_says_the_iso_lux_step_and_bolds_the_required_level():
    # the office plan: labels fit on few lines between the markers; the title gives the
    # step and the required level's line is drawn bold
    rd = _room(GRID, OUTPUTS)
    fig = D.room_plan_figure(rd, rd.outline, 800.0, [e.name for e in CAT],
                             D.output_groups(rd, CAT))
    ax = fig.axes[0]
    levels = D.iso_levels(rd.metrics.lux, 500.0)
    step = levels[1] - levels[0]
    assert ax.get_title().endswith(f"iso-lux lines every {step:g} lx, 500 lx bold")
    widths = _level_widths(ax.iso_lines)
    assert widths[levels.index(500.0)] > 2 * max(w for v, w in zip(levels, widths)
                                                 if v != 500.0)
    assert D.iso_words(np.array([100.0, 100.0]), 500.0).startswith("no iso-lux lines")
    assert D.iso_words(np.array([380.0, 760.0]), 500.0) == (
        "iso-lux lines every 100 lx, 500 lx bold")
    assert D.iso_words(np.array([380.0, 760.0]), 550.0) == (
        "iso-lux lines at 400, 500, 550, 600, 700 lx, 550 lx bold")


def test_deep_dimming_note_says_what_a_smaller_type_would_trade():
    rd = _room(GRID, OUTPUTS)
    # the catalogue's smaller DL-1000 is less efficient (117.6 against 134.6 lm/W): fewer
    # rated watts, more drawn
    note = deep_dimming_note(rd, CAT)
    assert "DL-1000 (8.5 W, 118 lm/W)" in note and "less efficient than DL-3500 (135" in note
    assert "better choice" not in note
    # nothing smaller in the room's catalogue
    alone = deep_dimming_note(rd, CAT[1:])
    assert "no type with fewer rated watts than DL-3500 (26 W)" in alone
    # a smaller type as efficient: named as such, not called less efficient
    good = CatalogueEntry("DL-2000", 2000.0, 14.0, radius_m=0.3)
    both = deep_dimming_note(rd, CAT + [good])
    assert "DL-2000 is as efficient as DL-3500" in both and "less efficient" not in both
    assert both.index("DL-1000") < both.index("DL-2000 (14 W")
