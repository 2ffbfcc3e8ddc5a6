"""The regular grid a lighting designer would lay is a candidate of the search: each
luminous size gets its own layouts, and a design never draws more than the best regular
grid of its catalogue (every type, every nx x ny, half spacing at the walls, dimmed
evenly) as the exact model judges it."""
import numpy as np

from invrad_wb.core.synthetic import generate as g


def _spec(room, cat):
    from invrad_wb.core.design.spec import spec_from_dict
    return spec_from_dict({"maintenance_factor": 0.8, "catalogue": cat, "rooms": {"0": room}})


def _panel():
    from invrad_wb.core.model.photometry import Photometry
    ph = Photometry.lambertian()
    return Photometry(ph.table, 1.0, name="panel", luminous_area_m2=0.36,
                      luminous_extent_m=(0.6, 0.6))


CAT = [{"name": "DL", "flux_lm": 1200, "watts": 10.0, "radius_m": 0.05,
        "dimming": [0.1, 1.0]},
       {"name": "PN", "flux_lm": 3600, "watts": 29.0, "dimming": [0.1, 1.0]}]


def _search(sc, spec):
    from invrad_wb.core.design.evaluate import RoomModel
    from invrad_wb.core.design.room import DesignRoom
    from invrad_wb.core.design.search import RoomSearch
    rs = spec.room_spec(0)
    dr = DesignRoom(sc, 0)
    pts, _ = dr.grid(0.75, 0.5)
    search = RoomSearch(RoomModel(sc, dr, pts, 0.8, "numpy"), rs.work_plane, rs,
                        spec.entries_for(rs, 2.8), {"PN": _panel()})
    return search, dr


def test_a_downlight_keeps_the_outer_rows_a_panel_must_drop():
    """Layouts are kept clear of the walls by the half size of the opening they serve: a
    0.6 m panel's centre never comes within 0.3 m + the wall clearance of a wall, while a
    small downlight may use rows that close (a grid with half spacing at the walls of
    0.8 m spacing puts them 0.4 m from the wall: before, every type lost them)."""
    from invrad_wb.core.design.layouts import WALL_CLEARANCE_M
    sc = g.with_reflectances(g.box_room(size=(4.0, 3.2, 2.8), cell=0.5))
    search, dr = _search(sc, _spec({"work_plane": {"lux": 500, "u0": 0.6}}, CAT))
    search._calibrate_all()
    t = search.table()
    pairs = search._pairs()
    half = {"DL": 0.05, "PN": 0.3}
    near = {"DL": 0, "PN": 0}
    for gi, pi in zip(t["geom"], t["pair"]):
        names = {search.entries[k].name for k in pairs[pi]}
        d = dr.wall_distance(search.geoms[gi].positions[:, :2]).min()
        assert d >= WALL_CLEARANCE_M + max(half[n] for n in names) - 1e-9
        if len(names) == 1:
            near[names.pop()] += d < WALL_CLEARANCE_M + 0.3 - 1e-9
    assert near["DL"] > 0 and near["PN"] == 0
    # a 5 x 4 downlight grid with half spacing at the walls (0.4 m from them) is there
    assert any(geo.ns == 5 and geo.nt == 4 and geo.count == 20 and geo.edge_deviation == 0
               for geo in search.geoms)


def test_the_design_never_draws_more_than_the_best_regular_grid(monkeypatch):
    """Every regular grid of the room (each type, each nx x ny, half spacing at the walls,
    dimmed evenly to the exact model's need with the design margin) that the fast model
    puts within 1.25 x the design's watts (its errors are a few per cent) checked
    exactly: the design draws no more than the least of those that meet every
    requirement."""
    from invrad_wb.core.design import refine
    from invrad_wb.core.design.design import design_room
    from invrad_wb.core.design.search import _finalise
    # the per-group programme only on the search's design and the best grid (speed)
    monkeypatch.setattr(refine, "EXACT_TRIES", 0)
    sc = g.with_reflectances(g.box_room(size=(3.2, 2.4, 2.8), cell=0.8))
    spec = _spec({"work_plane": {"lux": 500, "u0": 0.6}, "walls": {"lux": 75}}, CAT[:1])
    rd = design_room(sc, spec, 0, photometry={}, backend="numpy")
    assert rd.compliant
    search, _ = _search(sc, spec)
    search.margin = spec.design_margin
    search._calibrate_all()
    t = search.table()
    single = np.array([a == b for a, b in search._pairs()])[t["pair"]]
    rows = np.flatnonzero(single & (search.g_fdev[t["geom"]] == 0)
                          & (t["watts"] <= 1.25 * rd.watts))
    best, n_ok = np.inf, 0
    for r in rows:
        c, _ = _finalise(search, search.candidate(t, r), search.check(search.candidate(t, r)))
        if c.ok:
            best, n_ok = min(best, c.watts), n_ok + 1
    assert n_ok >= 2 and np.isfinite(best)
    assert rd.watts <= best * (1 + 1e-6), (rd.watts, best)
