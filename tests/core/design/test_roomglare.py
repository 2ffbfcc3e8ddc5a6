"""UGR rates the installation new (CIE 117; EN 12464-1's limits hold in new condition):
the luminaires' luminance and the background luminance both without the maintenance
factor, so a room's UGR does not depend on it (until round 12 the background was taken
maintained, which read every room 8 log10(1 / MF) high)."""
import numpy as np
import pytest

from invrad_wb.core.design.evaluate import RoomModel
from invrad_wb.core.design.room import DesignRoom
from invrad_wb.core.design.roomglare import glare_terms, room_ugr
from invrad_wb.core.model.luminaires import Luminaire
from invrad_wb.core.output.glare import observers, ugr, ugr_from_sum
from invrad_wb.core.synthetic import generate as g


def test_room_ugr_is_the_new_installations_and_its_terms_add_up():
    sc = g.with_reflectances(g.box_room(size=(5.0, 4.0, 2.8), cell=0.4))
    droom = DesignRoom(sc, 0)
    lums = [Luminaire(position=np.array([x, y, 2.78]), normal=np.array([0.0, 0.0, -1.0]),
                      flux_lm=3000.0, radius_m=0.3)
            for x in (1.25, 3.75) for y in (1.0, 3.0)]
    pts = droom.grid(0.8, 0.5)[0]
    u = {mf: room_ugr(RoomModel(sc, droom, pts, mf, backend="numpy"), droom, lums)
         for mf in (0.5, 0.8, 1.0)}
    assert u[0.5] == pytest.approx(u[1.0], abs=1e-9) == pytest.approx(u[0.8], abs=1e-9)
    # the same figure from the formula with the unmaintained interreflected light at the
    # eyes (an MF in the background would move it by 8 log10(1 / 0.8) = 0.78)
    model = RoomModel(sc, droom, pts, 0.8, backend="numpy")
    obs = observers(droom)
    eyes, views = np.array([e for e, _ in obs]), np.array([v for _, v in obs])
    lb = model.indirect_at(eyes, views, lums)
    assert lb.min() > 10.0
    by_hand = max(x for x in (ugr(lums, e, v, b) for (e, v), b in zip(obs, lb))
                  if x is not None)
    assert u[0.8] == pytest.approx(by_hand, abs=1e-9)
    # glare_terms gives the parts the design's programme adds up (the whole's openings
    # in place), on the same footing
    t1, b1 = glare_terms(model, droom, lums[:2], covering=lums)
    t2, b2 = glare_terms(model, droom, lums[2:], covering=lums)
    assert np.nanmax(ugr_from_sum(t1 + t2, b1 + b2)) == pytest.approx(u[0.8], abs=1e-6)


def test_the_searchs_ugr_paths_rate_the_installation_new_as_room_ugr():
    """The search's UGR figures (search.fast_ugr of the table, search.exact_glare of a
    layout, and the per-group programme's background rows, refine._fast_parts) count the
    background as room_ugr does, new: the same figures whatever the model's maintenance
    factor (which scales the maintained lux only), and exact_glare gives room_ugr's UGR."""
    from invrad_wb.core.design.design import _with_surroundings
    from invrad_wb.core.design.evaluate import surface_grids
    from invrad_wb.core.design.refine import _fast_parts, groups_of
    from invrad_wb.core.design.search import RoomSearch
    from invrad_wb.core.design.spec import spec_from_dict
    sc = g.with_reflectances(g.box_room(size=(5.0, 4.0, 2.8), cell=0.5))
    spec = spec_from_dict({"maintenance_factor": 0.8, "rooms": {"0": {
        "work_plane": {"lux": 500, "u0": 0.6}, "ugr_max": 19}}, "catalogue": [
        {"name": "DL-3500", "flux_lm": 3500, "watts": 26.0, "dimming": [0.1, 1.0],
         "radius_m": 0.25}]})
    rs, droom = spec.room_spec(0), DesignRoom(sc, 0)
    req = rs.work_plane
    pts, _ = droom.grid(req.height_m, req.margin_m)
    surfaces = surface_grids(sc, 0, droom)
    rs = _with_surroundings(rs, droom, req, surfaces, type("RD", (), {"notes": []})())
    model = RoomModel(sc, droom, pts, 0.8, surfaces=surfaces, backend="numpy")
    search = RoomSearch(model, req, rs, spec.entries_for(rs, 2.8), {}, mixed=False)
    search._calibrate_all()
    assert search.obs and search.ugr_max == 19
    t = search.table()
    cand = search.candidate(t, int(np.flatnonzero(np.isfinite(t["ugr"]))[0]))
    lums = search.luminaires(cand)
    groups = groups_of(cand.geom.plan, cand.geom.cls)
    sel = np.arange(len(search.geoms))
    pair = (0, 0)

    def figures():
        return (search.fast_ugr(pair, sel, np.full(len(sel), 0.7)),
                search.exact_glare(lums)[1], _fast_parts(search, cand, groups)[1][1])

    at_08 = figures()
    total, lb = search.exact_glare(lums)
    assert np.nanmax(ugr_from_sum(total, lb)) == pytest.approx(
        room_ugr(model, droom, lums), abs=1e-9)
    model.mf = 0.5                      # the maintained lux x 0.625; UGR stays
    for a, b in zip(at_08, figures()):
        assert np.isfinite(a).any() and np.array_equal(a, b, equal_nan=True)
