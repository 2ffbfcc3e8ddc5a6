"""Rooms of a FreeCAD document: Arch Spaces -> closed solids -> sampling meshes in metres.

A room is an Arch Space, whether built from wall/slab boundaries (``Boundaries``), from a
solid (``Base``) or imported from an IfcSpace (:mod:`.ifcrooms`). Its boundary surfaces
are the faces of the Space's solid; targets refer to them as ``FaceN`` (1-based, FreeCAD's
sub-element names), meshes carry the 0-based face index per triangle.

:func:`mesh_room` tessellates each face on its own (FreeCAD), then refines the triangles
until no edge is longer than the resolution (:func:`invrad_wb.app.meshing.refine`); every
new vertex lies on a parent edge, so a planar face stays exactly planar. Vertices are not
shared between faces (a target on the floor must not leak up the walls). A Space's solid
has outward normals: triangles are wound so that their normals point INTO the room, and the
whole mesh is checked by its signed volume. Coordinates are converted from FreeCAD's mm to
metres here, and nowhere else.
"""
from dataclasses import dataclass, field
import time

import numpy as np

from invrad_wb.errors import SceneError, SettingsError
from invrad_wb.app import backend
from invrad_wb.app import settings as S
# global_shape lived here: rooms.global_shape as before
from invrad_wb.app.document import describe, global_shape  # noqa: F401
from invrad_wb.core.geometry.meshing import refine, signed_volume, triangle_normals
from invrad_wb.app.units import points_mm_to_m

SURFACE_KINDS = ("floor", "wall", "ceiling")


@dataclass
class RoomMesh:
    """The sampling mesh of one room.

    Attributes
    ----------
    space : str
        Internal name of the Arch Space (``doc.getObject(space)``).
    label : str
        The Space's label (the room name shown to the user).
    vertices : (n, 3) float64, metres
    triangles : (m, 3) int64, counter-clockwise seen from the room (normals inward)
    triangle_face : (m,) int64, 0-based index of the Space face of each triangle
    face_kind : list of str, per face: 'floor', 'wall' or 'ceiling'
    face_normal : (k, 3) float64, inward unit normal of each face (area-weighted)
    face_area : (k,) float64, m^2
    face_reflectance : (k,) float64 in [0, 1)
    volume : float, m^3
    seconds : float, time taken to mesh
    coarse : ((k, 3), (j, 3)): FreeCAD's own (unrefined) tessellation, inward, metres
    triangle_open : (m,) bool, triangles on an open border to another room
        (:func:`open_borders`; all False unless ``mesh_room`` was given open regions)
    """
    space: str
    label: str
    vertices: np.ndarray
    triangles: np.ndarray
    triangle_face: np.ndarray
    face_kind: list
    face_normal: np.ndarray
    face_area: np.ndarray
    face_reflectance: np.ndarray
    volume: float
    seconds: float = 0.0
    coarse: tuple = None
    extra: dict = field(default_factory=dict)
    triangle_open: np.ndarray = None

    def __post_init__(self):
        if self.triangle_open is None:
            self.triangle_open = np.zeros(len(self.triangles), dtype=bool)

    @property
    def n_faces(self):
        return len(self.face_kind)

    @staticmethod
    def face_label(i):
        """FreeCAD sub-element name of the 0-based face ``i``."""
        return f"Face{int(i) + 1}"

    @property
    def triangle_reflectance(self):
        return self.face_reflectance[self.triangle_face]

    @property
    def floor_triangles(self):
        """(m,) bool: triangles on floor faces."""
        kinds = np.array([k == "floor" for k in self.face_kind])
        return kinds[self.triangle_face]

    def faces_of_kind(self, kind):
        """0-based indices of the faces of one kind ('floor', 'wall', 'ceiling')."""
        return [i for i, k in enumerate(self.face_kind) if k == kind]


# --------------------------------------------------------------------------- spaces
def is_space(obj):
    """A room of its document's backend (:mod:`.backend`): an Arch/BIM Space, or an
    IfcSpace of a NativeIFC document (FreeCAD 1.x)."""
    return backend.of(obj).is_room(obj)


def is_native(space):
    """True for a room of a NativeIFC document."""
    return backend.of(space).native


def room_name(space):
    """The name of a room shown to the user: its Label, or a NativeIFC IfcSpace's
    LongName ("Wohnen"; NativeIFC labels it with the IFC Name, e.g. "1")."""
    return backend.of(space).room_name(space)


def find_spaces(doc):
    """All rooms of a document (Arch Spaces, or a NativeIFC document's IfcSpaces), in
    document order."""
    return backend.of(doc).rooms(doc)


def space_uid(space):
    """The IFC GlobalId stored on a Space (``IfcData['IfcUID']``, or a NativeIFC
    space's ``GlobalId``) or ''."""
    return backend.of(space).room_uid(space)


def get_space(doc, key):
    """The Space whose Name, Label or IFC GlobalId is ``key``; SceneError if none/ambiguous."""
    spaces = find_spaces(doc)
    if not spaces:
        raise SceneError("the document has no rooms (Arch Spaces)", doc.Label)
    for attr in ("Name", "Label", "room"):
        hit = [s for s in spaces
               if (room_name(s) if attr == "room" else getattr(s, attr)) == key]
        if len(hit) == 1:
            return hit[0]
        if len(hit) > 1:
            raise SceneError(f"{len(hit)} rooms are labelled {key!r}: use their names"
                             f" ({', '.join(s.Name for s in hit)})", doc.Label)
    hit = [s for s in spaces if space_uid(s) == key]
    if hit:
        return hit[0]
    raise SceneError(f"no room {key!r}; the rooms are: "
                     + ", ".join(describe(s) for s in spaces), doc.Label)


def room_shape(space):
    """The room's closed solid, in global coordinates (mm), checked by its document's
    backend (:meth:`.backend.DocumentBackend.room_solid`).

    Raises
    ------
    SceneError
        Naming the room when it has no geometry, its boundaries enclose no volume or its
        surface is not closed.
    """
    return backend.of(space).room_solid(space)


def check_resolution(resolution_m):
    try:
        r = float(resolution_m)
    except (TypeError, ValueError):
        raise SettingsError(f"resolution {resolution_m!r} is not a length in metres")
    if not np.isfinite(r) or r < S.MIN_RESOLUTION_M:
        raise SettingsError(f"resolution {resolution_m!r} m: must be a finite length of at"
                            f" least {S.MIN_RESOLUTION_M} m")
    if r > 100:
        raise SettingsError(f"resolution {r} m is larger than any room; the resolution is in"
                            " metres (e.g. 0.3)")
    return r


def _face_outward_normals(face, points_m, tris):
    """Outward normal per triangle of one face (FreeCAD's normalAt honours orientation)."""
    import FreeCAD
    surf = face.Surface
    if "Plane" in type(surf).__name__:
        u0, u1, v0, v1 = face.ParameterRange
        n = face.normalAt(0.5 * (u0 + u1), 0.5 * (v0 + v1))
        return np.tile([n.x, n.y, n.z], (len(tris), 1))
    out = np.empty((len(tris), 3))
    cent = points_m[tris].mean(axis=1) * 1000.0
    for i, c in enumerate(cent):
        u, v = face.Surface.parameter(FreeCAD.Vector(*c))
        n = face.normalAt(u, v)
        out[i] = (n.x, n.y, n.z)
    return out


def classify(normal_in):
    """Surface kind from an inward unit normal: floor (faces up), ceiling, or wall."""
    nz = float(normal_in[2])
    if nz > S.FLOOR_CEILING_NZ:
        return "floor"
    if nz < -S.FLOOR_CEILING_NZ:
        return "ceiling"
    return "wall"


def _check_reflectance(value, what, source):
    try:
        r = float(value)
    except (TypeError, ValueError):
        raise SceneError(f"{what} is {value!r}: reflectance must be a number in [0, 1)",
                         source)
    if not np.isfinite(r) or r < 0 or r >= 1:
        raise SceneError(f"{what} is {value!r}: reflectance must be in [0, 1) (a fraction,"
                         " not a percentage)", source)
    return r


def mesh_room(space, resolution_m=S.RESOLUTION_M, reflectance=None, open_regions=None):
    """Mesh the boundary surfaces of a Space for sampling.

    Parameters
    ----------
    space : Arch Space
    resolution_m : float
        Longest triangle edge, metres.
    reflectance : dict, optional
        Overrides of the default reflectance: keys 'floor', 'wall', 'ceiling' (per kind)
        and/or int (0-based face index); values in [0, 1).
    open_regions : dict, optional
        ``{0-based face index: [Part.Face, ...]}`` (mm, in that face's plane): the parts
        of the face that are open borders to another room (:func:`open_borders`). The face
        is meshed in two parts, its triangles there are flagged in ``triangle_open``.

    Returns
    -------
    RoomMesh
    """
    t0 = time.perf_counter()
    res = check_resolution(resolution_m)
    shape = room_shape(space)
    verts, tris, tface, topen = [], [], [], []
    coarse_v, coarse_t = [], []
    n_v = n_cv = 0
    face_normal, face_area, kinds = [], [], []
    for i, face in enumerate(shape.Faces):
        pieces = _split_open(face, (open_regions or {}).get(i))
        meshed = [(m, is_open) for sub, is_open in pieces
                  for m in [_mesh_face(sub, res, orient=face)] if m is not None]
        if not meshed:
            face_normal.append(np.zeros(3))
            face_area.append(0.0)
            kinds.append("wall")
            continue
        n_sum, a_sum = np.zeros(3), 0.0
        for ((cp, ct), (p, t), n, area), is_open in meshed:
            coarse_v.append(cp)
            coarse_t.append(ct + n_cv)
            n_cv += len(cp)
            verts.append(p)
            tris.append(t + n_v)
            tface.append(np.full(len(t), i, dtype=np.int64))
            topen.append(np.full(len(t), is_open))
            n_v += len(p)
            n_sum += n * area
            a_sum += area
        nn = np.linalg.norm(n_sum)
        n = n_sum / nn if nn > 0 else n_sum
        face_normal.append(n)
        face_area.append(a_sum)
        kinds.append(classify(n))
    if not tris:
        raise SceneError(f"room {describe(space)}: its surfaces could not be tessellated",
                         space.Label)
    v = np.concatenate(verts)
    t = np.concatenate(tris)
    tf = np.concatenate(tface)
    vol = signed_volume(v, t)
    coarse = (np.concatenate(coarse_v), np.concatenate(coarse_t))
    if vol > 0:         # the solid was inside out: its "outward" normals pointed in
        t = t[:, [0, 2, 1]]
        coarse = (coarse[0], coarse[1][:, [0, 2, 1]])
        face_normal = [-n for n in face_normal]
        kinds = [classify(n) for n in face_normal]
        vol = -vol
    expected = abs(shape.Volume) / 1e9
    if expected > 0 and abs(-vol - expected) > 0.01 * expected + 1e-6:
        raise SceneError(f"room {describe(space)}: its mesh encloses {-vol:.3f} m^3 but the"
                         f" solid {expected:.3f} m^3; the surface is not a valid closed"
                         " solid", space.Label)
    rho = _face_reflectances(kinds, reflectance, space.Label)
    return RoomMesh(space=space.Name, label=room_name(space), vertices=v, triangles=t,
                    triangle_face=tf, face_kind=kinds, face_normal=np.array(face_normal),
                    face_area=np.array(face_area), face_reflectance=rho, volume=-vol,
                    seconds=time.perf_counter() - t0, coarse=coarse,
                    triangle_open=np.concatenate(topen))


def _split_open(face, regions):
    """``[(sub-face, is_open), ...]``: ``face`` cut into the part on open borders
    (``regions``, Part faces in its plane) and the rest; ``[(face, False)]`` without."""
    if not regions:
        return [(face, False)]
    import Part
    region = Part.Compound(list(regions))
    opened = [f for f in face.common(region).Faces if f.Area > 1.0]
    rest = [f for f in face.cut(region).Faces if f.Area > 1.0]
    if not opened:
        return [(face, False)]
    return [(f, False) for f in rest] + [(f, True) for f in opened]


def _mesh_face(face, res, orient=None):
    """Tessellate one face of a room solid and refine it to edges <= ``res`` metres.

    ``orient`` is the face of the solid whose outward normal winds the triangles (a
    part of it cut off by a boolean operation may have lost its orientation); default
    ``face``.

    Returns ``((coarse_vertices, coarse_triangles), (vertices, triangles), normal,
    area_m2)`` with triangles wound to face into the room (metres; the unit ``normal`` is
    the refined triangles' mean), or None when the face gives no triangles.
    """
    pts, ftris = face.tessellate(S.TESSELLATION_TOL_MM)
    if not ftris:
        return None
    p = points_mm_to_m(pts)
    t = np.asarray(ftris, dtype=np.int64).reshape(-1, 3)
    out = _face_outward_normals(orient if orient is not None else face, p, t)
    tn = triangle_normals(p, t)
    flip = np.einsum("ij,ij->i", tn, out) > 0       # facing out: wind the other way
    t[flip] = t[flip][:, [0, 2, 1]]
    coarse = (p, t)
    p, t, _ = refine(p, t, res)
    tn = triangle_normals(p, t)
    area2 = np.linalg.norm(tn, axis=1)
    keep = area2 > 1e-14
    t = t[keep]
    n = tn[keep].sum(0)
    nn = np.linalg.norm(n)
    n = n / nn if nn > 0 else n
    return coarse, (p, t), n, 0.5 * float(area2[keep].sum())


def _face_reflectances(kinds, reflectance, label):
    """(n_faces,) reflectance: the default of each face's kind, then per-kind overrides
    ('floor', 'wall', 'ceiling'), then per-face ones (0-based int keys), all checked."""
    rho = np.array([S.REFLECTANCE[k] for k in kinds], dtype=np.float64)
    for key, value in (reflectance or {}).items():
        if isinstance(key, str):
            if key not in SURFACE_KINDS:
                raise SceneError(f"unknown surface kind {key!r} for reflectance; use one of"
                                 f" {', '.join(SURFACE_KINDS)}", label)
            r = _check_reflectance(value, f"{key} reflectance", label)
            rho[[k == key for k in kinds]] = r
    for key, value in (reflectance or {}).items():
        if not isinstance(key, str):
            k = int(key)
            if not 0 <= k < len(kinds):
                raise SceneError(f"reflectance given for Face{k + 1}, but the room has"
                                 f" {len(kinds)} faces", label)
            rho[k] = _check_reflectance(value, f"reflectance of Face{k + 1}", label)
    return rho


def face_count(space):
    """Number of faces of a Space's shape (0 without geometry)."""
    return backend.of(space).face_count(space)


def faces_by_kind(space, kind):
    """``['FaceN', ...]`` of a Space's faces of one kind ('floor', 'wall'/'walls',
    'ceiling', 'all'), from their outward normals."""
    kind = {"walls": "wall", "floors": "floor", "ceilings": "ceiling"}.get(kind, kind)
    shape = room_shape(space)
    out = []
    for i, f in enumerate(shape.Faces):
        if kind == "all":
            out.append(f"Face{i + 1}")
            continue
        u0, u1, v0, v1 = f.ParameterRange
        n = f.normalAt(0.5 * (u0 + u1), 0.5 * (v0 + v1))
        if classify((-n.x, -n.y, -n.z)) == kind:
            out.append(f"Face{i + 1}")
    if kind not in SURFACE_KINDS and kind != "all":
        raise SceneError(f"unknown surface kind {kind!r}; use floor, walls, ceiling or all",
                         space.Label)
    return out


# --------------------------------------------------------------------------- open borders
#: Two room faces at most this far apart (m) are one border: much thinner than any wall,
#: wide enough for rounding in IFC exports (FZK-Haus' open borders meet within 0.01 mm).
OPEN_BORDER_TOL_M = 0.01
#: Smaller shared areas (m^2) are touching edges or slivers, not open borders.
OPEN_BORDER_MIN_AREA_M2 = 0.05
#: IFC types of objects that close a border even where two rooms meet (rooms modelled to
#: wall axes, a wall overlapping both): anything built, not furniture or fixtures.
BLOCKING_TYPES = {"Wall", "Curtain Wall", "Column", "Slab", "Plate", "Member", "Window",
                  "Door", "Roof", "Covering", "Beam", "Building Element Proxy", "Chimney",
                  "Footing", "Pile", "Ramp", "Stair", "Shading Device"}


@dataclass
class OpenBorder:
    """Where two rooms meet with nothing between them: their faces coincide (opposite
    normals, same plane within :data:`OPEN_BORDER_TOL_M`) and no wall is there.

    Attributes
    ----------
    a, b : int, positions of the two rooms in the list given to :func:`open_borders`
    face_a, face_b : int, 0-based face of each room's solid (``FaceN`` - 1)
    region_a, region_b : Part.Face (mm), the open part, in the plane of each face
    area_m2 : float, its area
    """
    a: int
    b: int
    face_a: int
    face_b: int
    region_a: object
    region_b: object
    area_m2: float


def _is_planar(face):
    return "Plane" in type(face.Surface).__name__


def _outward(face):
    u0, u1, v0, v1 = face.ParameterRange
    return face.normalAt(0.5 * (u0 + u1), 0.5 * (v0 + v1))


def _ifc_kind(obj):
    """An object's IFC type in Arch's words ('Wall', 'Slab'...) or '' (NativeIFC objects
    give their class, 'IfcWallStandardCase' -> 'Wall')."""
    import re
    kind = str(getattr(obj, "IfcType", "") or "")
    cls = str(getattr(obj, "IfcClass", "") or "")
    if not kind and cls.startswith("Ifc"):
        name = cls[3:].replace("StandardCase", "").replace("ElementedCase", "")
        kind = " ".join(re.findall(r"[A-Z][a-z0-9]*", name))
    return kind


def blocking_solids(doc, spaces=()):
    """``[(object, global solid shape)]``: the document's walls, slabs, columns, windows,
    doors... (:data:`BLOCKING_TYPES`), which close a border between rooms that touch."""
    skip = {s.Name for s in spaces}
    for s in spaces:
        base = getattr(s, "Base", None)
        if base is not None:
            skip.add(base.Name)
    out = []
    for obj in doc.Objects:
        if obj.Name in skip or is_space(obj) or _ifc_kind(obj) not in BLOCKING_TYPES:
            continue
        shape = getattr(obj, "Shape", None)
        if shape is None or shape.isNull() or not shape.Solids:
            continue
        try:
            out.append((obj, global_shape(obj)))
        except Exception:
            continue
    return out


def open_borders(spaces, doc=None, tol_m=OPEN_BORDER_TOL_M, min_area_m2=OPEN_BORDER_MIN_AREA_M2,
                 shapes=None):
    """Open borders between rooms: faces of two Spaces that coincide with no wall between.

    Two planar faces are a border when their outward normals are opposite (within 2.6
    degrees), their planes are at most ``tol_m`` apart and they overlap (one projected on
    the other's plane, their common part). What of it lies in a wall, slab, column,
    window or door of ``doc`` (:func:`blocking_solids`; rooms modelled to wall axes meet
    inside the wall) is taken off. What is left, if at least ``min_area_m2``, is open.
    Horizontal faces are left out: an opening between storeys (a void) would be a
    horizontal virtual plane, which the locate core takes for a work plane.

    Parameters
    ----------
    spaces : list of Arch Spaces (or NativeIFC IfcSpaces)
    doc : FreeCAD document whose building elements may close a border (None: none)
    tol_m, min_area_m2 : float
    shapes : list of their :func:`room_shape` solids, optional (computed otherwise)

    Returns
    -------
    list of :class:`OpenBorder`
    """
    import FreeCAD
    import Part
    tol = float(tol_m) * 1000.0
    min_area = float(min_area_m2) * 1e6
    shapes = shapes or [room_shape(s) for s in spaces]
    blockers = None
    out = []
    for i in range(len(spaces)):
        box_i = FreeCAD.BoundBox(shapes[i].BoundBox)
        box_i.enlarge(tol)
        for j in range(i + 1, len(spaces)):
            if not box_i.intersect(shapes[j].BoundBox):
                continue
            for fi, fa in enumerate(shapes[i].Faces):
                if not _is_planar(fa):
                    continue
                na = _outward(fa)
                if abs(na.z) > S.FLOOR_CEILING_NZ:
                    continue
                box_a = FreeCAD.BoundBox(fa.BoundBox)
                box_a.enlarge(tol)
                for fj, fb in enumerate(shapes[j].Faces):
                    if not _is_planar(fb) or not box_a.intersect(fb.BoundBox):
                        continue
                    if na.dot(_outward(fb)) > -0.999:
                        continue
                    d = (fb.CenterOfMass - fa.CenterOfMass).dot(na)
                    if abs(d) > tol:
                        continue
                    moved = fb.copy()
                    moved.translate(na * (-d))
                    common = [f for f in fa.common(moved).Faces if f.Area > 1.0]
                    if sum(f.Area for f in common) < min_area:
                        continue
                    region = Part.Compound(common)
                    if blockers is None:
                        blockers = blocking_solids(doc, spaces) if doc is not None else []
                    for _, solid in blockers:
                        if solid.BoundBox.intersect(region.BoundBox):
                            region = Part.Compound([f for f in region.cut(solid).Faces
                                                    if f.Area > 1.0])
                    faces = region.Faces
                    area = sum(f.Area for f in faces)
                    if area < min_area:
                        continue
                    ra = Part.Compound(faces)
                    rb = ra.copy()
                    rb.translate(na * d)
                    out.append(OpenBorder(i, j, fi, fj, ra, rb, area / 1e6))
    return out


def lighting_zones(n_rooms, borders):
    """Rooms joined by open borders: ``(n_rooms,)`` int, the zone of each room (the
    lowest position of its rooms, so that a room without open borders is its own zone)."""
    from invrad_wb.core.geometry.components import component_labels
    return component_labels(n_rooms, ((b.a, b.b) for b in borders))


def containing_room(point_m, shapes, candidates=None):
    """The position (in ``shapes``) of the room solid that contains a point, else of the
    nearest one (a luminaire on a ceiling lies on its room's boundary).

    Parameters
    ----------
    point_m : (3,) float, metres
    shapes : list of room solids (mm, :func:`room_shape`)
    candidates : positions to choose from (default all)
    """
    import FreeCAD
    import Part
    from invrad_wb.app.units import MM_PER_M
    p = FreeCAD.Vector(*(float(c) * MM_PER_M for c in point_m))
    candidates = list(range(len(shapes))) if candidates is None else list(candidates)
    best, best_d = candidates[0], np.inf
    for k in candidates:
        sh = shapes[k]
        if sh.isInside(p, 0.5, True):
            return k
        d = sh.distToShape(Part.Vertex(p))[0]
        if d < best_d:
            best, best_d = k, d
    return best
