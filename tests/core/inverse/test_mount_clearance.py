"""Surface-mounted luminaires keep their centre clear of the border of the faces they are
on (locate's ``MOUNT_CLEARANCE_M``): a ceiling light pulled to the ceiling's edge by the
fit sat in the wall (FZK-Haus)."""
import numpy as np

from invrad_wb.core.synthetic import generate as g
from invrad_wb.core.inverse import locate as L
from invrad_wb.core.inverse.refine import Light
from invrad_wb.core.inverse.votemaps import build_canvas


def _ceiling_light(canvas, xy):
    k = next(i for i, m in enumerate(canvas.maps)
             if m.kind == "surface" and m.normal[2] < -0.9)
    m = canvas.maps[k]
    return Light("surface", np.array([xy[0], xy[1], 3.0]), np.array([0.0, 0.0, -1.0]), k,
                 plane=m.plane, origin=m.origin, u=m.u, v=m.v)


def test_surface_lights_move_clear_of_the_border():
    s = g.box_room((4, 3, 3), cell=0.25)
    canvas = build_canvas(s, 0, pixel=0.05, dummy=False)
    inside = L._make_inside(canvas)
    c = L.MOUNT_CLEARANCE_M
    # well inside: unchanged (the same object)
    mid = _ceiling_light(canvas, (2.0, 1.5))
    assert inside(mid) is mid
    # on the edge, near it, in a corner: moved to the clearance (to a quarter of it)
    for xy in ((0.0, 1.5), (0.03, 1.5), (3.99, 1.2), (3.95, 2.98), (0.001, 0.002)):
        got = inside(_ceiling_light(canvas, xy))
        assert got is not None, xy
        p = got.position
        clear = min(p[0], 4.0 - p[0], p[1], 3.0 - p[1])
        assert c - 1e-9 <= clear <= c + c / 4 + 0.05 + 1e-9, (xy, p)
        assert p[2] == 3.0                                # still on the ceiling
        moved = np.abs(p[:2] - np.array(xy))
        # only away from the near wall(s)
        assert np.all((moved < 1e-12) | (np.array([min(xy[0], 4 - xy[0]),
                                                   min(xy[1], 3 - xy[1])]) < c)), (xy, p)
    # off the ceiling altogether: refused
    assert inside(_ceiling_light(canvas, (4.5, 1.5))) is None


def test_a_face_narrower_than_twice_the_clearance_takes_no_light():
    s = g.box_room((4, 0.15, 3), cell=0.05)
    canvas = build_canvas(s, 0, pixel=0.025, dummy=False)
    assert L._make_inside(canvas)(_ceiling_light(canvas, (2.0, 0.075))) is None


def test_map_contains_all_is_map_contains_of_each_point():
    """The batched test (a luminaire and its probes at once) answers as the one-point test
    does, point by point: inside, on and beside the faces' border of an L-shaped ceiling
    (its re-entrant corner needs the face test), and off the map."""
    s = g.l_room(cell=0.25)
    canvas = build_canvas(s, 0, pixel=0.05, dummy=False)
    rng = np.random.default_rng(5)
    for k, m in enumerate(canvas.maps):
        if m.kind != "surface":
            continue
        extent = np.array(m.shape) * m.pixel
        uv = rng.uniform(-0.2, 1.0, (300, 2)) * (extent + 0.4)
        # and points on pixel and face borders exactly
        uv = np.vstack([uv, np.round(uv[:100] / m.pixel) * m.pixel])
        pts = m.origin + uv[:, :1] * m.u + uv[:, 1:] * m.v
        got = canvas.map_contains_all(k, pts)
        want = np.array([canvas.map_contains(k, p) for p in pts])
        assert want.any() and not want.all()
        np.testing.assert_array_equal(got, want)


def test_clear_inside_shortcut_gives_the_probes_answer(monkeypatch):
    """:func:`_clear_inside` (all pixels within the clearance inside the faces: no
    probes) changes no answer of :func:`_clear_of_border`: an L-shaped ceiling (its
    inner corner), points on a fine grid and at random, with and without it."""
    from invrad_wb.core.inverse import locate_placement as P
    mb = g.MeshBuilder(0.2)
    g.add_prism_room(mb, [(0, 0), (4, 0), (4, 2), (2, 2), (2, 3), (0, 3)], [(0, 0, 4, 2), (0, 2, 2, 3)],
                     height=3.0, reflectance=0.5)
    canvas = build_canvas(mb.scene(), 0, pixel=0.05, dummy=False)
    rng = np.random.default_rng(1)
    xy = np.vstack([np.stack(np.meshgrid(np.arange(-0.05, 4.1, 0.09),
                                         np.arange(-0.05, 3.1, 0.09)), -1).reshape(-1, 2),
                    rng.uniform(-0.1, 4.1, (300, 2))])
    lights = [_ceiling_light(canvas, p) for p in xy]
    fast = [P._clear_of_border(canvas, L) for L in lights]
    monkeypatch.setattr(P, "_clear_inside", lambda *a: False)
    slow = [P._clear_of_border(canvas, L) for L in lights]
    hits = 0
    for L, a, b in zip(lights, fast, slow):
        assert (a is None) == (b is None)
        if a is not None:
            assert np.array_equal(a.position, b.position)
            hits += a is L
    assert hits > len(lights) // 3        # the shortcut is taken where it may be
