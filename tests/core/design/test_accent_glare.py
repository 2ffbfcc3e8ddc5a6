"""The accents' glare in the general lighting's design: a painted spot's accent panel by the
back wall of an office, seen by the CIE 117 observers, is diluted only by the background
luminance the general lighting gives; the general lighting is designed with the accents'
glare sums and background as constants of its UGR rows, so the whole room meets UGR."""
import math

import numpy as np
import pytest

from invrad_wb.core.design.design import design_room
from invrad_wb.core.design.evaluate import RoomModel
from invrad_wb.core.design.refine import ugr_rows
from invrad_wb.core.design.room import DesignRoom
from invrad_wb.core.design.roomglare import glare_terms, room_ugr
from invrad_wb.core.design.spec import spec_from_dict
from invrad_wb.core.model.scene import Scene
from invrad_wb.core.output.glare import ugr_from_sum
from invrad_wb.core.synthetic import generate as g

#: the design panel's default catalogue (round panels with a luminous opening)
PANELS = [{"name": "Panel 1000 lm", "flux_lm": 1000.0, "watts": 8.5, "radius_m": 0.3},
          {"name": "Panel 2000 lm", "flux_lm": 2000.0, "watts": 15.5, "radius_m": 0.3},
          {"name": "Panel 3500 lm", "flux_lm": 3500.0, "watts": 26.0, "radius_m": 0.3,
           "dimming": [0.1, 1.0]}]


def test_ugr_rows_hold_the_fixed_glare_as_a_constant():
    """``ugr_rows`` with fixed terms: at outputs x with s = x^2, the observers' rows are met
    exactly where UGR of the groups plus the fixed luminaires is within the limit."""
    rng = np.random.default_rng(3)
    G, O = 3, 4
    T = rng.uniform(1e3, 5e4, (G, O))
    B = rng.uniform(20.0, 80.0, (G, O))
    T0, B0 = rng.uniform(1e3, 2e4, O), rng.uniform(5.0, 30.0, O)
    limit = 19.0
    K = 10.0 ** (limit / 8.0)
    lo, hi = np.full(G, 0.1), np.ones(G)
    n = 2 * G
    rows, ub = ugr_rows(T, B, K, lo, hi, G, n, G, fixed=(T0, B0))
    plain, ub_plain = ugr_rows(T, B, K, lo, hi, G, n, G)
    assert np.array_equal(rows, plain) and np.all(ub_plain[:O] == 0.0)
    for _ in range(200):
        x = rng.uniform(0.1, 1.0, G)
        v = np.r_[x, x ** 2]
        met = bool(np.all(rows[:O] @ v <= ub[:O]))
        u = ugr_from_sum((x ** 2) @ T + T0, x @ B + B0)
        assert met == bool(np.max(u) <= limit), (x, u)


def _office_with_a_spot(size, spot, cell=0.2):
    """A box office with an 800 lx cosine spot (0.8 m radius) painted on its back wall
    (y = size[1]), as the GUI smoke test paints one."""
    w, d, _ = size
    base = g.with_reflectances(g.box_room(size=size, cell=cell))
    v, nrm = base.vertices, base.vertex_normals
    on = (np.abs(v[:, 1] - d) < 1e-9) & (np.abs(nrm[:, 1]) > 0.5)
    r = np.linalg.norm(v - np.asarray(spot), axis=1)
    lux = np.full(len(v), np.nan)
    m = on & (r < 0.8)
    lux[m] = 800.0 * np.cos(0.5 * math.pi * r[m] / 0.8)
    return Scene(v, base.faces, vertex_lux=lux, face_room=base.face_room,
                 face_reflectance=base.face_reflectance, check_winding=False)


def test_accent_glare_is_designed_for_by_the_general_lighting():
    """An office with a desk area and an 800 lx spot on its back wall: the spot gets an
    accent panel at full output, whose glare the CIE 117 observers facing the back wall
    see; with the general lighting designed alone the whole installation breaks UGR 19
    (19.5: the general lighting 18.6 alone, the accent 21.0 alone, diluted by the general
    lighting's background only). Designed with the accent's glare as a
    constant, the whole room meets UGR as the judge (room_ugr on a fresh model) computes
    it, and every other requirement, the spot included."""
    size = (4.2, 3.4, 2.8)
    sc = _office_with_a_spot(size, (2.6, 3.4, 1.7))
    spec = spec_from_dict({
        "maintenance_factor": 0.8, "catalogue": PANELS,
        "rooms": {"0": {"room_type": "office", "work_plane": {
            "height_m": 0.8, "task_areas": [{"name": "desks",
                                             "rect": [0.9, 0.9, 3.1, 2.6]}]}}}})
    rd = design_room(sc, spec, 0)
    accents = [lum for lum in rd.luminaires if lum.extra.get("role") == "accent"]
    general = [lum for lum in rd.luminaires if lum.extra.get("role") != "accent"]
    assert accents and rd.verdicts["spots"], rd.notes
    assert rd.compliant, (rd.verdicts, rd.ugr, rd.notes)
    # the judge, independently of the design's own figures: the whole installation's UGR
    droom = DesignRoom(sc, 0)
    model = RoomModel(sc, droom, droom.grid(0.8, 0.5)[0], 0.8)
    whole = room_ugr(model, droom, rd.luminaires)
    assert whole <= 19.0 + 1e-9 and whole == pytest.approx(rd.ugr, abs=1e-6)
    # the accent alone over the limit at some observer, diluted by the general lighting's
    # background (light adds up: the parts' terms give the whole's UGR)
    ta, ba = glare_terms(model, droom, accents)
    tg, bg = glare_terms(model, droom, general)
    assert np.nanmax(ugr_from_sum(ta, ba)) > 19.0
    assert np.nanmax(ugr_from_sum(ta + tg, ba + bg)) == pytest.approx(whole, abs=0.1)
    assert any("designed again for the accents' glare" in n for n in rd.notes), rd.notes
