"""Meshes trimesh reads (OBJ, STL, glTF, ...) and their lux sidecars (JSON or CSV, per
vertex or per face)."""
import json
import os

import numpy as np

from invrad_wb.errors import InvradError, SceneError
from invrad_wb.core.model.scene import _check_lux
from invrad_wb.core.io.common import (_MeshData, _check_face_values, _check_vertices,
                                      _extension, _read_bytes)


#: Mesh extensions whose up axis is +Y by specification (converted to +Z).
Y_UP_EXTENSIONS = (".glb", ".gltf")


_SIDECAR_KEYS = ("vertex_lux", "face_lux", "face_room", "face_reflectance")


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
