"""Locate on requirement targets: classification and the regular layout (core, no FreeCAD)."""
import numpy as np
import pytest

from invrad_wb.core.design import en12464
from invrad_wb.core.design.room import DesignRoom, in_polygon
from invrad_wb.core.design.requirements import (EM_HIGH, EM_LOW, classify, classify_rooms,
                                                design_requirements, judge)
from invrad_wb.core.model.luminaires import Luminaire
from invrad_wb.core.model.scene import Scene
from invrad_wb.core.synthetic import generate as g


def _room(size=(6.0, 4.0, 3.0), level=300.0, height=0.75, cell=0.4, wall_lux=None):
    """A box room (ceiling 0.7, walls 0.5, floor 0.2) with a virtual work plane ``height``
    above the floor whose target is ``level`` lx everywhere (targets NaN elsewhere, or
    ``wall_lux(vertices, normals)`` on the real surfaces)."""
    base = g.with_reflectances(g.box_room(size=size, cell=cell))
    v, f = base.vertices, base.faces
    floor = base.face_normals[:, 2] > 0.99
    used, inv = np.unique(f[floor].reshape(-1), return_inverse=True)
    wv = v[used] + [0.0, 0.0, height]
    wt = inv.reshape(-1, 3) + len(v)
    real = np.full(len(v), np.nan) if wall_lux is None else wall_lux(v, base.vertex_normals)
    return Scene(np.vstack([v, wv]), np.vstack([f, wt]),
                 vertex_lux=np.r_[real, np.full(len(wv), float(level))],
                 face_room=np.zeros(len(f) + len(wt), int),
                 face_reflectance=np.r_[base.face_reflectance, np.zeros(len(wt))],
                 face_virtual=np.r_[np.zeros(len(f), bool), np.ones(len(wt), bool)],
                 check_winding=False)


def _rendered(scene):
    """The same room with the light of two downlights as (exact) targets everywhere."""
    from invrad_wb.core.forward.render import render
    lums = [Luminaire([2.0, 2.0, 3.0], [0, 0, -1], 3000.0, room=0),
            Luminaire([4.0, 2.0, 3.0], [0, 0, -1], 3000.0, room=0)]
    return scene.with_vertex_lux(render(scene, lums, interreflection=True, backend="numpy"))


def test_a_work_plane_level_is_a_requirement_with_en12464_uniformity():
    rt = classify(_room(level=500.0), 0)
    assert rt.kind == "requirement"
    assert rt.level_lux == 500.0 and rt.u0 == 0.6
    assert rt.u0_source == "EN 12464-1 for 500 lx"
    # targets to the walls: judged on the EN 12464-1 task area (a 0.5 m border zone)
    assert rt.height_m == pytest.approx(0.75) and rt.margin_m == 0.5
    assert classify(_room(level=200.0), 0).u0 == 0.4
    assert en12464.uniformity_for(750) == (0.7, "EN 12464-1 for 750 lx")


def test_uniform_walls_are_goals_of_a_requirement_room():
    wall = lambda v, n: np.where(np.abs(n[:, 2]) < 0.1, 150.0, np.nan)
    rt = classify(_room(wall_lux=wall), 0)
    assert rt.kind == "requirement"
    assert rt.surfaces and all(lux == 150.0 for _, lux in rt.surfaces)


def test_a_rendered_scene_is_exact():
    rt = classify(_rendered(_room()), 0)
    assert rt.kind == "exact" and "vary" in rt.reason


def test_a_level_with_a_rendered_picture_on_the_walls_is_mixed_and_exact():
    exact = _rendered(_room())
    lux = exact.vertex_targets()
    wp = np.zeros(len(lux), bool)
    wp[np.unique(exact.faces[exact.face_virtual])] = True
    lux[wp] = 300.0
    rt = classify(exact.with_vertex_lux(lux), 0)
    assert rt.kind == "exact" and "mixed" in rt.reason


def test_no_work_plane_is_exact():
    sc = g.box_room(size=(4.0, 4.0, 3.0), cell=0.5)
    sc = sc.with_vertex_lux(np.full(len(sc.vertices), 100.0))
    assert classify(sc, 0).kind == "exact"


def _spacings(values):
    u = np.unique(np.round(values, 6))
    return np.diff(u)


@pytest.mark.parametrize("level", [300.0, 500.0])
def test_a_requirement_room_gets_a_regular_ceiling_grid_that_meets_the_level(level):
    from invrad_wb.core.forward.render import render
    size = (7.0, 5.0, 3.0)
    sc = _room(size=size, level=level)
    targets = classify_rooms(sc)
    res = design_requirements(sc, targets, 2000.0, backend="numpy")
    lums = res.luminaires
    assert len(lums) >= 2
    p = np.array([lum.position for lum in lums])
    # on the ceiling facing down, none on a wall
    assert np.allclose(p[:, 2], 3.0)
    assert all(np.allclose(lum.normal, [0, 0, -1]) for lum in lums)
    assert all(lum.extra["mount"] == "surface" and lum.flux_lm == 2000.0 for lum in lums)
    # a regular grid: rows x columns, equal spacings along each axis
    xs, ys = np.unique(p[:, 0].round(6)), np.unique(p[:, 1].round(6))
    assert len(xs) * len(ys) == len(p)
    for d in (_spacings(p[:, 0]), _spacings(p[:, 1])):
        assert len(d) == 0 or np.allclose(d, d[0], atol=1e-6)
    # an independent forward render (interreflection) on the work plane's targets
    achieved = render(sc, lums, interreflection=True, backend="numpy")
    wp = np.unique(sc.faces[sc.face_virtual])
    xy = sc.vertices[wp, :2]
    task = wp[np.all((xy >= 0.5 - 1e-9) & (xy <= np.array(size[:2]) - 0.5 + 1e-9), axis=1)]
    em = achieved[task].mean()
    assert EM_LOW * level <= em <= EM_HIGH * level
    assert achieved[task].min() / em >= targets[0].u0
    # judged as EN 12464-1 does: interpolated at the calculation grid of the task area
    v = judge(sc, 0, targets[0], achieved)
    assert v.met and v.points == len(DesignRoom(sc, 0).grid(0.75, 0.5)[0])
    assert v.em_lux == pytest.approx(em, rel=0.03) and v.u0 >= targets[0].u0


def test_the_verification_report_judges_a_level_against_en12464_and_says_so(tmp_path):
    from invrad_wb.core.forward.render import render
    from invrad_wb.core.output.report import build_report
    sc = _room(size=(5.0, 4.0, 3.0), level=500.0)
    targets = classify_rooms(sc)
    lums = design_requirements(sc, targets, 2000.0, backend="numpy").luminaires
    achieved = render(sc, lums, interreflection=True, backend="numpy")
    v = judge(sc, 0, targets[0], achieved)
    pv = {"targets": "requirement", **v.to_dict(), "words": f"Office: {v.words()}"}
    out = build_report(sc, sc.vertex_targets(), achieved, lums, str(tmp_path),
                       room_names={0: "Office"}, verdicts={0: pv}, pdf=False,
                       write_exr=False)
    html = open(out.html, encoding="utf-8").read()
    assert "(EN 12464-1 for 500 lx)" in html and "U0 needed" in html
    assert f"U0 {v.u0:.2f} &gt;= 0.60 (EN 12464-1 for 500 lx) met" in html
    assert ">1 of 1</b>rooms meet their targets" in html.replace("\n", "")



def test_cli_locate_on_a_plain_mesh_lays_out_a_requirement_room(tmp_path, capsys):
    """A work plane written to PLY keeps its virtual faces, and ``python -m invrad_wb
    locate`` takes its level as a requirement, as the freecad command does: a regular
    ceiling layout judged on the task area (the point-by-point fit ringed the walls)."""
    import json
    from invrad_wb import cli
    from invrad_wb.core.io.sceneio import read_scene, write_scene
    room = _room(level=300.0, cell=0.5)
    ply = tmp_path / "room.ply"
    write_scene(ply, room)
    back = read_scene(ply)
    assert np.array_equal(back.face_virtual, room.face_virtual) and room.face_virtual.any()
    assert classify(back, 0).kind == "requirement"
    out = tmp_path / "r.json"
    rc = cli.main(["locate", str(ply), "--flux", "2000", "-o", str(out),
                   "--backend", "numpy"])
    said = capsys.readouterr().out
    assert rc == 0, said
    data = json.loads(out.read_text())
    (v,) = data["verdicts"]
    assert v["targets"] == "requirement" and v["met"], said
    assert 0.9 * 300 <= v["em_lux"] <= 1.3 * 300 and v["u0"] >= 0.4
    assert " grid" in v["layout"] and f"met: room: Em" in said
    lums = data["luminaires"]
    assert len(lums) >= 2 and all(l["normal"][2] < -0.99 for l in lums)   # no wall light
    assert all(abs(l["position"][2] - 3.0) < 0.05 for l in lums)           # on the ceiling
    assert len({round(l["flux_lm"], 6) for l in lums}) == 1


def _with_zones(sc, zones):
    return Scene(sc.vertices, sc.faces, vertex_lux=sc.vertex_lux, face_room=sc.face_room,
                 face_reflectance=sc.face_reflectance, face_virtual=sc.face_virtual,
                 check_winding=False, _split=False, no_mount=zones)


def _rect(x0, y0, x1, y1):
    return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], dtype=np.float64)


def test_no_luminaire_in_a_forbidden_part_of_the_ceiling_and_the_level_is_still_met():
    """A stair in the middle of the room (nothing may be mounted over it) and a slab
    opening along one end (no ceiling: only a pendant may hang there)."""
    from invrad_wb.core.forward.render import render
    from invrad_wb.core.design.layouts import VOID_PENDANT_DROP_M
    from invrad_wb.core.model.scene import NoMountZone
    size, level = (7.0, 5.0, 3.0), 300.0
    stair, opening = _rect(2.5, 1.0, 4.5, 4.0), _rect(5.5, 0.0, 7.0, 5.0)
    sc = _with_zones(_room(size=size, level=level),
                     [NoMountZone(0, stair, "stair"),
                      NoMountZone(0, opening, "slab opening above", pendants=True)])
    targets = classify_rooms(sc)
    # without the zones most candidate grids have a position over the stair
    from invrad_wb.core.design.layouts import grid_geometries
    from invrad_wb.core.design.spec import Mounting
    free = grid_geometries(DesignRoom(_room(size=size), 0), Mounting(), 0.05, 0.75, 2, 12)
    over = [in_polygon(stair, gm.positions[:, :2]).any() for gm in free]
    assert np.mean(over) > 0.5
    res = design_requirements(sc, targets, 2000.0, backend="numpy")
    lums = res.luminaires
    p = np.array([lum.position for lum in lums])
    assert not in_polygon(stair, p[:, :2]).any(), p
    # on the ceiling, except under the opening: pendants hung below the ceiling's level
    void = in_polygon(opening, p[:, :2])
    assert np.allclose(p[~void, 2], 3.0)
    assert np.allclose(p[void, 2], 3.0 - VOID_PENDANT_DROP_M)
    assert [lum.extra["mount"] for lum in lums] == ["pendant" if v else "surface"
                                                      for v in void]
    assert all(np.allclose(lum.normal, [0, 0, -1]) for lum in lums)
    # the level and the uniformity are still met (an independent render, EN 12464-1 grid)
    achieved = render(sc, lums, interreflection=True, backend="numpy")
    v = judge(sc, 0, targets[0], achieved)
    assert v.met, v.words()
    assert EM_LOW * level <= v.em_lux <= EM_HIGH * level and v.u0 >= targets[0].u0


def test_a_no_mount_zone_must_be_a_plan_polygon():
    from invrad_wb.core.model.scene import NoMountZone
    from invrad_wb.errors import SceneError
    with pytest.raises(SceneError, match="no-mount zone 'stair' of room 0: a polygon"):
        _with_zones(_room(), [NoMountZone(0, [[0, 0], [1, 1]], "stair")])
