"""The ceiling behind a luminaire's luminous opening is the luminaire, not ceiling: the
design's exact model leaves those receivers out of its surface grids' figures (as the
Radiance judge does). Counted in, a panel near a wall put the brightest ceiling spots
(next to the lit wall) into the mean: +16-18 % over Radiance in a box, +5 % in the L
corridor (bench_wall_light.py)."""
import numpy as np
import pytest

from invrad_wb.core.design import openings
from invrad_wb.core.synthetic import generate as g


def _panel_model():
    from invrad_wb.core.design import evaluate as ev
    from invrad_wb.core.model.photometry import Photometry
    lam = Photometry.lambertian()
    panel = Photometry(lam.table, 1.0, name="panel", luminous_area_m2=0.36,
                       luminous_extent_m=(0.6, 0.6))
    model = ev.RoomModel(*_panel_model_args())
    return ev, model, panel, lam


def _panel_model_args():
    """RoomModel's arguments for a 4 x 3 x 2.6 m box (numpy backend)."""
    from invrad_wb.core.design import evaluate as ev
    from invrad_wb.core.design.room import DesignRoom
    sc = g.with_reflectances(g.box_room(size=(4.0, 3.0, 2.6), cell=0.3))
    droom = DesignRoom(sc, 0)
    surfaces = ev.surface_grids(sc, 0, droom)
    pts = np.array([[2.0, 1.5, 0.8], [1.0, 1.0, 0.8]])
    return sc, droom, pts, 0.8, "numpy", None, surfaces


def _lum(at, ph, flux=3000.0):
    from invrad_wb.core.model.luminaires import Luminaire
    return Luminaire(np.array(at, float), np.array([0.0, 0.0, -1.0]), flux, room=0,
                     photometry=ph)


def test_ceiling_figures_leave_out_the_receivers_behind_an_opening():
    ev, model, panel, lam = _panel_model()
    lum = _lum([0.45, 1.5, 2.6], panel)          # its opening 0.15 m from the wall
    sl, w = model.layout.parts["ceiling"]
    hidden = openings.behind_openings(model.points[sl], model.normals[sl], [lum])
    assert 0 < hidden.sum() < len(hidden)
    # only ceiling receivers inside the opening's rectangle
    d = model.points[sl][hidden] - lum.position
    assert np.all(np.abs(d[:, :2]) <= 0.3 + 1e-9) and np.all(np.abs(d[:, 2]) < 0.05)
    assert not openings.behind_openings(model.points[sl], model.normals[sl],
                                  [_lum([0.45, 1.5, 2.6], lam)]).any()   # a point source
    lux, direct = model.exact([lum])
    raw = model._behind
    model._behind = lambda openings: None
    try:
        lux_raw, _ = model.exact([lum])
    finally:
        model._behind = raw
    free = ~hidden
    mean_free = np.sum(lux_raw[sl][free] * w[free]) / w[free].sum()
    mean_all = np.sum(lux_raw[sl] * w) / w.sum()
    # next to the lit wall the hidden spots read bright: counting them overstated the mean
    assert mean_all > 1.03 * mean_free
    assert np.sum(lux[sl] * w) / w.sum() == pytest.approx(mean_free, rel=1e-9)
    assert lux[sl].min() == pytest.approx(lux_raw[sl][free].min(), rel=1e-9)
    # the other receivers are untouched (work plane, walls, the free ceiling)
    assert np.array_equal(lux[:model.n_wp], lux_raw[:model.n_wp])
    assert np.array_equal(lux[sl][free], lux_raw[sl][free])


def test_left_out_receivers_keep_the_light_linear_for_one_installation():
    """Parts of an installation lit alone with the whole one's openings in place add up
    to the whole (the design's per-group solves rely on it)."""
    ev, model, panel, _ = _panel_model()
    a, b = _lum([0.45, 1.5, 2.6], panel), _lum([3.0, 1.0, 2.6], panel, 2000.0)
    whole, wd = model.exact([a, b])
    pa, pad = model.exact([a], covering=[a, b])
    pb, pbd = model.exact([b], covering=[a, b])
    # (the solves with the openings in place iterate to RADIOSITY_TOL)
    assert np.allclose(pa + pb, whole, rtol=1e-4, atol=1e-6)
    assert np.allclose(pad + pbd, wd, rtol=1e-9, atol=1e-9)
    # and the hidden receivers are those of both openings in every part
    sl, _ = model.layout.parts["ceiling"]
    h = openings.behind_openings(model.points[sl], model.normals[sl], [a, b])
    assert np.ptp(pa[sl][h]) == pytest.approx(0.0, abs=1e-9)


def test_a_kept_solve_is_given_back_only_for_the_same_luminaires_and_openings():
    """RoomModel.solve keeps its last solves (a design check solves each layout for its
    grid, the UGR background and the cylindrical eyes): the same layout gets the kept
    exitance, any change of position, flux, distribution or covering openings a new one,
    equal to what a fresh model solves."""
    from dataclasses import replace
    ev, model, panel, lam = _panel_model()
    a, b = _lum([0.45, 1.5, 2.6], panel), _lum([3.0, 1.0, 2.6], panel, 2000.0)
    first = model.solve([a, b])
    assert model.solve([replace(a), replace(b)]) is first       # equal copies: kept
    with pytest.raises(ValueError):
        first[0] = 0.0                                           # kept solves are read-only
    fresh = ev.RoomModel(*_panel_model_args())
    for change in ([replace(a, position=a.position + [0.1, 0.0, 0.0]), b],
                   [replace(a, flux_lm=2500.0), b],
                   [replace(a, photometry=lam), b]):
        got = model.solve(change)
        assert got is not first
        assert np.allclose(got, fresh.solve(change), rtol=1e-12, atol=0.0)
    alone = model.solve([a], covering=[a, b])
    assert alone is not model.solve([a])
    assert np.allclose(alone, fresh.solve([a], covering=[a, b]), rtol=1e-12, atol=0.0)
    assert not np.allclose(alone, fresh.solve([a]))
