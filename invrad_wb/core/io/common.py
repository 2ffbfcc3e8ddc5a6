"""What the scene readers share: units, the checked raw mesh, value checks with messages
that name the file, face or vertex."""
import os

import numpy as np

from invrad_wb.errors import SceneError, SettingsError
from invrad_wb.core.model.scene import Scene, _check_lux



#: Length units accepted by ``unit=`` and their size in metres.
UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001}


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
        self.face_virtual = None
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
                          face_virtual=per_triangle(self.face_virtual),
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
