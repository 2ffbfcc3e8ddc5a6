"""Scene generator for tests, benchmarks and examples: rooms with subdivided surfaces.

Every surface is a planar quadrilateral subdivided into a grid of triangles of about
``cell`` metres, wound counter-clockwise seen from the room (normals into the room).
Rooms: box, L-shaped, sloped ceiling, any rectilinear outline; box occluders (pillars,
tables); several rooms on a floor with their own room ids.
"""
import math

import numpy as np

from invrad_wb.core.model.scene import Scene


class MeshBuilder:
    """Accumulates subdivided quads into one triangle mesh with room/reflectance per face."""

    def __init__(self, cell=0.2):
        self.cell = float(cell)
        self._v, self._f, self._room, self._rho = [], [], [], []
        self._nv = 0

    def quad(self, p0, p1, p2, p3, inward, room=0, reflectance=0.5, cell=None):
        """Add the planar quad p0-p1-p2-p3 (in order around it), facing ``inward``.

        The quad is subdivided bilinearly into ``ceil(edge / cell)`` steps each way.
        """
        p = [np.asarray(x, dtype=np.float64) for x in (p0, p1, p2, p3)]
        n = np.cross(p[1] - p[0], p[3] - p[0])
        if np.dot(n, inward) < 0:
            p = [p[0], p[3], p[2], p[1]]
        cell = self.cell if cell is None else cell
        nu = max(1, math.ceil(max(np.linalg.norm(p[1] - p[0]), np.linalg.norm(p[2] - p[3]))
                              / cell - 1e-9))
        nv = max(1, math.ceil(max(np.linalg.norm(p[3] - p[0]), np.linalg.norm(p[2] - p[1]))
                              / cell - 1e-9))
        s = np.linspace(0, 1, nu + 1)
        t = np.linspace(0, 1, nv + 1)
        S, T = np.meshgrid(s, t, indexing="ij")
        S, T = S[..., None], T[..., None]
        pts = ((1 - S) * (1 - T) * p[0] + S * (1 - T) * p[1] + S * T * p[2]
               + (1 - S) * T * p[3]).reshape(-1, 3)
        idx = np.arange((nu + 1) * (nv + 1)).reshape(nu + 1, nv + 1)
        a, b = idx[:-1, :-1].reshape(-1), idx[1:, :-1].reshape(-1)
        c, d = idx[1:, 1:].reshape(-1), idx[:-1, 1:].reshape(-1)
        faces = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)]) + self._nv
        self._v.append(pts)
        self._f.append(faces)
        self._room.append(np.full(len(faces), room))
        self._rho.append(np.full(len(faces), reflectance))
        self._nv += len(pts)
        return self

    def scene(self, **kwargs):
        return Scene(np.concatenate(self._v), np.concatenate(self._f),
                     face_room=np.concatenate(self._room),
                     face_reflectance=np.concatenate(self._rho), **kwargs)


def _outline_area_sign(outline):
    x, y = outline[:, 0], outline[:, 1]
    return 0.5 * np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y)


def add_prism_room(mb, outline, rects, height=3.0, slope=(0.0, 0.0), origin=(0, 0, 0),
                   room=0, reflectance=0.5, floor_reflectance=None, ceiling_reflectance=None):
    """Add a room with a polygonal outline, flat floor and planar (possibly sloped) ceiling.

    Parameters
    ----------
    outline : (k, 2) float64
        Floor outline in metres (either orientation).
    rects : list of (x0, y0, x1, y1)
        Axis-aligned rectangles that tile the outline (floor and ceiling pieces).
    height : float
        Ceiling height at the outline's local origin (metres).
    slope : (2,) float64
        Ceiling height change per metre along x and y (a sloped ceiling).
    """
    o = np.asarray(origin, dtype=np.float64)
    outline = np.asarray(outline, dtype=np.float64)
    if _outline_area_sign(outline) < 0:
        outline = outline[::-1]
    fr = reflectance if floor_reflectance is None else floor_reflectance
    cr = reflectance if ceiling_reflectance is None else ceiling_reflectance

    def h(x, y):
        return height + slope[0] * x + slope[1] * y

    for x0, y0, x1, y1 in rects:
        mb.quad(o + [x0, y0, 0], o + [x1, y0, 0], o + [x1, y1, 0], o + [x0, y1, 0],
                inward=[0, 0, 1], room=room, reflectance=fr)
        mb.quad(o + [x0, y0, h(x0, y0)], o + [x1, y0, h(x1, y0)], o + [x1, y1, h(x1, y1)],
                o + [x0, y1, h(x0, y1)], inward=[-slope[0], -slope[1], -1], room=room,
                reflectance=cr)
    k = len(outline)
    for i in range(k):
        (xa, ya), (xb, yb) = outline[i], outline[(i + 1) % k]
        inward = np.array([-(yb - ya), xb - xa, 0.0])  # left of a counter-clockwise edge
        mb.quad(o + [xa, ya, 0], o + [xb, yb, 0], o + [xb, yb, h(xb, yb)],
                o + [xa, ya, h(xa, ya)], inward=inward, room=room, reflectance=reflectance)
    return mb


def add_box_occluder(mb, lo, hi, room=0, reflectance=0.5, skip_bottom=None, skip_top=None):
    """Add an axis-aligned box whose faces point out of the box (into the room).

    Faces lying on the floor (z = 0 in the room) or at the top of the room can be skipped.
    """
    lo = np.asarray(lo, dtype=np.float64)
    hi = np.asarray(hi, dtype=np.float64)
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    quads = [
        ([x0, y0, z0], [x1, y0, z0], [x1, y0, z1], [x0, y0, z1], [0, -1, 0]),
        ([x0, y1, z0], [x1, y1, z0], [x1, y1, z1], [x0, y1, z1], [0, 1, 0]),
        ([x0, y0, z0], [x0, y1, z0], [x0, y1, z1], [x0, y0, z1], [-1, 0, 0]),
        ([x1, y0, z0], [x1, y1, z0], [x1, y1, z1], [x1, y0, z1], [1, 0, 0]),
    ]
    if not skip_top:
        quads.append(([x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1], [0, 0, 1]))
    if not skip_bottom:
        quads.append(([x0, y0, z0], [x1, y0, z0], [x1, y1, z0], [x0, y1, z0], [0, 0, -1]))
    for p0, p1, p2, p3, n in quads:
        mb.quad(p0, p1, p2, p3, inward=n, room=room, reflectance=reflectance)
    return mb


def box_room(size=(6.0, 4.0, 3.0), cell=0.2, reflectance=0.5, origin=(0, 0, 0), room=0):
    """A closed box room ``size = (x, y, z)`` metres with its floor corner at ``origin``."""
    w, d, h = size
    mb = MeshBuilder(cell)
    add_prism_room(mb, [(0, 0), (w, 0), (w, d), (0, d)], [(0, 0, w, d)], height=h,
                   origin=origin, room=room, reflectance=reflectance)
    return mb.scene()


def l_room(size=(6.0, 5.0, 3.0), cut=(3.0, 2.5), cell=0.2, reflectance=0.5, room=0):
    """An L-shaped room: the box ``size`` minus its corner [cut_x, x] x [cut_y, y]."""
    w, d, h = size
    cx, cy = cut
    outline = [(0, 0), (w, 0), (w, cy), (cx, cy), (cx, d), (0, d)]
    rects = [(0, 0, w, cy), (0, cy, cx, d)]
    mb = MeshBuilder(cell)
    add_prism_room(mb, outline, rects, height=h, room=room, reflectance=reflectance)
    return mb.scene()


def sloped_room(size=(6.0, 4.0), low=2.5, high=4.0, cell=0.2, reflectance=0.5, room=0):
    """A room whose ceiling rises along x from ``low`` to ``high`` metres."""
    w, d = size
    mb = MeshBuilder(cell)
    add_prism_room(mb, [(0, 0), (w, 0), (w, d), (0, d)], [(0, 0, w, d)], height=low,
                   slope=((high - low) / w, 0.0), room=room, reflectance=reflectance)
    return mb.scene()


def pillar_room(size=(6.0, 4.0, 3.0), pillar=((2.8, 1.8), (3.2, 2.2)), cell=0.2,
                reflectance=0.5, room=0):
    """A box room with a floor-to-ceiling pillar (x0, y0) - (x1, y1).

    The floor and ceiling have a hole where the pillar stands (no hidden faces).
    """
    w, d, h = size
    (x0, y0), (x1, y1) = pillar
    mb = MeshBuilder(cell)
    rects = [(0, 0, x0, d), (x1, 0, w, d), (x0, 0, x1, y0), (x0, y1, x1, d)]
    add_prism_room(mb, [(0, 0), (w, 0), (w, d), (0, d)], rects, height=h,
                   room=room, reflectance=reflectance)
    add_box_occluder(mb, (x0, y0, 0), (x1, y1, h), room=room, reflectance=reflectance,
                     skip_bottom=True, skip_top=True)
    return mb.scene()


def floor_of_rooms(rooms=((4.0, 4.0), (4.0, 4.0), (5.0, 4.0), (3.0, 4.0)), height=3.0,
                   wall=0.2, cell=0.25, reflectance=0.5):
    """Several box rooms side by side along x, separated by walls ``wall`` thick.

    Room ``i`` gets room id ``i``; returns the scene and the rooms' floor origins (k, 3).
    """
    mb = MeshBuilder(cell)
    x = 0.0
    origins = []
    for i, (w, d) in enumerate(rooms):
        add_prism_room(mb, [(0, 0), (w, 0), (w, d), (0, d)], [(0, 0, w, d)], height=height,
                       origin=(x, 0, 0), room=i, reflectance=reflectance)
        origins.append((x, 0.0, 0.0))
        x += w + wall
    return mb.scene(), np.array(origins)


def with_reflectances(scene, ceiling=0.7, walls=0.5, floor=0.2):
    """The scene with reflectances by face orientation (the usual 0.7 / 0.5 / 0.2)."""
    nz = scene.face_normals[:, 2]
    rho = np.where(nz < -0.3, ceiling, np.where(nz > 0.3, floor, walls))
    return Scene(scene.vertices, scene.faces, face_room=scene.face_room,
                 face_reflectance=rho, face_virtual=scene.face_virtual, source=scene.source,
                 check_winding=False)
