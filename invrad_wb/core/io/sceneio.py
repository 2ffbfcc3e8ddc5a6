"""Scene files: read meshes with target illuminance into a :class:`Scene`, write PLY.

Three input forms, chosen by :func:`read_scene` from the file name:

1. **PLY** (the interchange format): vertex properties ``x y z [lux]``, face properties
   ``vertex_indices [room] [reflectance] [lux]`` (per-face ``lux`` instead of per-vertex),
   ASCII or binary (little or big endian). Read by this module's own PLY parser (see
   :func:`read_ply_elements` for why not trimesh's). Polygons are triangulated here (a fan
   for convex ones, ear clipping for concave ones), their per-face properties copied to
   every triangle; non-planar polygons are refused.
2. **Any mesh trimesh reads** (OBJ, STL, OFF, GLB/glTF, ...) plus a lux *sidecar*:
   ``ROOM.lux.json`` holding ``{"vertex_lux": [...]}`` or ``{"face_lux": [...]}`` and
   optionally ``"face_room"`` and ``"face_reflectance"``, or a ``.csv``/``.txt`` with one
   value per line (as many as the mesh has vertices: per vertex; as many as faces: per
   face; ``nan`` = no target). ``ROOM.lux.json|csv|txt`` next to ``ROOM.obj`` is found by
   itself. glTF is Y-up by its specification and is turned to invrad's Z-up.
3. **UV-mapped illuminance textures**: a mesh with texture coordinates plus an image read
   by OpenImageIO. Float images (EXR, HDR, float TIFF) hold lux; 8/16-bit images (PNG,
   JPEG, TIFF) hold fractions of ``texture_max_lux`` (white = that many lux, linear in the
   stored code value, no sRGB decoding). RGB is reduced to Rec.709 luminance; alpha is
   ignored.

Coordinates are converted to metres at this boundary (``unit``). Every error is a
:class:`SceneError` naming the file and the offending face/vertex/pixel and value. Writes
are atomic (:mod:`invrad_wb.core.io.atomic`): a failed write leaves any earlier file intact.

After reading, a scene carries two extra attributes:

* ``face_source (m,) int64``: the face of the file each triangle comes from (for PLY the
  polygon index, for other meshes the triangle index as trimesh loaded it);
* ``polygons_triangulated``: how many polygons with more than 3 corners were split.
"""
import json
import os
import re
import struct

import numpy as np

from invrad_wb import constants as C
from invrad_wb.errors import InvradError, SceneError, SettingsError
from invrad_wb.core.io.atomic import atomic_path
from invrad_wb.core.model.scene import Scene, _check_lux, plane_basis

#: Length units accepted by ``unit=`` and their size in metres.
UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001}
#: Names of lux sidecars next to a mesh ``ROOM.ext``: ``ROOM`` + one of these.
SIDECAR_SUFFIXES = (".lux.json", ".lux.csv", ".lux.txt")
#: Rec.709 luminance weights for RGB lux textures.
#: Mesh extensions whose up axis is +Y by specification (converted to +Z).
Y_UP_EXTENSIONS = (".glb", ".gltf")

_PLY_TYPES = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
              "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
              "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
              "float": "f4", "float32": "f4", "double": "f8", "float64": "f8"}
_PLY_FORMATS = {"ascii": None, "binary_little_endian": "<", "binary_big_endian": ">"}
_SIDECAR_KEYS = ("vertex_lux", "face_lux", "face_room", "face_reflectance")
_PLY_UV_NAMES = (("s", "t"), ("u", "v"), ("texture_u", "texture_v"),
                 ("texture_s", "texture_t"))


# ====================================================================== entry points
def read_scene(path, lux=None, texture=None, texture_max_lux=None, unit="m",
               reflectance=None, room=None):
    """Read a scene file into a checked :class:`Scene`, choosing the reader by extension.

    Parameters
    ----------
    path : str or os.PathLike
        ``.ply``, or any mesh trimesh reads (``.obj``, ``.stl``, ``.off``, ``.glb`` ...).
    lux : str or os.PathLike, optional
        Lux sidecar (``.json``, ``.csv``, ``.txt``); see the module docstring. Without it,
        ``ROOM.lux.json|csv|txt`` next to a non-PLY mesh ``ROOM.ext`` is used if present.
        Targets given here replace those stored in the mesh file.
    texture : str or os.PathLike, optional
        UV-mapped illuminance image; the mesh must have texture coordinates (PLY: vertex
        properties ``s t``, ``u v`` or ``texture_u texture_v``). Replaces file targets.
    texture_max_lux : float, optional
        Lux of a white pixel of an 8/16-bit texture (required for those, refused for
        float images, whose values are lux).
    unit : {"m", "cm", "mm"}
        Length unit of the file's coordinates; converted to metres.
    reflectance : float or (f,) array_like, optional
        Reflectance in [0, 1) of all faces, or one per face of the file; replaces the
        file's values.
    room : int or (f,) array_like, optional
        Room id of all faces, or one per face of the file; replaces the file's values.

    Returns
    -------
    Scene
        With ``face_source (m,)`` and ``polygons_triangulated`` set (module docstring).

    Raises
    ------
    SceneError
        Naming the file and the offending face/vertex/pixel and value.
    SettingsError
        For an unknown ``unit`` or a non-positive ``texture_max_lux``.
    """
    path = os.fspath(path)
    scale = _unit_scale(unit)
    _check_readable(path)
    if lux is not None and texture is not None:
        raise SceneError("give target illuminance as a lux sidecar or as a texture, not both",
                         path)
    ext = _extension(path)
    if ext == ".ply":
        mesh = _mesh_from_ply(path, scale, need_uv=texture is not None)
    else:
        if lux is None and texture is None:
            lux = find_sidecar(path)
        mesh = _mesh_from_trimesh(path, scale, need_uv=texture is not None,
                                  keep_order=lux is not None)
    if lux is not None:
        _apply_sidecar(mesh, read_lux_sidecar(lux))
    if texture is not None:
        mesh.vertex_lux = mesh.face_lux = None
        mesh.lux_texture = read_lux_texture(texture, texture_max_lux)
    if room is not None:
        mesh.face_room = _per_face_option("room", room, mesh, np.float64)
    if reflectance is not None:
        mesh.face_reflectance = _per_face_option("reflectance", reflectance, mesh,
                                                 np.float64)
    _check_face_values(path, mesh.face_room, mesh.face_reflectance)
    return mesh.scene()


def write_scene(path, scene, lux=None, binary=True, comments=()):
    """Write a scene; only PLY (``.ply``) for now. See :func:`write_ply`."""
    path = os.fspath(path)
    if _extension(path) != ".ply":
        raise SceneError(f"cannot write scenes as '{_extension(path) or 'no extension'}':"
                         " only .ply is supported for now", path)
    write_ply(path, scene, lux=lux, binary=binary, comments=comments)


def find_sidecar(mesh_path):
    """The lux sidecar ``ROOM.lux.json|csv|txt`` next to ``ROOM.ext``, or None.

    Raises
    ------
    SceneError
        If more than one exists (which one is meant is unclear).
    """
    mesh_path = os.fspath(mesh_path)
    stem = os.path.splitext(mesh_path)[0]
    found = [stem + s for s in SIDECAR_SUFFIXES if os.path.isfile(stem + s)]
    if len(found) > 1:
        raise SceneError(f"several lux sidecars next to the mesh ({', '.join(found)});"
                         " pass the one to use explicitly", mesh_path)
    return found[0] if found else None


# ====================================================================== mesh data
class _MeshData:
    """A mesh on its way into a Scene: triangles plus per-file-face and per-vertex values.

    ``face_*`` arrays are per *file face* (``n_file_faces``, polygons for PLY) and are
    copied to triangles through ``face_source`` in :meth:`scene`.
    """

    def __init__(self, path, vertices, faces, face_source, n_file_faces, n_split=0):
        self.path = path
        self.vertices = vertices
        self.faces = faces
        self.face_source = face_source
        self.n_file_faces = n_file_faces
        self.n_split = n_split
        self.vertex_lux = self.face_lux = None
        self.face_room = self.face_reflectance = None
        self.vertex_uv = self.lux_texture = None

    def scene(self):
        fs = self.face_source

        def per_triangle(a):
            return None if a is None else np.asarray(a)[fs]

        face_uv = None
        if self.lux_texture is not None:
            face_uv = self.vertex_uv[self.faces]
        try:
            scene = Scene(self.vertices, self.faces, vertex_lux=self.vertex_lux,
                          face_lux=per_triangle(self.face_lux),
                          face_room=per_triangle(self.face_room),
                          face_reflectance=per_triangle(self.face_reflectance),
                          face_uv=face_uv, lux_texture=self.lux_texture, source=self.path)
        except SceneError as exc:
            if not self.n_split or "face" not in str(exc):
                raise
            msg = str(exc)
            prefix = f"{self.path}: "
            msg = msg[len(prefix):] if msg.startswith(prefix) else msg
            raise SceneError(f"{msg} (face numbers here count triangles: {self.n_split} of the"
                             f" file's {self.n_file_faces} faces were polygons, split into"
                             f" {len(self.faces)} triangles in file order)", self.path) from None
        scene.face_source = fs.copy()
        scene.polygons_triangulated = int(self.n_split)
        return scene


def _unit_scale(unit):
    try:
        return UNITS[unit]
    except (KeyError, TypeError):
        raise SettingsError(f"unit must be one of {', '.join(UNITS)}, not {unit!r}") from None


def _extension(path):
    return os.path.splitext(os.fspath(path))[1].lower()


def _check_readable(path):
    if not os.path.exists(path):
        raise SceneError("file not found", path)
    if os.path.isdir(path):
        raise SceneError("is a folder, not a file", path)


def _read_bytes(path):
    _check_readable(path)
    try:
        with open(path, "rb") as fh:
            return fh.read()
    except OSError as exc:
        raise SceneError(f"cannot read file: {exc.strerror or exc}", path) from None


def _per_face_option(name, value, mesh, dtype):
    try:
        arr = np.asarray(value, dtype=dtype)
    except (TypeError, ValueError):
        raise SettingsError(f"{name} must be a number or one number per face,"
                            f" not {value!r}") from None
    if arr.ndim == 0:
        return np.full(mesh.n_file_faces, arr, dtype=dtype)
    arr = arr.reshape(-1)
    if len(arr) != mesh.n_file_faces:
        raise SceneError(f"{len(arr)} {name} values given for the file's"
                         f" {mesh.n_file_faces} faces", mesh.path)
    return arr


def _check_face_values(source, room=None, reflectance=None, lux=None, what="face"):
    """Check per-face values with the indices of the file they come from."""
    if room is not None:
        fr = np.asarray(room, dtype=np.float64)
        bad = ~np.isfinite(fr) | (fr != np.round(fr)) | (fr < 0)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise SceneError(f"room id of {what} {i} is {fr[i]}: must be an integer >= 0;"
                             f" {int(bad.sum())} such {what}(s)", source)
    if reflectance is not None:
        rho = np.asarray(reflectance, dtype=np.float64)
        bad = ~np.isfinite(rho) | (rho < 0) | (rho >= 1)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise SceneError(f"reflectance of {what} {i} is {rho[i]}: must be in [0, 1)"
                             f" (a fraction, not a percentage); {int(bad.sum())} such"
                             f" {what}(s)", source)
    if lux is not None:
        _check_lux("target illuminance", np.asarray(lux, dtype=np.float64), what, source)


def _check_vertices(vertices, source):
    bad = ~np.all(np.isfinite(vertices), axis=1)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise SceneError(f"vertex {i} has a non-finite coordinate {vertices[i].tolist()};"
                         f" {int(bad.sum())} such vertex(es)", source)


# ====================================================================== PLY reading
class PlyList:
    """A PLY list property in compressed form: ``counts (n,)`` and ``values (sum(counts),)``.

    Row ``i`` is ``values[starts[i]:starts[i] + counts[i]]``.
    """

    def __init__(self, counts, values):
        self.counts = np.asarray(counts, dtype=np.int64)
        self.values = values
        self.starts = np.concatenate([[0], np.cumsum(self.counts)[:-1]]).astype(np.int64)

    def __len__(self):
        return len(self.counts)

    def row(self, i):
        return self.values[self.starts[i]:self.starts[i] + self.counts[i]]


def read_ply_elements(path):
    """Parse a PLY file into its elements and properties, without interpreting them.

    trimesh's PLY reader is not used: it cannot read binary files that mix polygon sizes
    (triangles and quads), silently truncates non-integer values of integer properties in
    ASCII files and misreads files whose element counts do not match their data.

    Returns
    -------
    elements : dict
        ``{element name: {property name: array}}`` in file order; scalar properties are
        ``(count,)`` arrays (float64 for float types, int64 for integer types), list
        properties are :class:`PlyList`.
    comments : list of str
        The header's comment lines.

    Raises
    ------
    SceneError
        For a file that is missing, not a PLY, or whose data does not match its header.
    """
    path = os.fspath(path)
    data = _read_bytes(path)
    fmt, decls, comments, offset = _parse_ply_header(data, path)
    if fmt is None:
        elements = _read_ply_ascii(data[offset:], decls, path)
    else:
        elements = _read_ply_binary(data, offset, decls, fmt, path)
    return elements, comments


def _parse_ply_header(data, path):
    """Return (endian or None for ASCII, [(element, count, [(name, type, count_type)])],
    comments, data offset)."""
    if data[:64].split(b"\n", 1)[0].strip() != b"ply":
        raise SceneError("not a PLY file (it does not start with a 'ply' line)", path)
    m = re.search(rb"(^|\n)end_header[ \t]*\r?\n", data[:1 << 20])
    if m is None:
        m = re.search(rb"(^|\n)end_header[ \t]*$", data[:1 << 20])
        if m is None:
            raise SceneError("PLY header has no 'end_header' line", path)
    offset = m.end()
    lines = data[:m.start()].decode("utf-8", errors="replace").splitlines()[1:]
    fmt = "missing"
    decls, comments = [], []
    for lineno, raw in enumerate(lines, start=2):
        words = raw.split()
        if not words:
            continue
        key = words[0]
        if key == "comment":
            comments.append(raw.strip()[len("comment"):].strip())
        elif key == "obj_info":
            continue
        elif key == "format":
            if len(words) != 3 or words[1] not in _PLY_FORMATS:
                raise SceneError(f"PLY header line {lineno}: unknown format '{raw.strip()}'"
                                 f" (expected one of {', '.join(_PLY_FORMATS)})", path)
            fmt = _PLY_FORMATS[words[1]]
        elif key == "element":
            if len(words) != 3 or not words[2].isdigit():
                raise SceneError(f"PLY header line {lineno}: bad element line"
                                 f" '{raw.strip()}'", path)
            decls.append((words[1], int(words[2]), []))
        elif key == "property":
            if not decls:
                raise SceneError(f"PLY header line {lineno}: property before any element",
                                 path)
            if len(words) == 3 and words[1] in _PLY_TYPES:
                decls[-1][2].append((words[2], _PLY_TYPES[words[1]], None))
            elif (len(words) == 5 and words[1] == "list" and words[2] in _PLY_TYPES
                  and words[3] in _PLY_TYPES and _PLY_TYPES[words[2]][0] in "iu"):
                decls[-1][2].append((words[4], _PLY_TYPES[words[3]], _PLY_TYPES[words[2]]))
            else:
                raise SceneError(f"PLY header line {lineno}: bad property line"
                                 f" '{raw.strip()}'", path)
        else:
            raise SceneError(f"PLY header line {lineno}: unknown keyword '{key}'", path)
    if fmt == "missing":
        raise SceneError("PLY header has no 'format' line", path)
    return fmt, decls, comments, offset


def _as_property(values, code, element, prop, row0, path):
    """float64 values -> float64 or (checked integral) int64 per the declared type."""
    if code[0] == "f":
        return values
    bad = ~np.isfinite(values) | (values != np.round(values))
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise SceneError(f"{element} {row0(i)}: {prop} is {values[i]!r}, but the property is"
                         " declared as an integer", path)
    return values.astype(np.int64)


def _read_ply_ascii(body, decls, path):
    tokens = body.split()
    try:
        vals = np.array(tokens, dtype=np.float64)
    except ValueError:
        for k, tok in enumerate(tokens):
            try:
                float(tok)
            except ValueError:
                raise SceneError(f"PLY data value {k} is '{tok.decode(errors='replace')}',"
                                 " not a number", path) from None
        raise
    pos = 0
    out = {}
    for element, count, props in decls:
        cols = {}
        if all(cdt is None for _, _, cdt in props):
            k = len(props)
            if pos + count * k > len(vals):
                raise SceneError(f"file ends early: element '{element}' needs {count} rows of"
                                 f" {k} values", path)
            block = vals[pos:pos + count * k].reshape(count, k)
            pos += count * k
            for j, (name, code, _) in enumerate(props):
                cols[name] = _as_property(block[:, j], code, element, name, lambda i: i, path)
        else:
            done = _read_ply_ascii_uniform(vals, pos, element, count, props, cols, path)
            pos = done if done is not None else _read_ply_ascii_lists(
                vals, pos, element, count, props, cols, path)
        out[element] = cols
    if pos != len(vals):
        raise SceneError(f"{len(vals) - pos} values after the last element: the element"
                         " counts in the header do not match the data", path)
    return out


def _read_ply_ascii_uniform(vals, pos, element, count, props, cols, path):
    """Fast path: every row's lists have the first row's lengths. None if they don't."""
    layout, width = [], 0
    for name, code, cdt in props:
        if cdt is None:
            layout.append((name, code, None, width))
            width += 1
            continue
        if pos + width >= len(vals):
            return None
        c = vals[pos + width]
        if not (c >= 0 and c == int(c)):
            return None
        layout.append((name, code, int(c), width))
        width += 1 + int(c)
    if count == 0 or pos + count * width > len(vals):
        return None
    block = vals[pos:pos + count * width].reshape(count, width)
    for name, code, c, col in layout:
        if c is not None and np.any(block[:, col] != c):
            return None
    for name, code, c, col in layout:
        if c is None:
            cols[name] = _as_property(block[:, col], code, element, name, lambda i: i, path)
        else:
            flat = block[:, col + 1:col + 1 + c].reshape(-1)
            cols[name] = PlyList(np.full(count, c),
                                 _as_property(flat, code, element, name,
                                              lambda i, c=c: i // max(c, 1), path))
    return pos + count * width


def _read_ply_ascii_lists(vals, pos, element, count, props, cols, path):
    """Rows with list properties, one row after the other (their length varies)."""
    n = len(vals)
    scalars = {name: np.empty(count) for name, _, cdt in props if cdt is None}
    counts = {name: np.empty(count, dtype=np.int64) for name, _, cdt in props if cdt}
    pieces = {name: [] for name in counts}
    for r in range(count):
        for name, code, cdt in props:
            if pos >= n:
                raise SceneError(f"file ends early in {element} {r} (of {count})", path)
            if cdt is None:
                scalars[name][r] = vals[pos]
                pos += 1
                continue
            c = vals[pos]
            if not (c >= 0 and c == int(c)):
                raise SceneError(f"{element} {r}: list length of {name} is {c!r}", path)
            c = int(c)
            if pos + 1 + c > n:
                raise SceneError(f"file ends early in {element} {r} (of {count})", path)
            counts[name][r] = c
            pieces[name].append(vals[pos + 1:pos + 1 + c])
            pos += 1 + c
    for name, code, cdt in props:
        if cdt is None:
            cols[name] = _as_property(scalars[name], code, element, name, lambda i: i, path)
        else:
            flat = np.concatenate(pieces[name]) if pieces[name] else np.empty(0)
            lst = PlyList(counts[name], flat)
            row_of = np.repeat(np.arange(count), lst.counts)
            lst.values = _as_property(flat, code, element, name, lambda i: int(row_of[i]),
                                      path)
            cols[name] = lst
    return pos


def _read_ply_binary(data, offset, decls, endian, path):
    out = {}
    u8 = np.frombuffer(data, dtype=np.uint8)
    for element, count, props in decls:
        has_list = any(cdt for _, _, cdt in props)
        left = len(data) - offset
        cols = None
        if not has_list:
            dt = np.dtype([(f"p{j}", endian + code) for j, (_, code, _) in enumerate(props)])
            if count * dt.itemsize > left:
                raise SceneError(f"file ends early: element '{element}' needs"
                                 f" {count * dt.itemsize} bytes, {left} left", path)
            rec = np.frombuffer(data, dtype=dt, count=count, offset=offset)
            cols = {name: _from_binary(rec[f"p{j}"], code)
                    for j, (name, code, _) in enumerate(props)}
            offset += count * dt.itemsize
        elif count:
            cols, offset = _read_ply_binary_uniform(data, offset, element, count, props,
                                                    endian)
            if cols is None:
                cols, offset = _read_ply_binary_ragged(data, u8, offset, element, count,
                                                       props, endian, path)
        else:
            cols = {name: (PlyList([], np.empty(0)) if cdt else np.empty(0))
                    for name, _, cdt in props}
        out[element] = cols
    if data[offset:].strip(b" \t\r\n\0"):
        raise SceneError(f"{len(data) - offset} bytes after the last element: the element"
                         " counts in the header do not match the data", path)
    return out


def _from_binary(arr, code):
    return np.asarray(arr, dtype=np.float64 if code[0] == "f" else np.int64)


def _read_ply_binary_uniform(data, offset, element, count, props, endian):
    """Fast path: every row's lists have the first row's lengths. None if they don't."""
    fields, pos = [], offset
    for j, (name, code, cdt) in enumerate(props):
        if cdt is None:
            fields.append((f"p{j}", endian + code))
            pos += np.dtype(code).itemsize
            continue
        if pos + np.dtype(cdt).itemsize > len(data):
            return None, offset
        c = int(np.frombuffer(data, dtype=endian + cdt, count=1, offset=pos)[0])
        if c < 0:
            return None, offset
        fields.append((f"n{j}", endian + cdt))
        fields.append((f"p{j}", endian + code, (c,)))
        pos += np.dtype(cdt).itemsize + c * np.dtype(code).itemsize
    dt = np.dtype(fields)
    if count * dt.itemsize > len(data) - offset:
        return None, offset
    rec = np.frombuffer(data, dtype=dt, count=count, offset=offset)
    cols = {}
    for j, (name, code, cdt) in enumerate(props):
        if cdt is None:
            cols[name] = _from_binary(rec[f"p{j}"], code)
            continue
        n = rec[f"n{j}"]
        c = dt[f"p{j}"].shape[0]
        if np.any(n != c):
            return None, offset
        cols[name] = PlyList(np.full(count, c), _from_binary(rec[f"p{j}"], code).reshape(-1))
    return cols, offset + count * dt.itemsize


def _read_ply_binary_ragged(data, u8, offset, element, count, props, endian, path):
    """Rows whose lists differ in length: find each row's start, then gather per property."""
    nprop = len(props)
    offs = np.empty((count, nprop), dtype=np.int64)
    lens = np.zeros((count, nprop), dtype=np.int64)
    size = [np.dtype(code).itemsize for _, code, _ in props]
    csize = [np.dtype(cdt).itemsize if cdt else 0 for _, _, cdt in props]
    cfmt = [endian + {"i1": "b", "u1": "B", "i2": "h", "u2": "H", "i4": "i", "u4": "I"}[cdt]
            if cdt else None for _, _, cdt in props]
    end = len(data)
    pos = offset
    for r in range(count):
        for j in range(nprop):
            offs[r, j] = pos
            if cfmt[j] is None:
                pos += size[j]
            else:
                if pos + csize[j] > end:
                    raise SceneError(f"file ends early in {element} {r} (of {count})", path)
                c = struct.unpack_from(cfmt[j], data, pos)[0]
                if c < 0:
                    raise SceneError(f"{element} {r}: list length of {props[j][0]} is {c}",
                                     path)
                lens[r, j] = c
                pos += csize[j] + c * size[j]
        if pos > end:
            raise SceneError(f"file ends early in {element} {r} (of {count})", path)
    cols = {}
    for j, (name, code, cdt) in enumerate(props):
        dt = np.dtype(endian + code)
        if cdt is None:
            idx = offs[:, j, None] + np.arange(size[j])
            cols[name] = _from_binary(u8[idx].copy().view(dt).reshape(-1), code)
            continue
        nbytes = lens[:, j] * size[j]
        first = np.repeat(offs[:, j] + csize[j], nbytes)
        within = np.arange(int(nbytes.sum())) - np.repeat(np.cumsum(nbytes) - nbytes, nbytes)
        flat = u8[first + within].copy().view(dt)
        cols[name] = PlyList(lens[:, j], _from_binary(flat, code))
    return cols, pos


# ====================================================================== PLY -> mesh
def _mesh_from_ply(path, scale, need_uv=False):
    elements, _ = read_ply_elements(path)
    vert = elements.get("vertex")
    if vert is None:
        raise SceneError("PLY has no 'vertex' element", path)
    missing = [c for c in "xyz" if c not in vert]
    if missing:
        raise SceneError(f"PLY vertex element has no {'/'.join(missing)} property", path)
    for c in "xyz":
        if isinstance(vert[c], PlyList):
            raise SceneError(f"PLY vertex property {c} is a list, must be a number", path)
    vertices = np.stack([vert["x"], vert["y"], vert["z"]], axis=1).astype(np.float64)
    _check_vertices(vertices, path)
    vertices = vertices * scale
    face = elements.get("face")
    if face is None:
        raise SceneError("PLY has no 'face' element (a point cloud is not a scene)", path)
    key = "vertex_indices" if "vertex_indices" in face else "vertex_index"
    polys = face.get(key)
    if not isinstance(polys, PlyList):
        raise SceneError("PLY face element has no list property 'vertex_indices'", path)
    faces, face_source, n_split = triangulate_polygons(vertices, polys, path)
    mesh = _MeshData(path, vertices, faces, face_source, len(polys), n_split)

    def scalar(el, name, what):
        a = el.get(name)
        if isinstance(a, PlyList):
            raise SceneError(f"PLY {what} property '{name}' is a list, must be a number",
                             path)
        return None if a is None else np.asarray(a, dtype=np.float64)

    mesh.vertex_lux = scalar(vert, "lux", "vertex")
    mesh.face_lux = scalar(face, "lux", "face")
    mesh.face_room = scalar(face, "room", "face")
    mesh.face_reflectance = scalar(face, "reflectance", "face")
    _check_face_values(path, mesh.face_room, mesh.face_reflectance, mesh.face_lux)
    if need_uv:
        for su, sv in _PLY_UV_NAMES:
            if su in vert and sv in vert:
                mesh.vertex_uv = np.stack([vert[su], vert[sv]], axis=1).astype(np.float64)
                break
        else:
            raise SceneError("a texture needs texture coordinates, but the PLY vertices have"
                             " no s/t (or u/v, texture_u/texture_v) properties", path)
    return mesh


def triangulate_polygons(vertices, polygons, source=None, tol=C.PLANE_OFFSET_TOL_M):
    """Split planar polygons into triangles with the polygons' winding.

    Convex polygons are split as a fan from their first corner, concave ones by ear
    clipping; triangles keep the order of their polygons.

    Parameters
    ----------
    vertices : (n, 3) float64, metres
    polygons : PlyList or sequence of sequences of int
        Corner indices of each polygon.
    source : str, optional
        File name for error messages.
    tol : float
        Largest distance (metres) of a corner from its polygon's plane.

    Returns
    -------
    faces : (m, 3) int64
    face_source : (m,) int64
        Index of the polygon each triangle comes from.
    n_split : int
        How many polygons had more than three corners.

    Raises
    ------
    SceneError
        For a polygon with fewer than 3 corners, an index out of range, a non-planar,
        zero-area or self-intersecting polygon (naming the polygon and the value).
    """
    if not isinstance(polygons, PlyList):
        rows = [np.asarray(p, dtype=np.int64).reshape(-1) for p in polygons]
        polygons = PlyList([len(p) for p in rows],
                           np.concatenate(rows) if rows else np.empty(0, np.int64))
    counts, idx = polygons.counts, np.asarray(polygons.values)
    nv = len(vertices)
    if idx.dtype.kind == "f":
        bad = ~np.isfinite(idx) | (idx != np.round(idx))
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            i = int(np.searchsorted(polygons.starts, k, side="right") - 1)
            raise SceneError(f"face {i} refers to vertex {idx[k]!r}: vertex indices must be"
                             " integers", source)
    idx = idx.astype(np.int64)
    small = counts < 3
    if small.any():
        i = int(np.flatnonzero(small)[0])
        raise SceneError(f"face {i} has {counts[i]} vertices (a face needs at least 3);"
                         f" {int(small.sum())} such face(s)", source)
    bad = (idx < 0) | (idx >= nv)
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        i = int(np.searchsorted(polygons.starts, k, side="right") - 1)
        raise SceneError(f"face {i} refers to vertex {idx[k]} but there are only {nv}"
                         f" vertices (indices 0..{nv - 1})", source)
    tris, owner = [], []
    for k in np.unique(counts):
        sel = np.flatnonzero(counts == k)
        corners = idx[polygons.starts[sel, None] + np.arange(k)]
        if k == 3:
            tris.append(corners)
            owner.append(sel)
            continue
        t, o = _triangulate_group(vertices, corners, sel, tol, source)
        tris.append(t)
        owner.append(o)
    if not tris:
        return np.empty((0, 3), np.int64), np.empty(0, np.int64), 0
    faces = np.concatenate(tris).astype(np.int64)
    face_source = np.concatenate(owner).astype(np.int64)
    order = np.argsort(face_source, kind="stable")
    return faces[order], face_source[order], int(np.sum(counts > 3))


def _triangulate_group(vertices, corners, sel, tol, source):
    """Triangulate polygons with the same number k > 3 of corners (g, k)."""
    g, k = corners.shape
    pts = vertices[corners]
    centre = pts.mean(axis=1, keepdims=True)
    d = pts - centre
    newell = np.cross(d, np.roll(d, -1, axis=1)).sum(axis=1)
    area2 = np.linalg.norm(newell, axis=1)
    size = np.max(np.linalg.norm(d, axis=2), axis=1)
    flat = area2 <= 1e-12 * np.maximum(size, 1e-300) ** 2
    if flat.any():
        i = int(np.flatnonzero(flat)[0])
        raise SceneError(f"face {sel[i]} (vertices {corners[i].tolist()}) has zero area",
                         source)
    normal = newell / area2[:, None]
    off_plane = np.abs(np.einsum("gkc,gc->gk", d, normal))
    worst = off_plane.max(axis=1)
    bad = worst > tol
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        j = int(np.argmax(off_plane[i]))
        raise SceneError(f"face {sel[i]} is not planar: its vertex {corners[i, j]} lies"
                         f" {worst[i]:.3g} m off the polygon's plane (tolerance {tol:g} m);"
                         f" {int(bad.sum())} such face(s). Non-planar polygons cannot be"
                         " triangulated faithfully: triangulate them in the modeller", source)
    # turn at each corner, in the polygon's own plane (positive = convex)
    e_in = pts - np.roll(pts, 1, axis=1)
    e_out = np.roll(pts, -1, axis=1) - pts
    turn = np.einsum("gkc,gc->gk", np.cross(e_in, e_out), normal)
    # convex: every corner turns left and the turns add up to one revolution (a star
    # polygon such as a pentagram turns left everywhere but twice around)
    total = np.arctan2(turn, np.einsum("gkc,gkc->gk", e_in, e_out)).sum(axis=1)
    convex = (np.all(turn > 1e-9 * size[:, None] ** 2, axis=1)
              & (np.abs(total - 2 * np.pi) < 1e-6))
    fan = np.stack([np.zeros(k - 2, np.int64), np.arange(1, k - 1), np.arange(2, k)], axis=1)
    tris = [corners[convex][:, fan].reshape(-1, 3)]
    owner = [np.repeat(sel[convex], k - 2)]
    for i in np.flatnonzero(~convex):
        u, v = plane_basis(normal[i])
        q = np.stack([d[i] @ u, d[i] @ v], axis=1)
        eps = 1e-9 * size[i] ** 2
        local = None if _edges_cross(q, eps) else _ear_clip(q, eps)
        if local is None:
            raise SceneError(f"face {sel[i]} (vertices {corners[i].tolist()}) cannot be"
                             " triangulated: it intersects itself or is degenerate", source)
        tris.append(corners[i][local])
        owner.append(np.full(len(local), sel[i]))
    return np.concatenate(tris), np.concatenate(owner)


def _edges_cross(q, eps):
    """True if two non-adjacent edges of the closed 2-D polygon q (k, 2) touch or cross."""
    k = len(q)
    i, j = np.triu_indices(k, 2)
    keep = ~((i == 0) & (j == k - 1))
    i, j = i[keep], j[keep]
    a, b = q, np.roll(q, -1, axis=0)

    def side(p, r, x):
        o = (r[:, 0] - p[:, 0]) * (x[:, 1] - p[:, 1]) - (r[:, 1] - p[:, 1]) * (x[:, 0] - p[:, 0])
        return np.where(np.abs(o) <= eps, 0, np.sign(o))

    def on(p, r, x):  # x within the bounding box of segment p-r
        tol = np.sqrt(eps)
        return np.all((np.minimum(p, r) - tol <= x) & (x <= np.maximum(p, r) + tol), axis=1)

    s1, s2 = side(a[i], b[i], a[j]), side(a[i], b[i], b[j])
    s3, s4 = side(a[j], b[j], a[i]), side(a[j], b[j], b[i])
    cross = (s1 * s2 < 0) & (s3 * s4 < 0)
    touch = (((s1 == 0) & on(a[i], b[i], a[j])) | ((s2 == 0) & on(a[i], b[i], b[j]))
             | ((s3 == 0) & on(a[j], b[j], a[i])) | ((s4 == 0) & on(a[j], b[j], b[i])))
    return bool(np.any(cross | touch))


def _ear_clip(q, eps):
    """Triangulate a simple counter-clockwise 2-D polygon q (k, 2); None if impossible."""
    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    ring = list(range(len(q)))
    out = []
    while len(ring) > 3:
        n = len(ring)
        for s in range(n):
            a, b, c = ring[s - 1], ring[s], ring[(s + 1) % n]
            if cross(q[a], q[b], q[c]) <= eps:
                continue  # reflex or straight corner: not an ear
            blocked = False
            for j in ring:
                if j in (a, b, c):
                    continue
                p = q[j]
                if (cross(q[a], q[b], p) >= -eps and cross(q[b], q[c], p) >= -eps
                        and cross(q[c], q[a], p) >= -eps):
                    blocked = True  # a corner inside or on the ear
                    break
            if not blocked:
                out.append((a, b, c))
                ring.pop(s)
                break
        else:
            return None
    a, b, c = ring
    if cross(q[a], q[b], q[c]) <= eps:
        return None
    out.append((a, b, c))
    return np.array(out, dtype=np.int64)


# ====================================================================== trimesh meshes
def _mesh_from_trimesh(path, scale, need_uv=False, keep_order=False):
    """Load any mesh trimesh reads; ``keep_order`` for per-vertex/per-face sidecars."""
    try:
        import trimesh
    except ImportError as exc:
        raise InvradError(f"reading {_extension(path)} meshes needs trimesh"
                          f" (pip install trimesh): {exc}") from None
    ext = _extension(path)
    formats = trimesh.available_formats()
    if ext[1:] not in formats:
        raise SceneError(f"unknown mesh format '{ext or 'no extension'}'; readable: .ply, "
                         + ", ".join("." + f for f in sorted(formats) if f != "ply"), path)
    kwargs = {"process": False}
    if ext == ".obj":
        # maintain_order keeps the file's vertices (unreferenced ones too) in file order,
        # but garbles texture coordinates at UV seams, so it is used only for sidecars
        kwargs.update(skip_materials=True, maintain_order=bool(keep_order and not need_uv))
    try:
        loaded = trimesh.load(path, **kwargs)
    except Exception as exc:  # trimesh raises many types for malformed files
        raise SceneError(f"cannot read as a {ext[1:].upper()} mesh: {exc}", path) from None
    if isinstance(loaded, trimesh.Trimesh):
        parts = [loaded]
    elif isinstance(loaded, trimesh.Scene):
        parts = [g for g in loaded.dump() if isinstance(g, trimesh.Trimesh)]
    else:
        parts = []
    parts = [p for p in parts if len(p.faces)]
    if not parts:
        raise SceneError(f"holds no triangles (trimesh read it as {type(loaded).__name__})",
                         path)
    if len(parts) > 1 and keep_order:
        raise SceneError(f"holds {len(parts)} separate meshes (objects or materials) whose"
                         " order trimesh does not keep, so per-vertex/per-face lux values"
                         " cannot be matched; join them into one mesh or use PLY", path)
    verts, faces, uvs, base = [], [], [], 0
    for p in parts:
        verts.append(np.asarray(p.vertices, dtype=np.float64))
        faces.append(np.asarray(p.faces, dtype=np.int64) + base)
        base += len(p.vertices)
        if need_uv:
            uv = getattr(p.visual, "uv", None)
            if uv is None or len(uv) != len(p.vertices):
                raise SceneError("a texture needs texture coordinates, but the mesh has none"
                                 " (UVs)", path)
            uvs.append(np.asarray(uv, dtype=np.float64))
    vertices = np.concatenate(verts)
    _check_vertices(vertices, path)
    if ext in Y_UP_EXTENSIONS:
        vertices = np.stack([vertices[:, 0], -vertices[:, 2], vertices[:, 1]], axis=1)
    faces = np.concatenate(faces)
    mesh = _MeshData(path, vertices * scale, faces, np.arange(len(faces)), len(faces))
    if need_uv:
        mesh.vertex_uv = np.concatenate(uvs)
    if ext == ".obj" and keep_order:
        mesh.obj_counts = _obj_counts(path)
    return mesh


def _obj_counts(path):
    """(vertex lines, face lines) of an OBJ file, for clearer count mismatch messages."""
    nv = nf = 0
    try:
        with open(path, "rb") as fh:
            for line in fh:
                if line.startswith(b"v "):
                    nv += 1
                elif line.startswith(b"f "):
                    nf += 1
    except OSError:
        return None
    return nv, nf


# ====================================================================== sidecars
def read_lux_sidecar(path):
    """Read a lux sidecar.

    Parameters
    ----------
    path : str or os.PathLike
        ``.json``: an object with ``vertex_lux`` or ``face_lux`` (lists, ``null``/``NaN``
        = no target) and optionally ``face_room``, ``face_reflectance`` (lists or one
        value for all faces) and ``comment``. ``.csv``/``.txt``: one value per line,
        ``nan`` = no target, ``#`` starts a comment line.

    Returns
    -------
    dict
        Some of ``vertex_lux``, ``face_lux``, ``values`` (a csv/txt column, per vertex or
        per face by its length), ``face_room``, ``face_reflectance``: float64 arrays;
        ``source``: the path.
    """
    path = os.fspath(path)
    data = _read_bytes(path)
    if _extension(path) == ".json":
        return _read_json_sidecar(data, path)
    if _extension(path) in (".csv", ".txt"):
        return {"values": _read_column(data, path), "source": path}
    raise SceneError("unknown lux sidecar type: use .json, .csv or .txt", path)


def _read_json_sidecar(data, path):
    try:
        doc = json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, ValueError) as exc:
        raise SceneError(f"not valid JSON: {exc}", path) from None
    if not isinstance(doc, dict):
        raise SceneError("must hold a JSON object like {\"vertex_lux\": [...]}", path)
    unknown = sorted(set(doc) - set(_SIDECAR_KEYS) - {"comment"})
    if unknown:
        raise SceneError(f"unknown key(s) {', '.join(map(repr, unknown))}; allowed:"
                         f" {', '.join(_SIDECAR_KEYS)}, comment", path)
    if ("vertex_lux" in doc) == ("face_lux" in doc):
        raise SceneError("give exactly one of 'vertex_lux' and 'face_lux'", path)
    out = {"source": path}
    for key in _SIDECAR_KEYS:
        if key not in doc:
            continue
        value = doc[key]
        lux_key = key.endswith("_lux")
        if not isinstance(value, list):
            if lux_key or isinstance(value, bool) or not isinstance(value, (int, float)):
                raise SceneError(f"'{key}' must be a list of numbers", path)
            out[key] = np.float64(value)
            continue
        arr = np.empty(len(value))
        for i, x in enumerate(value):
            if x is None and lux_key:
                arr[i] = np.nan
            elif isinstance(x, (int, float)) and not isinstance(x, bool):
                arr[i] = x
            else:
                raise SceneError(f"{key}[{i}] is {x!r}, not a number", path)
        out[key] = arr
    return out


def _read_column(data, path):
    text = data.decode("utf-8", errors="replace")
    lines = text.splitlines()
    while lines and not lines[-1].strip():
        lines.pop()
    values = []
    for lineno, line in enumerate(lines, start=1):
        s = line.strip()
        if s.startswith("#"):
            continue
        try:
            values.append(float(s))
        except ValueError:
            raise SceneError(f"line {lineno} is '{s}': need one number per line"
                             " (nan = no target)", path) from None
    return np.array(values, dtype=np.float64)


def _apply_sidecar(mesh, side):
    """Put sidecar values onto the mesh (they replace the file's own targets)."""
    src = side["source"]
    nv, nf = len(mesh.vertices), mesh.n_file_faces
    if "values" in side:
        vals = side["values"]
        if len(vals) == nv and len(vals) == nf:
            raise SceneError(f"{len(vals)} values, and the mesh has {nv} vertices and as many"
                             " faces: per vertex or per face is unclear; use a .lux.json with"
                             " 'vertex_lux' or 'face_lux'", src)
        if len(vals) == nv:
            side = {"vertex_lux": vals, "source": src}
        elif len(vals) == nf:
            side = {"face_lux": vals, "source": src}
        else:
            raise SceneError(f"{len(vals)} values, but {mesh.path} has {nv} vertices and"
                             f" {nf} faces{_count_hint(mesh)}", src)
    counts = {"vertex_lux": nv, "face_lux": nf, "face_room": nf, "face_reflectance": nf}
    for key, n in counts.items():
        if key in side and np.ndim(side[key]) and len(side[key]) != n:
            what = "vertices" if key.startswith("vertex") else "faces"
            raise SceneError(f"{len(side[key])} {key} values, but {mesh.path} has {n}"
                             f" {what}{_count_hint(mesh)}", src)
    if "vertex_lux" in side:
        _check_lux("target illuminance", side["vertex_lux"], "vertex", src)
    face = {k: (np.full(nf, side[k]) if k in side and not np.ndim(side[k]) else side.get(k))
            for k in ("face_lux", "face_room", "face_reflectance")}
    _check_face_values(src, face["face_room"], face["face_reflectance"], face["face_lux"])
    mesh.vertex_lux = side.get("vertex_lux")
    mesh.face_lux = face["face_lux"]
    if face["face_room"] is not None:
        mesh.face_room = face["face_room"]
    if face["face_reflectance"] is not None:
        mesh.face_reflectance = face["face_reflectance"]


def _count_hint(mesh):
    counts = getattr(mesh, "obj_counts", None)
    if not counts:
        return ""
    nv, nf = counts
    notes = []
    if nv != len(mesh.vertices):
        notes.append(f"the file lists {nv} vertices, trimesh kept {len(mesh.vertices)}")
    if nf != mesh.n_file_faces:
        notes.append(f"its {nf} polygons were split into {mesh.n_file_faces} triangles"
                     " (per-face values count triangles)")
    return f" ({'; '.join(notes)})" if notes else ""


# ====================================================================== textures
def read_lux_texture(path, max_lux=None):
    """Read an illuminance image as lux.

    Parameters
    ----------
    path : str or os.PathLike
        Any image OpenImageIO reads. Float images (EXR, HDR, float TIFF) hold lux; 8/16-bit
        images hold fractions of ``max_lux``.
    max_lux : float, optional
        Lux of a white (1.0) pixel; required for 8/16-bit images, refused for float ones.

    Returns
    -------
    (h, w) float64, lux
        Row 0 is the image's top row (v = 1). RGB is reduced to Rec.709 luminance, other
        images use their first channel; alpha below 0.5 and NaN pixels are no target
        (:mod:`invrad_wb.core.io.oiio`).
    """
    path = os.fspath(path)
    _check_readable(path)
    if max_lux is not None:
        try:
            ok = float(max_lux) > 0 and np.isfinite(float(max_lux))
        except (TypeError, ValueError):
            ok = False
        if not ok:
            raise SettingsError(f"texture_max_lux must be a positive number, not {max_lux!r}")
    from invrad_wb.core.io.oiio import read_lux_image
    try:
        image = read_lux_image(path)
    except OSError as exc:
        raise SceneError(f"cannot read as an image: {exc}", path)
    lux, is_float = image.values, image.is_float
    if is_float and max_lux is not None:
        raise SceneError(f"a {image.format} image holds lux already: texture_max_lux applies"
                         " to 8/16-bit images only", path)
    if not is_float:
        if max_lux is None:
            raise SceneError(f"a {image.format} image holds no lux values: give"
                             " texture_max_lux, the lux of a white pixel (or use a float"
                             " EXR/HDR/TIFF holding lux)", path)
        lux = lux * float(max_lux)
    bad = np.isinf(lux) | (lux < 0)
    if bad.any():
        y, x = (int(a[0]) for a in np.nonzero(bad))
        kind = "infinite" if np.isinf(lux[y, x]) else "negative"
        raise SceneError(f"pixel (x={x}, y={y}) is {lux[y, x]} lx: illuminance cannot be"
                         f" {kind} (NaN = no target); {int(bad.sum())} such pixel(s)", path)
    return lux


# ====================================================================== PLY writing
def write_ply(path, scene, lux=None, binary=True, comments=()):
    """Write a scene as PLY, atomically.

    Vertices (``x y z`` as double), triangles (``vertex_indices`` as ``list uchar int``),
    ``room`` (int) and ``reflectance`` (double) per face and the target illuminance
    (double, NaN = no target): ``lux`` per vertex if given, else the scene's own targets
    (per vertex or per face; a texture is sampled at the vertices). Doubles make round
    trips exact, in ASCII too (17 significant digits).

    Parameters
    ----------
    path : str or os.PathLike
    scene : Scene
    lux : (n,) float64, lux, optional
        Per-vertex illuminance (e.g. a render of the scene).
    binary : bool
        ``binary_little_endian`` (default) or ``ascii``.
    comments : sequence of str
        Header comments, e.g. ``["invrad render"]``.

    Raises
    ------
    SceneError
        If ``lux`` does not have one value per vertex.
    OSError
        If the file cannot be written; an existing file is then left unchanged.
    """
    path = os.fspath(path)
    n, m = len(scene.vertices), len(scene.faces)
    vertex_lux = face_lux = None
    if lux is not None:
        vertex_lux = np.asarray(lux, dtype=np.float64).reshape(-1)
        if len(vertex_lux) != n:
            raise SceneError(f"{len(vertex_lux)} lux values to write for {n} vertices", path)
    elif scene.vertex_lux is not None:
        vertex_lux = scene.vertex_lux
    elif scene.face_lux is not None:
        face_lux = scene.face_lux
    elif scene.lux_texture is not None:
        vertex_lux = scene.vertex_targets()
    endian = "<" if binary else "="
    vfields = [("x", "f8"), ("y", "f8"), ("z", "f8")] + ([("lux", "f8")]
                                                         if vertex_lux is not None else [])
    vrec = np.empty(n, dtype=[(k, endian + t) for k, t in vfields])
    for j, c in enumerate("xyz"):
        vrec[c] = scene.vertices[:, j]
    if vertex_lux is not None:
        vrec["lux"] = vertex_lux
    room = np.asarray(scene.face_room, dtype=np.int64)
    if room.size and room.max() > np.iinfo(np.int32).max:
        raise SceneError(f"room id {room.max()} does not fit a PLY int", path)
    ffields = [("n", "u1"), ("vertex_indices", "i4", (3,)), ("room", "i4"),
               ("reflectance", "f8")] + ([("lux", "f8")] if face_lux is not None else [])
    frec = np.empty(m, dtype=[(f[0], endian + f[1], *f[2:]) for f in ffields])
    frec["n"] = 3
    frec["vertex_indices"] = scene.faces
    frec["room"] = room
    frec["reflectance"] = scene.face_reflectance
    if face_lux is not None:
        frec["lux"] = face_lux
    names = {"f8": "double", "i4": "int"}
    head = ["ply", f"format {'binary_little_endian' if binary else 'ascii'} 1.0",
            "comment written by invrad"]
    head += ["comment " + " ".join(str(c).split()) for c in comments]
    head += [f"element vertex {n}"] + [f"property {names[t]} {k}" for k, t in vfields]
    head += [f"element face {m}", "property list uchar int vertex_indices",
             "property int room", "property double reflectance"]
    head += ["property double lux"] if face_lux is not None else []
    head += ["end_header", ""]
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        fh.write("\n".join(head).encode("ascii"))
        _write_block(fh, vrec, binary)
        _write_block(fh, frec, binary)
        fh.flush()
        os.fsync(fh.fileno())


def _write_block(fh, records, binary):
    """Write one element's rows: raw records, or text with round-trip exact numbers."""
    if binary:
        fh.write(records.tobytes())
        return
    cols, fmts = [], []
    for name in records.dtype.names:
        col = records[name]
        col = col.reshape(len(records), -1)
        cols.append(col)
        fmts += ["%.17g" if col.dtype.kind == "f" else "%d"] * col.shape[1]
    if not len(records):
        return
    table = np.concatenate([c.astype(object) for c in cols], axis=1)
    line = " ".join(fmts) + "\n"
    fh.write("".join(line % tuple(row) for row in table).encode("ascii"))
