"""``locate --aim free`` with free fluxes (issue 23): a beam's light traded between the
spot and a second luminaire far from it that lights the same footprint (a ghost) is
resolved into the one spot (:func:`invrad_wb.core.inverse.aim.footprint_merge`)."""
import os

import numpy as np
import pytest

from invrad_wb.core.forward.render import render
from invrad_wb.core.inverse import locate as locate_mod
from invrad_wb.core.inverse.aim import MERGE_OVERLAP, _aimed_light, _overlap, footprint_merge
from invrad_wb.core.inverse.locate import LocateSettings, locate
from invrad_wb.core.inverse.locate_count import CountSearch
from invrad_wb.core.inverse.locate_fit import _RoomFit
from invrad_wb.core.model import aiming
from invrad_wb.core.model.luminaires import Luminaire
from invrad_wb.core.model.photometry import read_photometry
from invrad_wb.core.synthetic import generate
from repo_paths import PHOTOMETRY

DOWN = np.array([0.0, 0.0, -1.0])


class _Stop(Exception):
    pass


@pytest.fixture(scope="module")
def floor_spot_room(monkeypatch_module):
    """A ceiling spot aimed 30 degrees at the floor beside a downlight (direct light,
    fluxes unknown): the room's refinement problem, as locate builds it."""
    phot = read_photometry(os.path.join(PHOTOMETRY, "spot.ies"))
    scene = generate.box_room((4.0, 3.0, 2.7), cell=0.1, reflectance=0.0)
    aim = aiming.aim_from_tilt_pan(DOWN, 30.0, 0.0)             # towards +x
    true = [Luminaire([1.8, 1.6, 2.7], aim, 1200.0, photometry=phot,
                      c0=aiming.aimed_c0(DOWN, aim)),
            Luminaire([0.8, 0.7, 2.7], DOWN, 1200.0, photometry=phot)]
    lux = render(scene, true, interreflection=False, backend="numpy")
    got = {}

    def capture(run, s, flux, **_kw):
        got["run"], got["s"] = run, s
        raise _Stop

    monkeypatch_module.setattr(locate_mod, "_postprocess", capture)
    # no votes: the test starts from given luminaires
    monkeypatch_module.setattr(
        locate_mod, "_vote_function",
        lambda canvas, *_a, **_k: lambda *_b, **_c: np.zeros(canvas.size, np.float32))
    with pytest.raises(_Stop):
        locate(scene.with_vertex_lux(lux), None,
               LocateSettings(aim="free", indirect="none", dummy_planes=False), photometry=phot,
               backend="numpy")
    return got["run"], got["s"], true


@pytest.fixture(scope="module")
def monkeypatch_module():
    mp = pytest.MonkeyPatch()
    yield mp
    mp.undo()


def _light(run, s, lum, flux, ceiling=True):
    """``lum`` (position, aim) as an aimable refinement light on the ceiling or a wall."""
    canvas = run.canvas
    for k, m in enumerate(canvas.maps):
        if m.kind == "surface" and ((m.normal[2] < -0.9) == ceiling) \
                and abs(lum[0] @ m.normal + m.offset) < 1e-6 and canvas.map_contains(k, lum[0]):
            return run.problem.with_indirect(_aimed_light(canvas, k, lum[0], lum[1], s,
                                                          scale=flux / run.flux))
    raise AssertionError(f"no map holds {lum[0]}")


def _assert_each_found(true, found, run):
    """Each true luminaire has a found one within 5 cm, 2 degrees and 5 % flux."""
    for t in true:
        f = min(found, key=lambda L: np.linalg.norm(L.position - t.position))
        assert np.linalg.norm(f.position - t.position) < 0.05
        assert np.degrees(np.arccos(np.clip(f.normal @ t.normal, -1, 1))) < 2.0
        assert f.flux_scale * run.flux == pytest.approx(t.flux_lm, rel=0.05)


def test_a_ghost_sharing_a_spot_footprint_is_merged_away(floor_spot_room):
    run, s, true = floor_spot_room
    spot, down = true
    hit = spot.position + spot.normal * (spot.position[2] / -spot.normal[2])  # on the floor
    # the ghost's start: the spot 0.3 m off with 80 % of the flux, and a wall light on
    # y = 0 aimed at the same floor spot with the rest; the downlight as it is
    off = spot.position + np.array([-0.3, 0.1, 0.0])
    wall = np.array([2.6, 0.0, 2.3])
    start = [_light(run, s, (off, (hit - off) / np.linalg.norm(hit - off)), 960.0),
             _light(run, s, (wall, (hit - wall) / np.linalg.norm(hit - wall)), 240.0,
                    ceiling=False),
             _light(run, s, (down.position, DOWN), 1200.0)]
    fit = _RoomFit(run, s)
    lights, cost = fit.opt(start)
    search = CountSearch(fit)
    lights, cost = search.run(lights, cost)
    # the two share one footprint: the wall light's light lies inside the spot's
    own = [fit.prob.fixed_light([L]) for L in lights]
    assert len(lights) == 3
    assert max(_overlap(own[i], own[j], fit.prob.w_area)
               for i in range(3) for j in range(i + 1, 3)) > MERGE_OVERLAP
    merged, c = footprint_merge(fit, search, lights, cost)
    assert len(merged) == 2, [(L.position, L.flux_scale * run.flux) for L in merged]
    assert c < cost
    _assert_each_found(true, merged, run)


def test_beams_that_overlap_but_are_both_needed_stay_two(floor_spot_room):
    """The true spot and downlight: nothing merged, nothing moved."""
    run, s, true = floor_spot_room
    spot, down = true
    start = [_light(run, s, (spot.position, spot.normal), spot.flux_lm),
             _light(run, s, (down.position, DOWN), down.flux_lm)]
    fit = _RoomFit(run, s)
    lights, cost = fit.opt(start)
    got, c = footprint_merge(fit, CountSearch(fit), lights, cost, overlap=0.0)
    assert len(got) == 2 and c == cost


def test_a_wall_light_standing_in_for_a_spot_is_split_then_merged(floor_spot_room):
    """One wall light aimed at the floor spot's footprint in the spot's place (the bench
    lobby --seed 8's first selection): the aimed count search splits it, merges the
    pieces' shared footprint at once, and ends with the true spot and downlight."""
    from invrad_wb.core.inverse.aim import AimedCountSearch
    run, s, true = floor_spot_room
    spot, down = true
    hit = spot.position + spot.normal * (spot.position[2] / -spot.normal[2])
    wall = np.array([1.6, 0.0, 2.4])
    start = [_light(run, s, (wall, (hit - wall) / np.linalg.norm(hit - wall)), 1200.0,
                    ceiling=False),
             _light(run, s, (down.position, DOWN), 1200.0)]
    fit = _RoomFit(run, s)
    lights, cost = fit.opt(start)
    search = AimedCountSearch(fit)
    got, c = search.run(lights, cost)
    assert any("footprint_merges" in t and t["footprint_merges"] for t in fit.trace)
    assert len(got) == 2, [(L.position, L.flux_scale * run.flux) for L in got]
    assert c < cost
    _assert_each_found(true, got, run)


def test_polishing_many_apexes_at_once_is_the_one_at_a_time_search(floor_spot_room):
    """aim._polish_many (all apexes' pattern searches scored in one batch) ends where
    aim._polish, one apex at a time, ends: apex, aim, flux scale and cost."""
    from invrad_wb.core.inverse.aim import _Scorer, _polish, _polish_many, apex_grid
    run, s, true = floor_spot_room
    spot = true[0]
    hit = spot.position + spot.normal * (spot.position[2] / -spot.normal[2])
    P, Mn, K = apex_grid(run.canvas)
    ceiling = np.flatnonzero(Mn[:, 2] < -0.9)
    pick = ceiling[np.argsort(np.linalg.norm(P[ceiling] - spot.position, axis=1))[[0, 5, 12]]]
    up = np.array([0.0, 0.0, 1.0])
    jobs = [(K[i], P[i], hit, up, Mn[i]) for i in pick]
    jobs.append((K[pick[0]], P[pick[0]], hit + np.array([-1.0, 0.5, 0.0]), up, Mn[pick[0]]))
    scorer = _Scorer(run.problem)
    # beside the downlight's light: the spot's footprint is what is left to explain
    scorer.add_base(run.problem.fixed_light([_light(run, s, (true[1].position, DOWN),
                                                    1200.0)]))
    cos_max = np.cos(np.radians(s.max_tilt_deg))
    many = _polish_many(scorer, run.canvas, jobs, True, cos_max)
    assert len(many) == len(jobs)
    for job, got in zip(jobs, many):
        want = _polish(scorer, run.canvas, job[0], job[1], job[2], job[3], job[4], True,
                       cos_max)
        np.testing.assert_allclose(got[0], want[0], atol=1e-9)
        np.testing.assert_allclose(got[1], want[1], atol=1e-9)
        assert got[2] == pytest.approx(want[2], rel=1e-9)
        assert got[3] == pytest.approx(want[3], rel=1e-9, abs=1e-15)
    # the apex nearest the spot, aimed at its hit, polishes to (near) the spot itself
    assert np.linalg.norm(many[0][0] - spot.position) < 0.1, many[0]
