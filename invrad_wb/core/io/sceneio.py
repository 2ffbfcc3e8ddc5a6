"""Scene files: read meshes with target illuminance into a :class:`Scene`, write PLY.

Three input forms, chosen by :func:`read_scene` from the file name:

1. **PLY** (the interchange format): vertex properties ``x y z [lux]``, face properties
   ``vertex_indices [room] [reflectance] [lux] [virtual]`` (per-face ``lux`` instead of
   per-vertex; ``virtual`` 1 marks a work plane's faces, which receive light and neither
   block nor reflect it),
   ASCII or binary (little or big endian). Read by invrad's own PLY parser
   (:mod:`invrad_wb.core.io.ply` says why not trimesh's or plyfile's). Polygons are
   triangulated (:mod:`invrad_wb.core.geometry.triangulation`: a fan for convex ones, ear
   clipping for concave ones), their per-face properties copied to every triangle;
   non-planar polygons are refused.
2. **Any mesh trimesh reads** (OBJ, STL, OFF, GLB/glTF, ...) plus a lux *sidecar*:
   ``ROOM.lux.json`` holding ``{"vertex_lux": [...]}`` or ``{"face_lux": [...]}`` and
   optionally ``"face_room"`` and ``"face_reflectance"``, or a ``.csv``/``.txt`` with one
   value per line (as many as the mesh has vertices: per vertex; as many as faces: per
   face; ``nan`` = no target). ``ROOM.lux.json|csv|txt`` next to ``ROOM.obj`` is found by
   itself. glTF is Y-up by its specification and is turned to invrad's Z-up.
3. **UV-mapped illuminance textures**: a mesh with texture coordinates plus an image read
   by OpenImageIO. Float images (EXR, HDR, float TIFF) hold lux; 8/16-bit images (PNG,
   JPEG, TIFF) hold fractions of ``texture_max_lux`` (white = that many lux, linear in the
   stored code value, no sRGB decoding). RGB is reduced to Rec.709 luminance; pixels whose
   alpha is below 0.5 are no target (:mod:`invrad_wb.core.model.oiio`, the one image reader).

Coordinates are converted to metres at this boundary (``unit``). Every error is a
:class:`SceneError` naming the file and the offending face/vertex/pixel and value. Writes
are atomic (:mod:`invrad_wb.core.io.atomic`): a failed write leaves any earlier file intact.

After reading, a scene carries two extra attributes:

* ``face_source (m,) int64``: the face of the file each triangle comes from (for PLY the
  polygon index, for other meshes the triangle index as trimesh loaded it);
* ``polygons_triangulated``: how many polygons with more than 3 corners were split.
"""
import os

import numpy as np

from invrad_wb.errors import SceneError
from invrad_wb.core.io.common import (UNITS, _check_face_values, _check_readable, _extension,
                                      _per_face_option, _unit_scale)
from invrad_wb.core.geometry.triangulation import triangulate_polygons
from invrad_wb.core.io.ply import PlyList, _mesh_from_ply, read_ply_elements, write_ply
from invrad_wb.core.io.meshes import _apply_sidecar, _mesh_from_trimesh, read_lux_sidecar
from invrad_wb.core.io.textures import read_lux_texture

#: the scene-file API (the format modules' public names are re-exported here)
__all__ = ["read_scene", "write_scene", "find_sidecar", "read_lux_texture", "read_lux_sidecar",
           "read_ply_elements", "write_ply", "PlyList", "triangulate_polygons", "UNITS",
           "SIDECAR_SUFFIXES"]

#: Names of lux sidecars next to a mesh ``ROOM.ext``: ``ROOM`` + one of these.
SIDECAR_SUFFIXES = (".lux.json", ".lux.csv", ".lux.txt")


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


