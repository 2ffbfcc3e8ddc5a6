"""UGR (CIE 117 formula method) against a hand computation and its limits."""
import math

import numpy as np
import pytest

from invrad_wb.core.model.luminaires import Luminaire
from invrad_wb.core.output.glare import guth_index, observers, ugr


def test_one_luminaire_by_hand():
    # eye at 1.2 m looking along +x; a lambertian disk (r = 0.1 m, 3000 lm) at (3, 0, 3)
    F, R = 3000.0, 0.1
    lum = Luminaire([3.0, 0.0, 3.0], [0, 0, -1], F, R)
    d = np.array([3.0, 0.0, 1.8])
    dist = float(np.linalg.norm(d))
    sigma = math.degrees(math.atan2(1.8, 3.0))          # 30.96 deg above the line of sight
    tau = 0.0                                           # straight ahead: vertical plane
    p = math.exp((35.2 - 0.31889 * tau - 1.22 * math.exp(-2 * tau / 9)) * 1e-3 * sigma
                 + (21 + 0.26667 * tau - 0.002963 * tau ** 2) * 1e-5 * sigma ** 2)
    cos_e = 1.8 / dist
    luminance = (F / math.pi * cos_e) / (math.pi * R * R * cos_e)   # cd/m^2, lambertian
    omega = math.pi * R * R * cos_e / dist ** 2
    lb = 100.0 / math.pi
    expected = 8 * math.log10(0.25 / lb * luminance ** 2 * omega / p ** 2)
    got = ugr([lum], [0, 0, 1.2], [1, 0, 0], background_lux=100.0)
    assert got == pytest.approx(expected, abs=1e-6)
    assert p == pytest.approx(3.50, abs=0.01)


def test_limits_and_symmetry():
    lum = Luminaire([3.0, 0.5, 3.0], [0, 0, -1], 3000.0, 0.1)
    low = ugr([lum], [0, 0, 1.2], [1, 0, 0], background_lux=50.0)
    high = ugr([lum], [0, 0, 1.2], [1, 0, 0], background_lux=200.0)
    assert high < low and low - high == pytest.approx(8 * math.log10(4), abs=1e-9)
    mirrored = Luminaire([3.0, -0.5, 3.0], [0, 0, -1], 3000.0, 0.1)
    assert ugr([mirrored], [0, 0, 1.2], [1, 0, 0], 50.0) == pytest.approx(low)
    # behind the observer or below the eye: no glare
    assert ugr([lum], [0, 0, 1.2], [-1, 0, 0], 50.0) is None
    assert ugr([Luminaire([3, 0, 1.0], [0, 0, -1], 3000.0, 0.1)], [0, 0, 1.2], [1, 0, 0],
               50.0) is None
    # without a luminous area: a CIE 147 small source, 8 log(0.25 / Lb sum 200 I^2/(r^2 p^2))
    point = Luminaire([3, 0, 3], [0, 0, -1], 3000.0)
    d = np.array([3.0, 0.0, 1.8])
    r = float(np.linalg.norm(d))
    i_cd = 3000.0 / math.pi * (1.8 / r)
    p = float(guth_index(0.0, math.degrees(math.atan2(1.8, 3.0))))
    small = 8 * math.log10(0.25 / (50.0 / math.pi) * 200 * i_cd ** 2 / (r ** 2 * p ** 2))
    assert ugr([point], [0, 0, 1.2], [1, 0, 0], 50.0) == pytest.approx(small, abs=1e-9)
    # ... the most glaring reading: any real opening glares less
    assert ugr([point], [0, 0, 1.2], [1, 0, 0], 50.0) > ugr(
        [Luminaire([3, 0, 3], [0, 0, -1], 3000.0, 0.1)], [0, 0, 1.2], [1, 0, 0], 50.0)
    # the position index grows away from the line of sight, sideways faster
    assert guth_index(0, 10) < guth_index(0, 40)
    assert guth_index(60, 30) != guth_index(0, 30)


def test_standard_observers_of_a_room():
    from invrad_wb.core.design.room import DesignRoom
    from invrad_wb.core.synthetic import generate as g
    dr = DesignRoom(g.box_room(size=(6.0, 4.0, 3.0), cell=0.5), 0)
    obs = observers(dr)
    assert len(obs) == 4
    for eye, view in obs:
        assert eye[2] == pytest.approx(1.2)
        assert dr.inside(eye[None, :2])[0]
        # each looks into the room, along an axis
        assert np.isclose(abs(view[0]) + abs(view[1]), 1.0)
        assert dr.inside((eye[:2] + view[:2] * 1.0)[None])[0]


def test_design_reports_ugr_against_the_room_type_limit():
    from invrad_wb.core.design.design import design_room
    from invrad_wb.core.design.spec import spec_from_dict
    from invrad_wb.core.synthetic import generate as g
    sc = g.with_reflectances(g.box_room(size=(8.0, 6.0, 3.0), cell=0.4))
    small = {"name": "D", "flux_lm": 3000, "watts": 24, "radius_m": 0.1}
    rd = design_room(sc, spec_from_dict({"catalogue": [small], "rooms": {
        "0": {"room_type": "office"}}}), 0)
    assert rd.ugr_limit == 19 and rd.ugr is not None
    # small bright discs glare: more than the office limit, and said so
    assert rd.ugr > 19 and not rd.verdicts["UGR"] and not rd.compliant
    assert any("UGR" in n for n in rd.notes)
    # point emitters have no luminous area: rated as CIE 147 small sources (an upper
    # bound), judged, and said so
    rd = design_room(sc, spec_from_dict({"catalogue": [dict(small, radius_m=0.0)],
                                         "rooms": {"0": {"room_type": "office"}}}), 0)
    assert rd.ugr is not None and rd.ugr > 19 and not rd.verdicts["UGR"]
    assert any("small source" in n for n in rd.notes)
    # ... and the closest design still meets the work plane, walls and ceiling
    assert rd.verdicts["Em"] and rd.verdicts["U0"]
    assert rd.verdicts["walls"] and rd.verdicts["ceiling"]


def test_vectorised_glare_terms_match_the_scalar_formula():
    from invrad_wb.core.output.glare import ugr_from_sum, unit_glare
    rng = np.random.default_rng(3)
    pos = np.c_[rng.uniform(-4, 6, 30), rng.uniform(-3, 3, 30), rng.uniform(1.0, 3.5, 30)]
    nrm = np.tile([0.0, 0.0, -1.0], (30, 1))
    nrm[::3] = [0.3, 0.0, -0.954]
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    eye, view = np.array([0.0, 0.0, 1.2]), np.array([1.0, 0.2, 0.0])
    for radius in (0.0, 0.02, 0.3):
        lums = [Luminaire(p, n, 2000.0, radius) for p, n in zip(pos, nrm)]
        terms = unit_glare(eye, view, pos, nrm, math.pi * radius ** 2 if radius else None)
        want = ugr(lums, eye, view, 120.0)
        got = float(ugr_from_sum(2000.0 ** 2 * terms.sum(), 120.0))
        assert got == pytest.approx(want, abs=1e-9)


def test_observers_of_an_l_room_stand_clear_of_every_wall():
    from invrad_wb.core.design.room import DesignRoom
    from invrad_wb.core.synthetic import generate as g
    # 8 x 6 m with a 4 x 3 m corner cut out: the middle of the cut side of the bounding
    # rectangle (4, 5.5) lies on the inner corner's wall, (7.5, 3) outside the floor
    dr = DesignRoom(g.l_room(size=(8.0, 6.0, 3.0), cut=(4.0, 3.0), cell=0.25), 0)
    obs = observers(dr)
    assert len(obs) == 4
    eyes = np.array([e[:2] for e, _ in obs])
    assert np.all(dr.wall_distance(eyes) >= 0.5 - 1e-6)
    for eye, view in obs:
        # with its back to a wall 0.5 m behind it, looking into the room
        back = eye[:2] - view[:2] * 0.55
        assert not dr.inside(back[None])[0]
        assert dr.inside((eye[:2] + view[:2] * 1.0)[None])[0]
    # the two that moved stand in the middle of the wall that is really there: the right
    # wall (x = 8, y 0..3) and the top wall (y = 6, x 0..4)
    got = np.array(sorted(map(tuple, eyes)))
    want = np.array(sorted([(0.5, 3.0), (7.5, 1.5), (4.0, 0.5), (2.0, 5.5)]))
    assert np.allclose(got, want, atol=0.03)
    # a rectangle keeps the middles of its walls, exactly
    box = DesignRoom(g.box_room(size=(6.0, 4.0, 3.0), cell=0.5), 0)
    mids = sorted((round(float(e[0]), 9), round(float(e[1]), 9)) for e, _ in observers(box))
    assert mids == sorted([(0.5, 2.0), (5.5, 2.0), (3.0, 0.5), (3.0, 3.5)])
