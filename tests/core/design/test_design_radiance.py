"""A designed room judged by an independent engine: Radiance through ``pyradiance``.

An L-shaped room (6 x 5 m less a 2.5 x 2.5 m corner, 2.7 m high) with a 0.4 m column,
designed by ``design_room`` from a photometric catalogue entry (an IES LM-63 file with a
0.3 x 0.3 m luminous opening, I ~ cos^1.5, dimmable), is lit in Radiance with the
luminaires as ``ies2rad`` makes them (:mod:`radiance_judge`). Maintained values (x MF):
the work plane's Em and U0 within 3 % of the design's, the walls' and the ceiling's Em
within 5 % (issue #22 item 5). UGR by the CIE 117 formula computed here from Radiance:
each luminaire's luminance by a ray from the eye to its centre (a luminaire hidden by a
wall or the column is not seen), the exact solid angle of its luminous rectangle, Guth's
position index, the background luminance from Radiance's interreflected illuminance at the
eye / pi; within 1 of the design's UGR. evalglare on a fisheye from the worst observer
gives a second opinion.

Radiance's ambient settings are coarse (-ab 4 -ad 128: the module runs in about a
minute), its direct light exact (every source tested: ``radiance_judge.DIRECT``).
Measured 2026-11-26 on the design as UGR is rated since round 12 (new condition: 8
luminaires, 82.3 W; invrad / Radiance): Em 303.0 / 301.7 lx, U0 0.510 / 0.507, walls
124.8 / 123.2 lx, ceiling 55.4 / 54.4 lx; UGR 21.90 / 21.26-21.33 (the worst observer
differs between runs: Radiance's ambient sampling), evalglare there 21.78-21.84. Before
(background maintained; 13 dimmed panels, radiance_judge.DIRECT's note): UGR 21.90
against Radiance's 20.89 in the new condition (21.67 counted with the background x MF),
U0 0.510 / 0.492 (the least point in the column's penumbra, where the design samples
each opening at 2 x 2 Gauss points).
Round 13 (UGR counts only what each observer sees, roomglare.seen_shares; the background
at an eye gathered from every patch): the design is 6 luminaires, 80.5 W (8, 82.3 W
before); UGR 21.73 / 22.00 by the formula from Radiance at the worst observer (5.5, 1.25),
evalglare there 22.37; per observer invrad / Radiance 13.55 / 13.87 (beside the column,
which hides 3 of the 6), 21.73 / 22.00, 20.51 / 20.56, 20.52 / 20.65 (at (3, 4.5) the
inner corner hides 2; counting them, as before, read 22.47).
"""
import math
import os

import numpy as np
import pytest

from radiance_judge import (RadianceRoom, guth_position_index, polygon_solid_angle,
                            radiance_binaries, write_ies)

if radiance_binaries() is None:
    pytest.skip("pyradiance with its Radiance binaries (rtrace, ies2rad, rpict, evalglare)"
                " is not installed", allow_module_level=True)

pytestmark = pytest.mark.slow

MF = 0.8
#: the catalogue's one type: name, rated lm, W, cos exponent, luminous opening (m)
TYPE = ("PN", 2500.0, 20.0, 1.5, (0.3, 0.3))
#: coarse ambient settings (4 bounces, one cache for every ray of the room)
AMBIENT = ["-ab", "4", "-ad", "128", "-as", "32", "-aa", "0.2", "-ar", "8", "-lw", "1e-3"]
#: fisheye resolution for evalglare (a 0.3 m opening 5 m away spans about 3 pixels)
FISHEYE_PX = 160
#: evalglare's fixed glare-source threshold (cd/m^2): the room's surfaces stay below
#: 100 cd/m^2, the openings seen at up to 80 degrees off their axis exceed 1000
SOURCE_CD_M2 = 500.0


def l_room_with_column(cell=0.4):
    """The L (6 x 5 x 2.7 m less [3.5, 6] x [2.5, 5]) with a floor-to-ceiling column
    [1.5, 1.9] x [1.1, 1.5] (the floor and ceiling with a hole where it stands)."""
    from invrad_wb.core.synthetic import generate as g
    w, d, h, cx, cy = 6.0, 5.0, 2.7, 3.5, 2.5
    (c0x, c0y), (c1x, c1y) = col = ((1.5, 1.1), (1.9, 1.5))
    xs, ys = [0.0, c0x, c1x, cx, w], [0.0, c0y, c1y, cy, d]
    rects = []
    for x0, x1 in zip(xs[:-1], xs[1:]):
        for y0, y1 in zip(ys[:-1], ys[1:]):
            mx, my = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
            if not (mx > cx and my > cy) and not (c0x < mx < c1x and c0y < my < c1y):
                rects.append((x0, y0, x1, y1))
    mb = g.MeshBuilder(cell)
    g.add_prism_room(mb, [(0, 0), (w, 0), (w, cy), (cx, cy), (cx, d), (0, d)], rects,
                     height=h)
    g.add_box_occluder(mb, (c0x, c0y, 0.0), (c1x, c1y, h), skip_bottom=True, skip_top=True)
    return g.with_reflectances(mb.scene())


@pytest.fixture(scope="module")
def judged(tmp_path_factory):
    """The design, its grids and Radiance's illuminance at them (new installation)."""
    from invrad_wb.core.design.design import design_room
    from invrad_wb.core.design.evaluate import surface_grids
    from invrad_wb.core.design.room import DesignRoom
    from invrad_wb.core.design.spec import spec_from_dict
    from invrad_wb.core.output.glare import observers
    tmp = str(tmp_path_factory.mktemp("radiance"))
    name, flux, watts, n, size = TYPE
    ies = os.path.join(tmp, f"{name}.ies")
    write_ies(ies, name, flux, n, size)
    scene = l_room_with_column()
    spec = spec_from_dict({"maintenance_factor": MF, "catalogue": [
        {"name": name, "flux_lm": flux, "watts": watts, "photometry": ies,
         "dimming": [0.1, 1.0]}], "rooms": {"0": {
            "work_plane": {"lux": 300, "u0": 0.5, "height_m": 0.75, "margin_m": 0.5},
            "ugr_max": 22, "walls": {"lux": 75}, "ceiling": {"lux": 50}}}})
    rd = design_room(scene, spec, 0)
    assert rd.luminaires and rd.ugr is not None
    droom = DesignRoom(scene, 0)
    grids = surface_grids(scene, 0, droom)
    # a ceiling point behind a luminous opening is the luminaire (Radiance's light
    # polygon, 1 mm below the ceiling, leaves it dark; the design leaves it out too)
    P, N, W = grids["ceiling"]
    behind = np.zeros(len(P), dtype=bool)
    for lum in rd.luminaires:
        d = P - lum.position
        behind |= ((np.abs(d[:, 0]) <= 0.5 * size[0]) & (np.abs(d[:, 1]) <= 0.5 * size[1])
                   & (np.abs(d[:, 2]) < 0.05))
    grids["ceiling"] = (P[~behind], N[~behind], W[~behind])
    obs = observers(droom)
    rr = RadianceRoom(tmp, scene, rd.luminaires, {name: (ies, flux)}, AMBIENT)
    wp = rd.grid_points
    parts = [("work_plane", wp, np.tile([0.0, 0.0, 1.0], (len(wp), 1)), np.ones(len(wp))),
             ("walls", *grids["walls"]), ("ceiling", *grids["ceiling"]),
             ("eyes", np.array([e for e, _ in obs]), np.array([v for _, v in obs]),
              np.ones(len(obs)))]
    lux = rr.illuminance(np.concatenate([p[1] for p in parts]),
                         np.concatenate([p[2] for p in parts]))
    got, i = {}, 0
    for key, P, _, W in parts:
        got[key] = (lux[i:i + len(P)], W)
        i += len(P)
    direct_eyes = rr.illuminance(parts[3][1], parts[3][2], interreflected=False)
    return dict(rd=rd, rr=rr, got=got, obs=obs, size=size,
                indirect_eyes=np.maximum(got["eyes"][0] - direct_eyes, 0.0))


def test_work_plane_walls_and_ceiling_have_the_illuminance_radiance_finds(judged):
    """Maintained Em of the work plane within 3 %, of the walls and the ceiling (their
    EN 12464-1 grids, area-weighted) within 5 % of what the design reports."""
    rd, got = judged["rd"], judged["got"]
    e = MF * got["work_plane"][0]
    figures = {"work plane": (rd.metrics.em, e.mean())}
    for k in ("walls", "ceiling"):
        s, w = got[k]
        figures[k] = (rd.metrics.surfaces[k][0], MF * float(np.sum(s * w) / w.sum()))
    msg = "; ".join(f"{k}: invrad {a:.1f} lx, Radiance {b:.1f} lx" for k, (a, b)
                    in figures.items())
    assert figures["work plane"][1] == pytest.approx(figures["work plane"][0], rel=0.03), msg
    for k in ("walls", "ceiling"):
        assert figures[k][1] == pytest.approx(figures[k][0], rel=0.05), msg


def test_work_plane_uniformity_is_the_one_radiance_finds(judged):
    """U0 on the work plane within 3 % of the design's (an xfail until round 12, whose
    design of 13 panels put its least point in the column's penumbra: 0.510 / 0.492)."""
    rd, got = judged["rd"], judged["got"]
    e = got["work_plane"][0]
    u0 = float(e.min() / e.mean())
    assert u0 == pytest.approx(rd.metrics.u0, rel=0.03), (rd.metrics.u0, u0)


def _glare_sum(judged, eye, view):
    """CIE 117's sum of L^2 omega / p^2 of the luminaires seen from ``eye``: luminance by
    Radiance along the ray to each opening's centre, the opening's exact solid angle,
    Guth's index (0 where none is seen)."""
    rr, lums, (a, b) = judged["rr"], judged["rd"].luminaires, judged["size"]
    ahead = [k for k, lum in enumerate(lums)
             if lum.position[2] > eye[2] and (lum.position - eye) @ view > 0]
    if not ahead:
        return 0.0
    centres = np.array([lums[k].position + 0.001 * lums[k].normal for k in ahead])
    lum_cd, hit = rr.luminance_seen(eye, centres)
    total = 0.0
    for k, c, L, mod in zip(ahead, centres, lum_cd, hit):
        if mod != rr.light_names[k]:
            continue                     # a wall of the L or the column is in the way
        corners = c + np.array([[-a, -b, 0], [a, -b, 0], [a, b, 0], [-a, b, 0]]) * 0.5
        total += L ** 2 * polygon_solid_angle(eye, corners) \
            / guth_position_index(eye, view, c) ** 2
    return total


@pytest.fixture(scope="module")
def glare(judged):
    """Per observer (UGR in the new condition, eye, view), the worst first, and
    evalglare's figures at the worst observer (new condition)."""
    per = []
    for (e, v), lb in zip(judged["obs"], judged["indirect_eyes"]):
        s = _glare_sum(judged, e, v)
        if s > 0:
            per.append((8.0 * math.log10(0.25 * math.pi / lb * s), e, v))
    per.sort(key=lambda x: -x[0])
    pic = judged["rr"].fisheye("eye.hdr", per[0][1], per[0][2], FISHEYE_PX)
    eg = judged["rr"].evalglare(pic, SOURCE_CD_M2)
    msg = (f"UGR invrad {judged['rd'].ugr:.2f}; CIE 117 from Radiance, new condition:"
           f" {[round(x[0], 2) for x in per]} (worst observer {per[0][1]}, view"
           f" {per[0][2]}); evalglare there {eg['ugr']:.2f} (E_v {eg['E_v']:.1f} lx,"
           f" E_dir {eg['E_v_dir']:.1f} lx, Lb {eg['lum_backg']:.1f} cd/m2)")
    return per, eg, msg


def test_ugr_agrees_with_the_cie_formula_from_radiance_and_with_evalglare(judged, glare):
    """EN 12464-1 / CIE 117 rate the installation new (luminance and background both): the
    worst standard observer's UGR by the CIE 117 formula with Radiance's luminances and
    background within 1 of the design's (both count only the luminaires the observer
    sees; until round 13 invrad's also counted those a wall of the L or the column hides:
    at (3, 4.5) looking -y, 4 of the other leg's, about +0.5);
    evalglare on a fisheye from that observer (sources: pixels over SOURCE_CD_M2,
    background (E_v - E_dir) / pi) within 1.5 of the formula's value (the openings a few
    pixels wide, neighbouring sources merged, Guth's index capped at 16)."""
    per, eg, msg = glare
    assert abs(judged["rd"].ugr - per[0][0]) <= 1.0, msg
    assert abs(eg["ugr"] - per[0][0]) <= 1.5, msg
