"""Room names placed clear of fixtures, obstacles and walls (no FreeCAD: the placement
of invrad_wb.gui.roomlabels is numpy on plan outlines)."""
import numpy as np

from invrad_wb.gui import roomlabels as rl


def _rect_edges(x0, y0, x1, y1):
    c = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], dtype=float)
    return np.stack([c, np.roll(c, -1, axis=0)], axis=1)


def _box_hits(anchor, z, pts, box, eye):
    """Which of ``pts`` (k, 3) the name's screen box covers, seen from ``eye``."""
    r, u = rl.screen_axes(eye)
    a = np.array([anchor[0], anchor[1], z])
    hx, hy, up = box
    dx = np.abs(pts @ r - a @ r)
    dy = np.abs(pts @ u - (a @ u + up))
    return (dx < hx) & (dy < hy)


def test_screen_axes_of_freecads_views():
    r, u = rl.screen_axes(rl.TOP_EYE)
    np.testing.assert_allclose(r, [1, 0, 0])
    np.testing.assert_allclose(u, [0, 1, 0])
    r, u = rl.screen_axes(rl.ISO_EYE)
    # isometric from (1, -1, 1): plan diagonal (1, 1) across the screen, Z up on it
    np.testing.assert_allclose(r, np.array([1, 1, 0]) / np.sqrt(2))
    np.testing.assert_allclose(u, np.array([-1, 1, 2]) / np.sqrt(6))
    np.testing.assert_allclose(np.cross(r, u), np.array(rl.ISO_EYE) / np.sqrt(3))


def test_name_clear_of_fixture_discs_a_stair_and_walls_from_above_and_isometric():
    # an L-shaped room (6 x 4 m less a 2 x 2 m corner), ceiling 2.7 m, name at 2.4 m;
    # downlights of 0.3 m radius on the ceiling where a centred name would be, a pendant
    # hanging 1 m, and a stair drum standing in the room
    outline = np.array([[0, 0], [6, 0], [6, 2], [4, 2], [4, 4], [0, 4]], dtype=float)
    edges = np.stack([outline, np.roll(outline, -1, axis=0)], axis=1)
    z, top = 2.4, 2.7
    lights = np.array([[x, y, 2.68] for x in (1.0, 2.5) for y in (1.0, 2.5)]
                      + [[5.0, 1.0, 1.7]])
    rods = np.array([[5.0, 1.0, h] for h in np.linspace(1.7, 2.7, 11)])
    a = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    stair = np.array([[1.2 + 0.5 * np.cos(t), 3.2 + 0.5 * np.sin(t), h]
                      for t in a for h in np.linspace(0.0, 2.0, 5)])
    things = np.concatenate([lights, rods, stair])
    radii = np.concatenate([np.full(len(lights), 0.3), np.zeros(len(rods) + len(stair))])
    char_m, name = 6.0 / 70.0, "Schlafzimmer"
    c = rl.place_label(edges, z, top, things, radii, char_m, len(name))
    from invrad_wb.core.geometry.outline import inside_outline
    assert inside_outline(edges, np.asarray(c)[None])[0], c
    box = rl.text_box(char_m, len(name))
    discs = rl._disc_points(lights, np.full(len(lights), 0.3))
    wall = np.array(rl._edge_points(edges, 0.02))
    walls = np.concatenate([np.column_stack([wall, np.full(len(wall), h)])
                            for h in (z, top)])
    for eye, view in ((rl.TOP_EYE, "above"), (rl.ISO_EYE, "isometric")):
        for what, pts in (("fixture", discs), ("rod", rods), ("stair", stair),
                          ("wall", walls)):
            hit = _box_hits(c, z, pts, box, eye)
            assert not hit.any(), f"{name} at {c} covers a {what} seen {view}: {pts[hit][:3]}"


def test_name_of_an_empty_room_in_its_middle():
    edges = _rect_edges(0, 0, 6, 4)
    c = rl.place_label(edges, 2.4, 2.7, np.zeros((0, 3)), np.zeros(0), 0.09, 5,
                       eyes=(rl.TOP_EYE,))
    np.testing.assert_allclose(c, [3.0, 2.0], atol=0.11)


def test_a_large_disc_pushes_the_name_off_its_rim():
    # a corridor 4 x 1 m with a large panel (radius 0.9 m) at x = 1 and a small
    # downlight at x = 3: midway between their centres (what keeping clear of points
    # alone gives) the name covers the large one's rim; its outline keeps it clear
    edges = _rect_edges(0, 0, 4, 1)
    lights = np.array([[1.0, 0.5, 2.68], [3.0, 0.5, 2.68]])
    radii = [0.9, 0.05]
    char_m, n = 0.09, 4
    box = rl.text_box(char_m, n)
    rims = rl._disc_points(lights, radii)
    c = rl.place_label(edges, 2.4, 2.7, lights, radii, char_m, n, eyes=(rl.TOP_EYE,))
    assert not _box_hits(c, 2.4, rims, box, rl.TOP_EYE).any(), c
    # the same placement told only the centres lands on the large disc
    c0 = rl.place_label(edges, 2.4, 2.7, lights, [0.0, 0.0], char_m, n, eyes=(rl.TOP_EYE,))
    assert _box_hits(c0, 2.4, rims, box, rl.TOP_EYE).any(), c0
