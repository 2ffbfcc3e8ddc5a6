"""Design accents with aimed spots (issue 23): painted spots on a gallery's walls lit by
adjustable ceiling spots of an aimable catalogue, checked by a fresh forward solve (direct
light with shadows plus radiosity) independent of the design's search."""
import json
import math
import os

import numpy as np
import pytest

from invrad_wb.core.design.design import design_room
from invrad_wb.core.design.evaluate import RoomModel
from invrad_wb.core.design.room import DesignRoom
from invrad_wb.core.design.spec import spec_from_dict
from invrad_wb.core.forward.direct import direct_illuminance_numpy
from invrad_wb.core.forward.render import render
from invrad_wb.core.model.aiming import aimed_c0
from invrad_wb.core.model.luminaires import Luminaire
from invrad_wb.core.model.photometry import read_photometry
from invrad_wb.core.model.scene import Scene
from invrad_wb.core.synthetic import generate as g
from invrad_wb.errors import SettingsError

DOWN = np.array([0.0, 0.0, -1.0])
MF = 0.8
#: the painted spots' beams: cos^n intensity (n 40: about 21 deg, 15: 35 deg, 6: 55 deg)
BEAMS = {"SPOT-20": 40, "SPOT-35": 15, "FLOOD-55": 6}
GENERAL = [{"name": "DL-1000", "flux_lm": 1000, "watts": 8.5, "dimming": [0.1, 1.0],
            "radius_m": 0.3},
           {"name": "DL-2000", "flux_lm": 2000, "watts": 15.5, "dimming": [0.1, 1.0],
            "radius_m": 0.3}]


def _cos_n_ies(folder, n, flux=1000.0):
    """An IES file of I = F (n + 1) / (2 pi) cos^n(gamma) (rotationally symmetric)."""
    gammas = [2.5 * i for i in range(73)]
    cd = [flux * (n + 1) / (2 * math.pi) * max(math.cos(math.radians(x)), 0.0) ** n
          for x in gammas]
    path = os.path.join(folder, f"cos{n}.ies")
    with open(path, "w") as fh:
        fh.write("\n".join(["IESNA:LM-63-2002", f"[TEST] cos^{n} beam", "TILT=NONE",
                            f"1 {flux:g} 1 {len(gammas)} 1 1 2 0.06 0.06 0.0", "1.0 1.0 10",
                            " ".join(f"{x:g}" for x in gammas), "0",
                            " ".join(f"{v:.4f}" for v in cd)]) + "\n")
    return path


def _catalogue(folder, max_tilt=45.0):
    cat = [dict(e) for e in GENERAL]
    for name, n in BEAMS.items():
        _cos_n_ies(folder, n)
        cat.append({"name": name, "flux_lm": 1000, "watts": 10.0, "dimming": [0.1, 1.0],
                    "photometry": f"cos{n}.ies", "aimable": True, "max_tilt_deg": max_tilt})
    return cat


def _gallery(folder):
    """A 6 x 4 x 3 m gallery with three paintings' light painted on three walls: the light
    of aimed spots as the architect wants it (a small one, a large one, a long one lit by
    two), where it is at least 20 % of its peak, on top of 150 lx of ambient light."""
    phot = {k: read_photometry(_cos_n_ies(folder, n)) for k, n in BEAMS.items()}
    base = g.with_reflectances(g.box_room(size=(6.0, 4.0, 3.0), cell=0.15))
    v, nv = base.vertices, base.vertex_normals

    def spot(pos, hit, name, flux):
        a = np.asarray(hit, float) - pos
        a /= np.linalg.norm(a)
        return Luminaire(pos, a, flux, photometry=phot[name], c0=aimed_c0(DOWN, a))

    paintings = [
        ((6.0, 2.0, 1.6), (-1, 0, 0), [spot([5.1, 2.0, 3.0], [6.0, 2.0, 1.6], "SPOT-20", 500)]),
        ((2.0, 0.0, 1.5), (0, 1, 0), [spot([2.0, 0.85, 3.0], [2.0, 0.0, 1.5], "FLOOD-55", 900)]),
        ((3.5, 4.0, 1.6), (0, -1, 0), [spot([3.0, 3.15, 3.0], [3.0, 4.0, 1.6], "SPOT-35", 600),
                                       spot([4.0, 3.15, 3.0], [4.0, 4.0, 1.6], "SPOT-35",
                                            600)])]
    lux = np.full(len(v), np.nan)
    masks = []
    for centre, normal, lums in paintings:
        on = (np.abs((v - centre) @ np.asarray(normal, float)) < 1e-9) & (nv @ normal > 0.5)
        e = MF * direct_illuminance_numpy(v[on], nv[on], lums, occlusion=False)
        keep = e >= 0.2 * e.max()
        m = np.zeros(len(v), bool)
        m[np.flatnonzero(on)[keep]] = True
        lux[m] = e[keep] + 150.0
        masks.append(m)
    sc = Scene(v, base.faces, vertex_lux=lux, face_room=base.face_room,
               face_reflectance=base.face_reflectance, check_winding=False)
    return sc, masks, [p[0] for p in paintings]


def _vertex_areas(sc):
    return np.bincount(sc.faces.reshape(-1), weights=np.repeat(sc.face_areas / 3, 3),
                       minlength=len(sc.vertices))


def test_gallery_paintings_lit_by_aimed_spots_meet_peak_size_and_mean(tmp_path):
    sc, masks, centres = _gallery(str(tmp_path))
    sp = spec_from_dict({"maintenance_factor": MF, "catalogue": _catalogue(str(tmp_path)),
                         "rooms": {"0": {"work_plane": {"lux": 200, "u0": 0.4}}}},
                        base_dir=str(tmp_path))
    rd = design_room(sc, sp, 0)
    assert rd.compliant, (rd.verdicts, rd.notes)
    accents = [lum for lum in rd.luminaires if lum.extra.get("role") == "accent"]
    general = [lum for lum in rd.luminaires if lum.extra.get("role") != "accent"]
    # aimable entries are for accents; the general lighting is the downlights
    assert {lum.extra["type"] for lum in general} <= {"DL-1000", "DL-2000"}
    assert {lum.extra["type"] for lum in accents} <= set(BEAMS)
    # the general lighting stays compliant: a fresh exact solve on the EN 12464-1 grid
    droom = DesignRoom(sc, 0)
    pts, _ = droom.grid(0.75, 0.5)
    wp, _ = RoomModel(sc, droom, pts, MF).exact(rd.luminaires)
    assert wp.mean() >= 200.0 and wp.min() / wp.mean() >= 0.4
    # every spot independently: the whole scene rendered (direct with shadows + radiosity)
    t = sc.vertex_targets()
    area = _vertex_areas(sc)
    lux = MF * render(sc, rd.luminaires, interreflection=True)
    gen = MF * render(sc, general, interreflection=True)
    added = lux - gen                                     # light adds up
    per = []
    for m, c in zip(masks, centres):
        core = m & (t >= 0.5 * t[m].max())
        assert abs(lux[core].mean() / t[core].mean() - 1) <= 0.10       # the requirement
        assert gen[core].mean() < 0.9 * t[core].mean()                 # accents needed
        assert abs(lux[m].max() / t[m].max() - 1) <= 0.20              # the peak
        # the lit area: the accents' half-peak area against the painted light above the
        # general lighting's, over the painted wall
        wall = np.abs((sc.vertices - c) @ sc.vertex_normals[np.flatnonzero(m)[0]]) < 1e-9
        need = np.where(m, np.maximum(t - gen, 0.0), 0.0)
        half = 0.5 * need[m].max()
        asked = area[wall & (need >= half)].sum()
        got = area[wall & (added >= half)].sum()
        assert abs(got / asked - 1) <= 0.35, (got, asked)
        # aimed at it: each of its accents' axes passes close to the painting's centre
        mine = [lum for lum in accents
                if np.linalg.norm(np.asarray(lum.extra["aimed_at"]) - c) < 1.5]
        assert mine
        for lum in mine:
            to = c - lum.position
            miss = np.linalg.norm(to - (to @ lum.normal) * lum.normal)
            assert miss < 0.8
            # at a sensible throw: 20-40 degrees off vertical, within the entry's 45
            assert 20.0 - 1e-6 <= lum.extra["tilt_deg"] <= 40.0 + 1e-6
            assert np.degrees(np.arccos(-lum.normal[2])) == pytest.approx(
                lum.extra["tilt_deg"], abs=0.01)
        per.append(mine)
    # the beam follows the size: the small painting a narrower beam than the large one,
    # the long one more than one spot
    beam = {name: i for i, name in enumerate(BEAMS)}
    assert beam[per[0][0].extra["type"]] < beam[per[1][0].extra["type"]]
    assert len(per[2]) >= 2 and len(per[0]) == len(per[1]) == 1
    # notes and the result say how well each spot is met
    d = json.loads(json.dumps(rd.to_dict(), allow_nan=False))     # RESULT.json as written
    spots = [s for s in d["spots"] if s["kind"] == "spot"]
    assert len(spots) == 3 and all(s["pass"] for s in spots)
    for s in spots:
        assert {"peak_lux", "size_m2", "rim_share", "accent_count"} <= set(s)
    assert sum("half-peak area" in n and "peak" in n for n in rd.notes) == 3, rd.notes


@pytest.mark.parametrize("entry, words", [
    ({"aimable": "yes"}, "aimable"),
    ({"max_tilt_deg": 30}, "needs \"aimable\": true"),
    ({"aimable": True, "max_tilt_deg": 95}, "max_tilt_deg"),
])
def test_aimable_entries_are_checked(entry, words):
    d = {"catalogue": [dict(GENERAL[0], **entry)],
         "rooms": {"0": {"work_plane": {"lux": 200}}}}
    with pytest.raises(SettingsError) as e:
        spec_from_dict(d, source="DESIGN.json")
    assert words in str(e.value) and "\n" not in str(e.value)


def test_aimable_entry_round_trips():
    d = {"catalogue": [dict(GENERAL[0], aimable=True, max_tilt_deg=35)],
         "rooms": {"0": {"work_plane": {"lux": 200}}}}
    e = spec_from_dict(d).catalogue[0]
    assert e.aimable and e.max_tilt_deg == 35.0
    assert spec_from_dict({**d, "catalogue": [e.to_dict()]}).catalogue[0] == e
    plain = spec_from_dict({**d, "catalogue": [GENERAL[0]]}).catalogue[0]
    assert not plain.aimable and "aimable" not in plain.to_dict()
