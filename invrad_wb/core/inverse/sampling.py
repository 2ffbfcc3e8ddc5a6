"""Poisson-disk voting points on a room's surfaces (thesis 4.1.1.1 and 4.2.2).

As in the thesis, the Poisson-disk pattern is precalculated (``tables/poisson_tile.npz``, a
tileable pattern of a unit square made by ``tables/make_poisson_tile.py``) and looked up at
run time. Unlike the thesis, which sampled each triangle on its own (so the minimum distance
broke down at triangle borders and on finely meshed surfaces), the tile is laid over each
*plane* in its (u, v) coordinates, scaled to the requested density, with a per-plane offset;
points outside the plane's faces are dropped. Each point gets the face it lies on, its
barycentric coordinates and the face's target illuminance there.
"""
from dataclasses import dataclass
import functools
import hashlib
import json
import os

import numpy as np

from invrad_wb import constants as C
from invrad_wb.errors import InvradError, SettingsError
from invrad_wb.core.geometry.raster import locate_points, plane_triangles_2d


@dataclass
class VotingPoints:
    """Voting points of a scene.

    Attributes
    ----------
    positions : (k, 3) float64, metres
    normals : (k, 3) float64, unit (the face's plane normal)
    face : (k,) int64 scene face
    plane : (k,) int64 scene plane
    bary : (k, 3) float64 barycentric coordinates in the face
    lux : (k,) float64 target illuminance (NaN = no target, 0 = shade)
    area : (k,) float64, m^2 each point stands for (1 / density)
    density : float, points per m^2
    """

    positions: np.ndarray
    normals: np.ndarray
    face: np.ndarray
    plane: np.ndarray
    bary: np.ndarray
    lux: np.ndarray
    area: np.ndarray
    density: float

    def __len__(self):
        return len(self.positions)

    def subset(self, mask):
        return VotingPoints(self.positions[mask], self.normals[mask], self.face[mask],
                            self.plane[mask], self.bary[mask], self.lux[mask],
                            self.area[mask], self.density)


@functools.lru_cache(maxsize=1)
def poisson_tile():
    """The precalculated tileable Poisson-disk pattern: points (N, 2) in [0, 1)^2.

    Raises
    ------
    InvradError
        If the file is missing or its checksum does not match.
    """
    path = os.path.join(C.TABLES_DIR, "poisson_tile.npz")
    meta_path = os.path.join(C.TABLES_DIR, "poisson_tile.json")
    try:
        with open(path, "rb") as fh:
            data = fh.read()
        with open(meta_path, "r", encoding="utf-8") as fh:
            meta = json.load(fh)
    except OSError as exc:
        raise InvradError(f"{exc.filename}: missing ({exc.strerror}); regenerate it with"
                          " 'python tables/make_poisson_tile.py'")
    if hashlib.sha256(data).hexdigest() != meta.get("sha256"):
        raise InvradError(f"{path}: checksum does not match {meta_path}; regenerate it with"
                          " 'python tables/make_poisson_tile.py'")
    import io
    return np.load(io.BytesIO(data))["points"]


#: Peak bytes per candidate point of the tiled Poisson pattern (uv, masks, point location).
SAMPLE_BYTES_PER_POINT = 320


def _tile_grid(plane, side):
    return (int(np.ceil((plane.size[0] + side) / side)),
            int(np.ceil((plane.size[1] + side) / side)))


def require_sampling_memory(scene, plane_ids, density):
    """Refuse (:class:`~invrad_wb.core.model.memory.MemoryLimitError`) a votes-per-m^2
    whose candidate points would not fit in the memory budget, before sampling."""
    from invrad_wb.core.model.memory import require
    n_tile = len(poisson_tile())
    side = np.sqrt(n_tile / density)
    per_plane = [float(np.prod(_tile_grid(scene.planes[pi], side), dtype=np.float64)) * n_tile
                 for pi in plane_ids]
    if not per_plane:
        return
    # planes are sampled one at a time; the kept points of all of them stay
    area = sum(float(np.prod(scene.planes[pi].size)) for pi in plane_ids)
    require(max(per_plane) * SAMPLE_BYTES_PER_POINT + area * density * 64,
            f"{density:.3g} votes per m^2 ({max(per_plane):.3g} candidate points on the"
            f" largest plane)", "use fewer --votes-per-m2")


def sample_plane(scene, plane, density, seed=0):
    """Poisson-disk points on one plane's faces.

    Returns
    -------
    positions (k, 3), face (k,), bary (k, 3)
    """
    tile = poisson_tile()
    side = np.sqrt(len(tile) / density)  # metres covered by one tile
    rng = np.random.default_rng([seed, plane.index])
    offset = rng.random(2) * side
    nu, nv = _tile_grid(plane, side)
    gi, gj = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    shifts = np.stack([gi.reshape(-1), gj.reshape(-1)], axis=1) * side - offset
    uv = (tile[None, :, :] * side + shifts[:, None, :]).reshape(-1, 2)
    keep = ((uv[:, 0] >= -1e-9) & (uv[:, 0] <= plane.size[0] + 1e-9)
            & (uv[:, 1] >= -1e-9) & (uv[:, 1] <= plane.size[1] + 1e-9))
    uv = uv[keep]
    tri_idx, bary = locate_points(plane_triangles_2d(scene, plane), uv)
    ok = tri_idx >= 0
    faces = plane.faces[tri_idx[ok]]
    bary = bary[ok]
    pos = np.einsum("kj,kjc->kc", bary, scene.vertices[scene.faces[faces]])
    return pos, faces, bary


def default_density(scene, target_points=3000, lo=2.0, hi=400.0):
    """Votes per m^2 giving about ``target_points`` targeted points in the largest room.

    Only faces that carry a target count: a room whose only target is its work plane gets
    its points there instead of a sixth of them.
    """
    tg = scene.vertex_targets()
    has = np.any(np.isfinite(tg[scene.faces]), axis=1)
    area = np.where(has, scene.face_areas, 0.0)
    if not has.any():
        area = scene.face_areas
    areas = np.bincount(scene.face_room, weights=area)
    largest = float(areas.max())
    return float(np.clip(target_points / max(largest, 1e-9), lo, hi))


def voting_points(scene, density=None, planes=None, seed=0, keep_untargeted=False):
    """Poisson-disk voting points over a scene's planes.

    Parameters
    ----------
    scene : Scene
    density : float, optional
        Votes per square metre (the thesis' "votes per square meter"); default
        :func:`default_density`.
    planes : iterable of int, optional
        Planes to sample (default: all).
    seed : int
        Seed of the per-plane tile offsets (results are deterministic).
    keep_untargeted : bool
        Keep points whose target is NaN (no target).

    Returns
    -------
    VotingPoints
    """
    if density is None:
        density = default_density(scene)
    density = float(density)
    if not np.isfinite(density) or density <= 0:
        raise SettingsError(f"votes per m^2 must be a positive number, got {density!r}")
    plane_ids = range(len(scene.planes)) if planes is None else planes
    require_sampling_memory(scene, plane_ids, density)
    pos, fac, bar = [], [], []
    for pi in plane_ids:
        p, f, b = sample_plane(scene, scene.planes[pi], density, seed)
        pos.append(p)
        fac.append(f)
        bar.append(b)
    pos = np.concatenate(pos) if pos else np.zeros((0, 3))
    fac = np.concatenate(fac).astype(np.int64) if fac else np.zeros(0, np.int64)
    bar = np.concatenate(bar) if bar else np.zeros((0, 3))
    lux = scene.target_lux(fac, bar)
    pts = VotingPoints(positions=pos, normals=scene.face_normals[fac].copy(), face=fac,
                       plane=scene.face_plane[fac], bary=bar, lux=lux,
                       area=np.full(len(pos), 1.0 / density), density=density)
    if not keep_untargeted:
        pts = pts.subset(np.isfinite(lux))
    return pts
