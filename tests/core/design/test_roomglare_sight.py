"""UGR counts only the luminaires the observer sees (CIE 117's sum runs over the
luminaires in view): in an L, the ones behind the inner corner add nothing, one partly
hidden adds the seen share of its luminous area, and a convex room keeps its figures.

The hidden ones are found here independently of the design model's occluders: in an L
whose walls rise from floor to ceiling, a sight line from the eye to a point of a
luminaire is blocked exactly where its plan crosses the cut-out corner rectangle.
"""
import math

import numpy as np
import pytest

from invrad_wb.core.design.evaluate import RoomModel
from invrad_wb.core.design.room import DesignRoom
from invrad_wb.core.design.roomglare import glare_terms, room_ugr, seen_shares
from invrad_wb.core.model.luminaires import Luminaire
from invrad_wb.core.output.glare import observers, ugr, ugr_from_sum
from invrad_wb.core.synthetic import generate as g

#: the L: 7 x 6 x 2.8 m less the corner [4, 7] x [3, 6]
SIZE, CUT, H = (7.0, 6.0, 2.8), (4.0, 3.0), 2.8
#: disk radius of the luminaires (m)
R = 0.2


def _l_model():
    sc = g.with_reflectances(g.l_room(size=SIZE, cut=CUT, cell=0.5))
    droom = DesignRoom(sc, 0)
    return sc, droom, RoomModel(sc, droom, droom.grid(0.8, 0.5)[0], 0.8, backend="numpy")


def _lums(points):
    return [Luminaire(position=np.array([x, y, H]), normal=np.array([0.0, 0.0, -1.0]),
                      flux_lm=3000.0, radius_m=R) for x, y in points]


def _crosses_corner(a, b, n=2001):
    """Whether the plan segment a -> b passes through the cut-out corner (dense sampling:
    a reference that knows nothing of BVHs or triangles)."""
    t = np.linspace(0.0, 1.0, n)[:, None]
    p = (1 - t) * np.asarray(a[:2]) + t * np.asarray(b[:2])
    return bool(np.any((p[:, 0] > CUT[0] + 1e-9) & (p[:, 1] > CUT[1] + 1e-9)))


#: a layout over both legs: from the observers in the long leg, some of the short leg's
#: luminaires lie behind the inner corner
LAYOUT = [(1.0, 1.0), (3.0, 1.0), (5.5, 1.0), (5.5, 2.2), (1.0, 4.5), (2.8, 4.5),
          (1.0, 2.5), (3.0, 2.5)]


def test_ugr_sum_leaves_out_the_luminaires_behind_the_inner_corner():
    sc, droom, model = _l_model()
    lums = _lums(LAYOUT)
    obs = observers(droom)
    eyes, views = np.array([e for e, _ in obs]), np.array([v for _, v in obs])
    lb = model.indirect_at(eyes, views, lums)
    hidden_somewhere = 0
    by_hand = []
    for (e, v), b in zip(obs, lb):
        # each luminaire wholly seen or wholly hidden (checked at its disk's edge too)
        seen = []
        for lum in lums:
            edge = [lum.position + R * np.array([math.cos(a), math.sin(a), 0.0])
                    for a in np.linspace(0, 2 * math.pi, 16, endpoint=False)]
            hid = [_crosses_corner(e, p) for p in [lum.position] + edge]
            assert all(hid) or not any(hid), "a luminaire partly hidden: choose another"
            seen.append(not hid[0])
        hidden_somewhere += len(seen) - sum(seen)
        vis = [lum for lum, s in zip(lums, seen) if s]
        by_hand.append(ugr(vis, e, v, b) if vis else None)
        # the design model's shares: 1 for the seen, 0 for the hidden
        sh = seen_shares(model, e, np.array([x.position for x in lums]),
                         np.array([x.normal for x in lums]),
                         (0.5 * R * math.sqrt(math.pi),) * 2)
        assert np.array_equal(sh, np.array(seen, dtype=float)), (e, sh, seen)
    assert hidden_somewhere >= 2          # the layout does test what it means to
    worst = max(u for u in by_hand if u is not None)
    got = room_ugr(model, droom, lums)
    assert got == pytest.approx(worst, abs=1e-9)
    # counting every luminaire reads higher (the old sum)
    every = max(u for u in (ugr(lums, e, v, b) for (e, v), b in zip(obs, lb))
                if u is not None)
    assert every > got + 0.05
    # the design's programme adds the same visible terms up (glare_terms)
    t1, b1 = glare_terms(model, droom, lums[:4], covering=lums)
    t2, b2 = glare_terms(model, droom, lums[4:], covering=lums)
    # (the background gathered in float32: the parts add up to 1e-4)
    assert np.nanmax(ugr_from_sum(t1 + t2, b1 + b2)) == pytest.approx(got, abs=1e-4)


def test_a_luminaire_half_behind_the_corner_counts_half():
    """A square opening whose middle lies on the sight line past the inner corner: two of
    its 2 x 2 Gauss points are seen, its term counts half."""
    sc, droom, model = _l_model()
    eye = np.array([1.0, 5.5, 1.2])
    # the sight line from the eye through the corner (4, 3), followed to x = 6.5
    d = np.array([CUT[0], CUT[1]]) - eye[:2]
    c = eye[:2] + d * (6.5 - eye[0]) / d[0]
    # the opening's sides along the sight line and across it (C0 along the line)
    u = np.array([d[0], d[1], 0.0]) / np.linalg.norm(d)
    lum = Luminaire(position=np.array([c[0], c[1], H]), normal=np.array([0.0, 0.0, -1.0]),
                    flux_lm=3000.0, radius_m=0.0, c0=u)
    half = (0.3, 0.3)
    sh = seen_shares(model, eye, lum.position[None], lum.normal[None], half, u)
    w = np.cross([0.0, 0.0, -1.0], u)
    a = 0.3 / math.sqrt(3.0)
    expect = np.mean([not _crosses_corner(eye, lum.position + s * a * u + t * a * w)
                      for s in (-1, 1) for t in (-1, 1)])
    assert expect == 0.5 and sh[0] == pytest.approx(0.5)
    view = np.array([1.0, 0.0, 0.0])
    full = ugr([lum], eye, view, 100.0)
    assert ugr([lum], eye, view, 100.0, seen=[0.5]) == pytest.approx(
        full + 8 * math.log10(0.5), abs=1e-9)
    assert ugr([lum], eye, view, 100.0, seen=[0.0]) is None


def test_a_convex_room_keeps_its_figures():
    """No occluders, nothing hidden: the same UGR as every luminaire counted."""
    sc = g.with_reflectances(g.box_room(size=(5.0, 4.0, 2.8), cell=0.5))
    droom = DesignRoom(sc, 0)
    model = RoomModel(sc, droom, droom.grid(0.8, 0.5)[0], 0.8, backend="numpy")
    assert model.bvh is None
    lums = [Luminaire(position=np.array([x, y, 2.8]), normal=np.array([0.0, 0.0, -1.0]),
                      flux_lm=3000.0, radius_m=0.2) for x in (1.25, 3.75) for y in (1.0, 3.0)]
    obs = observers(droom)
    lb = model.indirect_at(np.array([e for e, _ in obs]), np.array([v for _, v in obs]), lums)
    every = max(u for u in (ugr(lums, e, v, b) for (e, v), b in zip(obs, lb))
                if u is not None)
    assert room_ugr(model, droom, lums) == every
    assert seen_shares(model, obs[0][0], np.zeros((1, 3)), np.array([[0, 0, -1.0]])) is None


def test_shares_of_luminaires_seen_before_are_not_traced_again(monkeypatch):
    """The search's fast programme asks for the same luminaires' shares in layout after
    layout: the model keeps them (the L with its column: 1076 calls, 1.2 s of an 11 s
    design, traced each time before); a new luminaire, eye or opening is traced, and the
    kept shares are the traced ones (the first call's)."""
    import invrad_wb.core.design.roomglare as rg
    sc, droom, model = _l_model()
    eye = np.array([1.0, 5.5, 1.2])
    pos = np.array([[x, y, H] for x, y in LAYOUT])
    nrm = np.tile([0.0, 0.0, -1.0], (len(pos), 1))
    half = (0.15, 0.15)
    first = seen_shares(model, eye, pos, nrm, half)
    traced = []
    real = rg.segments_occluded
    monkeypatch.setattr(rg, "segments_occluded",
                        lambda *a: traced.append(len(a[1])) or real(*a))
    again = seen_shares(model, eye, pos[::-1], nrm, half)
    assert np.array_equal(again, first[::-1]) and traced == []
    # one new position among the known ones: its 4 Gauss points are traced, alone
    more = np.vstack([pos, [[6.5, 2.0, H]]])
    got = seen_shares(model, eye, more, np.tile([0.0, 0.0, -1.0], (len(more), 1)), half)
    assert traced == [4] and np.array_equal(got[:-1], first)
    # another eye or opening is its own question
    seen_shares(model, eye + [0.5, 0.0, 0.0], pos, nrm, half)
    seen_shares(model, eye, pos, nrm, (0.3, 0.3))
    assert traced[1:] == [4 * len(pos)] * 2
