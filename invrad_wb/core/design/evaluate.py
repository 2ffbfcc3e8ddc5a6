"""Light of candidate designs on a room's calculation grid: a fast model and the exact one.

The design search compares thousands of layouts, so it uses a *fast model*: exact direct
light of every luminaire at the grid points (intensity distribution, inverse square,
cosine at the receiver; no shadows) plus interreflected light proportional to the flux
in the room, ``E_ind(p) = g(p) * sum(F)``, where ``g`` (lx/lm per point) comes from an
exact radiosity solve of a reference layout. A learned per-point correction ``c(p)``
(exact / fast of the last exactly checked layout) absorbs what the fast model leaves out
(shadows in non-convex rooms, the layout's own interreflection pattern).

The *exact model* (:meth:`RoomModel.exact`) is what every verdict is based on: direct light
with occlusion (:func:`~invrad_wb.core.forward.direct.direct_illuminance`) plus a radiosity
solve of the room (:class:`~invrad_wb.core.forward.radiosity.RadiosityModel`), gathered at
the grid points. Both scale the new installation's light by the maintenance factor.
"""
import math
from dataclasses import replace

import numpy as np

from invrad_wb import constants as C
from invrad_wb.errors import SceneError
from invrad_wb.core.design import en12464
from invrad_wb.core.design.openings import (OPENING_REFLECTANCE, behind_openings,
                                            covered_share, luminous_samples,
                                            opening_quadrature, triangle_reach)
from invrad_wb.core.design.spec import TASK_PART
from invrad_wb.core.forward.direct import direct_illuminance
from invrad_wb.core.forward.occlusion import segments_occluded
from invrad_wb.core.forward.radiosity import RadiosityModel
from invrad_wb.core.geometry.bvh import BVH
from invrad_wb.core.geometry.meshing import nearest_site, refine
from invrad_wb.core.geometry.raster import locate_points
from invrad_wb.core.model.aiming import photometric_frame
from invrad_wb.core.model.luminaires import Luminaire, disk_quadrature
from invrad_wb.core.model.scene import Scene, plane_basis

#: receivers per block of the fast model (bounds its memory: block x luminaires x 8 bytes)
_BLOCK = 4096


def room_mesh(scene, room):
    """The room's faces as their own Scene, refined so radiosity patches can be small.

    Returns the Scene (real faces of the room only) refined to edges of at most the
    radiosity patch size that ~``RADIOSITY_TARGET_PATCHES`` patches would have.
    """
    sel = np.flatnonzero((scene.face_room == room) & ~scene.face_virtual)
    tri_v = scene.vertices
    faces = scene.faces[sel]
    area = float(scene.face_areas[sel].sum())
    edge = max(C.RADIOSITY_MIN_PATCH_M, math.sqrt(area / C.RADIOSITY_TARGET_PATCHES))
    v, t, tags = refine(tri_v, faces, edge, tags=sel)
    used, inv = np.unique(t.reshape(-1), return_inverse=True)
    return Scene(v[used], inv.reshape(-1, 3), face_room=scene.face_room[tags],
                 face_reflectance=scene.face_reflectance[tags], source=scene.source,
                 check_winding=False)


#: :func:`unit_response` of a lambertian disk: a receiver at least this many radii from its
#: centre, whose own plane keeps more than a radius from it (no horizon across the disk),
#: takes the 6-point ring of :func:`~invrad_wb.core.model.luminaires.disk_quadrature`
#: (1 ring x 6 angles) instead of the full rule (3 x 8): measured against a 40 x 96 rule at
#: random such receivers, worst 0.11 % at 5 radii, 0.06 % at 6, 0.01 % at 10 (the full
#: rule: 0.05 % at 3 radii, 0.9 % at 2); most of a room's receivers are that far from a
#: luminaire, and the fast model's disks then cost a quarter
DISK_FAR_RADII = 5.0


def unit_response(points, normals, positions, lum_normals, radius_m=0.0, photometry=None,
                  c0=None):
    """Direct illuminance per lumen: (k, L) lux/lm of L luminaires at k receivers, no shadows.

    Parameters
    ----------
    points, normals : (k, 3) float64, receivers (metres, unit normals)
    positions, lum_normals : (L, 3) float64, luminaire centres and facing directions
    radius_m : float, disk radius (the disk quadrature of the luminaires module; a lighter
        rule far from a lambertian disk, :data:`DISK_FAR_RADII`)
    photometry : object with ``intensity_per_lm(local_dirs)``, optional
        Intensity per lumen (cd/lm) for (..., 3) unit directions in the luminaire's frame
        (x, y in its plane, z along its facing normal); None: lambertian ``cos(gamma) / pi``.
    c0 : (3,) float64 or None, the C = 0 direction of every luminaire (made perpendicular to
        its normal; :func:`~invrad_wb.core.model.aiming.photometric_frame`)
    """
    points = np.asarray(points, dtype=np.float64)
    normals = np.asarray(normals, dtype=np.float64)
    positions = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    lum_normals = np.asarray(lum_normals, dtype=np.float64).reshape(-1, 3)
    far = None
    if radius_m > 0:
        qp, qw = disk_quadrature()
        qp = radius_m * qp
        if photometry is None:
            fp, fw = disk_quadrature(1, 6)
            far = (radius_m * fp, fw)
    else:
        qp, qw = opening_quadrature(photometry)
    out = np.zeros((len(points), len(positions)))
    step = max(1, _BLOCK * 64 // max(1, len(points)))
    for key in np.unique(np.round(lum_normals, 9), axis=0):
        cols = np.flatnonzero(np.all(np.abs(lum_normals - key) < 1e-8, axis=1))
        n = lum_normals[cols[0]]
        u, v = photometric_frame(n, c0)
        for b in range(0, len(cols), step):
            cb = cols[b:b + step]
            if far is None:
                out[:, cb] = _quadrature_sum(points, normals, positions[cb], n, u, v,
                                             qp, qw, photometry)
                continue
            # the light ring at receivers far from a disk, the full rule near it (pairs)
            out[:, cb] = _quadrature_sum(points, normals, positions[cb], n, u, v, *far, None)
            off = positions[cb][None] - points[:, None]                        # (k, l, 3)
            # (a receiver on or behind the disk's plane gets nothing from any of it)
            near = (((np.einsum("kli,kli->kl", off, off) < (DISK_FAR_RADII * radius_m) ** 2)
                     | (np.abs(np.einsum("kli,ki->kl", off, normals)) <= radius_m))
                    & (off @ n < 0.0))
            i, j = np.nonzero(near)
            if len(i):
                out[i, cb[j]] = _quadrature_sum(points[i], normals[i], positions[cb[j]], n,
                                                u, v, qp, qw, None, pairs=True)
    return out


def _quadrature_sum(points, normals, centres, n, u, v, qp, qw, photometry, pairs=False):
    """The quadrature ``qp`` (q, 2) metres along (u, v), weights ``qw``, of luminaires
    centred at ``centres`` facing ``n``: (k, l) lux/lm at the receivers, or with ``pairs``
    (k,) for receiver i and luminaire i (k == l)."""
    out = 0.0
    for q, w in zip(qp, qw):
        c = centres + q[0] * u + q[1] * v
        r = points - c if pairs else points[:, None, :] - c[None]
        r2 = np.maximum(np.einsum("...i,...i->...", r, r), 1e-12)
        along = (np.einsum("ki,ki->k", normals, r) if pairs
                 else np.einsum("ki,kli->kl", normals, r))
        if photometry is None:
            # cos(gamma) / pi x cos(receiver) / r^2 with both cosines' 1 / |r| folded in
            out = out + (w / np.pi) * (np.maximum(r @ n, 0.0) * np.maximum(-along, 0.0)
                                       / (r2 * r2))
            continue
        inv = 1.0 / np.sqrt(r2)
        d = r * inv[..., None]
        i_lm = photometry.intensity_per_lm(np.stack([d @ u, d @ v, d @ n], -1))
        out = out + w * i_lm * np.maximum(-along * inv, 0.0) / r2
    return out




class Layout:
    """Where the grids lie among a model's receivers: the work plane first (``n_wp``),
    then each surface grid (``parts``: name -> (slice, area weights)), then the points
    that must stay dark (from ``shade0`` on)."""

    def __init__(self, n_wp, parts=None, shade0=None):
        self.n_wp = int(n_wp)
        self.parts = parts or {}
        self.shade0 = self.n_wp if shade0 is None else int(shade0)

    @classmethod
    def of(cls, layout):
        """A Layout from a Layout or from a plain work-plane count (no surfaces)."""
        return layout if isinstance(layout, Layout) else cls(layout)


def surface_grids(scene, room, droom, lift_m=1e-3, backend="auto"):
    """Calculation points of a room's walls and ceiling (EN 12464-1:2021 5.2.3).

    The room's real faces (open borders left out) that stand upright (walls, columns,
    partitions: ``|n_z| <= 0.3``) or face down (ceiling, sloped or flat: ``n_z < -0.3``).
    Each plane of them gets the EN 12464-1 grid of its own: its extent split into equal
    cells no longer than the spacing ``p`` of the room's longer side (a 0.24 m return of a
    wall is one column of cells, not a sliver cut off by a grid laid over the whole room),
    a point at each cell's area-weighted centroid, ``lift_m`` off the surface, weighted by
    the cell's area (the mean is area-weighted, Emin the least cell). A fine input mesh thus
    gives no more points than a coarse one.

    Only what the room's occupants see is graded: the faces are split finely (edges of at
    most ``p / SURFACE_SPLIT``) and a piece counts where its centre faces into the floor
    outline, has no other face of the room within :data:`INSIDE_PROBE_M` in front of it
    (a crevice: FZK-Haus's Flur has a beam box hung 2 cm off a wall, a slot no one sees
    into), and can be seen from at least one eye point (:data:`EYE_HEIGHT_M` above the
    work-plane cells, outside the border zone where the room is wide enough, at most
    :data:`EYE_POINTS` of them spread over the room). The outside of a wall, a face kept
    with the wrong winding and a face hidden in a box are left out.

    Returns
    -------
    dict name -> (points (j, 3), normals (j, 3), weights (j,) m^2), for 'walls' and
    'ceiling' (a part the room lacks is left out)
    """
    sel = (scene.face_room == room) & ~scene.face_virtual
    nz = scene.face_normals[:, 2]
    p = en12464.grid_spacing(max(droom.size))
    eyes = _eye_points(droom)
    bvh = BVH(scene.vertices[scene.faces[np.flatnonzero(sel)]])
    out = {}
    for name, mask in (("walls", np.abs(nz) <= 0.3), ("ceiling", nz < -0.3)):
        faces = np.flatnonzero(sel & mask)
        if len(faces) == 0:
            continue
        v, t, tags = refine(scene.vertices, scene.faces[faces], p / SURFACE_SPLIT, tags=faces)
        tri = v[t]
        a = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]),
                                 axis=1)
        keep = a > 1e-12
        n, c, a = scene.face_normals[tags[keep]], tri[keep].mean(axis=1), a[keep]
        # a piece that does not face into the floor outline (the outside of a wall, a face
        # kept with the wrong winding) or that no eye sees (a crevice) is left out
        ahead = c[:, :2] + INSIDE_PROBE_M * n[:, :2]
        seen = droom.inside(ahead) & (droom.wall_distance(ahead) > 0.0)
        # a crevice: another face of the room closer in front than the probe
        lifted = c + lift_m * n
        s = np.flatnonzero(seen)
        seen[s] = ~segments_occluded(bvh, lifted[s], c[s] + INSIDE_PROBE_M * n[s], backend)
        seen[seen] = _seen_from(bvh, lifted[seen], n[seen], eyes, backend)
        if not seen.any():
            continue
        n, c, a = n[seen], c[seen], a[seen]
        cell = _plane_cells(n, c, p)
        w = np.bincount(cell, weights=a)
        pts = np.stack([np.bincount(cell, weights=a * c[:, i]) for i in range(3)], 1)
        nrm = np.stack([np.bincount(cell, weights=a * n[:, i]) for i in range(3)], 1)
        ok = w > 0
        w, pts, nrm = w[ok], pts[ok] / w[ok, None], nrm[ok]
        nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
        out[name] = (pts + lift_m * nrm, nrm, w)
    return out


#: surface pieces are split to edges of at most the grid spacing over this (for the
#: visibility of each piece and equal cells per plane)
SURFACE_SPLIT = 4
#: eye height of the points a surface must be seen from (m above the floor; EN 12464-1's
#: seated eye height 1.2 m)
EYE_HEIGHT_M = 1.2
#: at most this many eye points per room (spread over its work-plane cells)
EYE_POINTS = 24


def _eye_points(droom):
    """Up to :data:`EYE_POINTS` eye points of the room: its work-plane cells outside the
    border zone (all of them where that leaves none) at :data:`EYE_HEIGHT_M`, spread
    evenly."""
    pts = np.zeros((0, 3))
    for margin in (en12464.BORDER_M, 0.0):
        try:
            pts, _ = droom.grid(EYE_HEIGHT_M, margin)
            break
        except SceneError:      # too narrow, or no head room at eye height
            continue
    if len(pts) > EYE_POINTS:
        pts = pts[np.round(np.linspace(0, len(pts) - 1, EYE_POINTS)).astype(int)]
    return pts


def _seen_from(bvh, points, normals, eyes, backend="auto"):
    """(k,) bool: each surface point (its normal) sees at least one eye point in front."""
    seen = np.zeros(len(points), dtype=bool)
    if len(eyes) == 0:
        seen[:] = True
        return seen
    for eye in eyes:
        todo = np.flatnonzero(~seen)
        if len(todo) == 0:
            break
        front = np.einsum("ij,ij->i", eye - points[todo], normals[todo]) > 1e-6
        todo = todo[front]
        if len(todo):
            blocked = segments_occluded(bvh, points[todo],
                                        np.broadcast_to(eye, (len(todo), 3)), backend)
            seen[todo[~blocked]] = True
    return seen


def _plane_cells(n, c, p):
    """Cell index (k,) of surface pieces (normals n, centres c): per plane (normal and
    offset), its extent split into equal cells no longer than ``p`` on a side."""
    plane_key = np.c_[np.round(n * 1e3), np.round(np.einsum("ij,ij->i", n, c) / 1e-3)]
    _, plane = np.unique(plane_key, axis=0, return_inverse=True)
    plane = plane.reshape(-1)
    cell = np.zeros(len(c), dtype=np.int64)
    base = 0
    for k in range(plane.max() + 1):
        m = np.flatnonzero(plane == k)
        u, v = plane_basis(n[m[0]])
        st = np.c_[c[m] @ u, c[m] @ v]
        lo, hi = st.min(axis=0), st.max(axis=0)
        cnt = np.maximum(np.ceil((hi - lo) / p - 1e-9), 1).astype(np.int64)
        ij = np.minimum(((st - lo) / np.maximum(hi - lo, 1e-12) * cnt).astype(np.int64),
                        cnt - 1)
        cell[m] = base + ij[:, 0] * cnt[1] + ij[:, 1]
        base += int(cnt[0] * cnt[1])
    _, cell = np.unique(cell, return_inverse=True)
    return cell.reshape(-1)


#: how far in front of a surface cell its point must lie inside the floor outline (m)
INSIDE_PROBE_M = 0.05


#: solves :meth:`RoomModel.solve` keeps (a check's grid, UGR background, cylindrical eyes)
SOLVES_KEPT = 4


def _solve_key(luminaires, covering):
    """What a radiosity solve of ``luminaires`` under ``covering``'s openings depends on."""

    def one(lums):
        if lums is None:
            return None
        return tuple((lum.position.tobytes(), lum.normal.tobytes(), float(lum.flux_lm),
                      float(lum.radius_m), id(getattr(lum, "photometry", None)),
                      None if lum.c0 is None else np.asarray(lum.c0, float).tobytes())
                     for lum in lums)
    return one(list(luminaires)), one(None if covering is None else list(covering))


class RoomModel:
    """Exact and fast light of designs in one room, on its calculation grid.

    Parameters
    ----------
    scene : Scene (the whole input scene)
    droom : DesignRoom
    points : (k, 3) float64, calculation grid (work plane)
    maintenance_factor : float
    backend : str
    extra_points : (j, 3) float64 and (j, 3) normals, optional
        Further receivers evaluated along (e.g. points that must stay dark).
    surfaces : dict name -> (points (j, 3), normals (j, 3), weights (j,)), optional
        Calculation grids of the room's walls and ceiling (:func:`surface_grids`); they
        follow the work plane in ``points``, before the ``extra`` points.

    Attributes
    ----------
    layout : :class:`Layout` (where each grid lies in ``points``)
    """

    def __init__(self, scene, droom, points, maintenance_factor, backend="auto",
                 extra=None, surfaces=None):
        self.droom = droom
        self.mf = float(maintenance_factor)
        self.backend = backend
        self.mesh = room_mesh(scene, droom.room)
        self.rad = RadiosityModel(self.mesh, backend=backend, occlusion=True)
        blockers = self.rad.rooms[0].blockers if self.rad.rooms else np.zeros(0, int)
        self.bvh = BVH(self.mesh.triangles[blockers]) if len(blockers) else None
        n_wp = len(points)
        ex_p, ex_n = extra if extra is not None else (np.zeros((0, 3)), np.zeros((0, 3)))
        surfaces = surfaces or {}
        sp = [np.asarray(v[0], dtype=np.float64).reshape(-1, 3) for v in surfaces.values()]
        sn = [np.asarray(v[1], dtype=np.float64).reshape(-1, 3) for v in surfaces.values()]
        self.points = np.concatenate([points, *sp, ex_p])
        self.normals = np.concatenate([np.tile([0.0, 0.0, 1.0], (n_wp, 1)), *sn, ex_n])
        self.n_wp = n_wp
        parts, i = {}, n_wp
        for (name, v), p in zip(surfaces.items(), sp):
            parts[name] = (slice(i, i + len(p)), np.asarray(v[2], dtype=np.float64))
            i += len(p)
        self.layout = Layout(n_wp, parts, i)
        self._gather = self.rad.gather(self.points, self.normals, self._point_patches())
        self.correction = np.ones(len(self.points))
        self.indirect_per_lm = {}
        self._air_ops = {}        # indirect_at's gather operators, by receivers
        self._reach = triangle_reach(self.mesh.triangles)
        self._solved = []         # (key, luminaires, exitance) of the last SOLVES_KEPT

    def _point_patches(self):
        """Patch below each receiver: the floor patch under a work-plane point (its room,
        visibility row), the nearest patch's for other receivers."""
        m = self.mesh
        floor = np.flatnonzero(m.face_normals[:, 2] > 0.99)
        idx, _ = locate_points(m.triangles[floor][..., :2], self.points[:, :2])
        patch = np.where(idx >= 0, self.rad.face_patch[floor[np.maximum(idx, 0)]], -1)
        plane = np.arange(len(patch)) < self.n_wp
        for name, (sl, _) in self.layout.parts.items():   # work-plane cells too
            if name.startswith(("surroundings", "background", TASK_PART)):
                plane[sl] = True       # (cylindrical.py, background.py, taskareas.py)
        miss = np.flatnonzero((idx < 0) | ~plane)
        if len(miss):
            patch[miss] = self.rad.face_patch[nearest_site(m.face_centroids,
                                                           self.points[miss])]
        return patch

    # ------------------------------------------------------------------ exact
    def solve(self, luminaires, covering=None):
        """Patch exitance (P,) of luminaires' light: their direct light on the patches and
        the radiosity solve, with the ceiling behind their luminous openings reflecting
        as an opening (:data:`OPENING_REFLECTANCE`), not as ceiling. ``covering``: the
        luminaires whose openings cover the ceiling (default: ``luminaires``; a part of
        an installation lit alone, with the whole installation's openings in place,
        adds up to the whole: the reflectances stay those of the whole)."""
        key = _solve_key(luminaires, covering)
        for k, _held, b in self._solved:
            if k == key:
                return b
        b = self._solve(luminaires, covering)
        b.flags.writeable = False      # (the luminaires held: their photometry's id stays)
        self._solved = [(key, (luminaires, covering), b)] + self._solved[:SOLVES_KEPT - 1]
        return b

    def _solve(self, luminaires, covering):
        rad = self.rad
        e = rad.patch_direct(luminous_samples(luminaires), self.bvh, self.bvh is not None,
                             self.backend)
        m = self.mesh
        share = covered_share(m.triangles, m.face_normals,
                              luminaires if covering is None else covering, self._reach)
        if not share.any():
            return rad.solve(e)
        cov = np.bincount(rad.face_patch[rad.face_patch >= 0],
                          weights=(m.face_areas * share)[rad.face_patch >= 0],
                          minlength=rad.n_patches)
        cov = np.clip(cov / np.maximum(rad.patch_area, 1e-12), 0.0, 1.0)
        rho = rad.patch_reflectance
        try:
            rad.patch_reflectance = rho * (1.0 - cov) + OPENING_REFLECTANCE * cov
            return rad.solve(e)
        finally:
            rad.patch_reflectance = rho

    def exact(self, luminaires, covering=None):
        """Maintained illuminance (k,) lux at the receivers: direct with shadows plus a
        radiosity solve; and the direct part alone (``covering``: :meth:`solve`)."""
        occl = self.bvh is not None
        b = self.solve(luminaires, covering)
        hidden = self._behind(luminaires if covering is None else covering)
        luminaires = luminous_samples(luminaires)
        indirect = self._gather(b)
        direct = direct_illuminance(self.points, self.normals, luminaires, bvh=self.bvh,
                                    occlusion=occl, backend=self.backend)
        total = direct + indirect
        if hidden is not None:
            total, direct = self._left_out(total, hidden), self._left_out(direct, hidden)
        return self.mf * total, self.mf * direct

    def _behind(self, openings):
        """(k,) bool: the surface grids' receivers behind the luminous openings of
        ``openings`` (:func:`behind_openings`), or None where there are none."""
        if not self.layout.parts:
            return None
        hidden = np.zeros(len(self.points), dtype=bool)
        for sl, _ in self.layout.parts.values():
            hidden[sl] = behind_openings(self.points[sl], self.normals[sl], openings)
        return hidden if hidden.any() else None

    def _left_out(self, lux, hidden):
        """``lux`` with each surface grid's receivers behind an opening given the
        area-weighted mean of the grid's other receivers: the grid's mean and least value
        are then those of the ceiling that is there (the judge's, Radiance's grid less the
        points behind its light polygons), and the light stays linear in the outputs for
        a given set of openings. Measured (bench_wall_light.py, round 11): a PN-3600 0.45
        m from the wall of a 4 x 3 x 2.6 m box, ceiling 43.16 lx with its four points
        behind the panel (148 and 78 lx: next to the lit wall), 37.03 without; Radiance
        37.11; the L corridor's bound layout 30.00 / 28.56 lx, Radiance 28.40."""
        lux = lux.copy()
        for sl, w in self.layout.parts.values():
            h = hidden[sl]
            if not h.any() or h.all():
                continue
            part = lux[sl]
            part[h] = np.sum(part[~h] * w[~h]) / max(float(np.sum(w[~h])), 1e-300)
            lux[sl] = part
        return lux

    def exact_at(self, points, normals, luminaires):
        """Maintained illuminance (k,) lux of ``luminaires`` at any receivers in the room
        (spots on its surfaces): direct light with shadows plus interreflection."""
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        if not luminaires:
            return np.zeros(len(points))
        # receivers on a surface: lifted off it so that it does not shadow them
        normals = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
        lifted = points + 1e-4 * normals
        occl = self.bvh is not None
        luminaires = luminous_samples(luminaires)
        direct = direct_illuminance(lifted, normals, luminaires, bvh=self.bvh,
                                    occlusion=occl, backend=self.backend)
        return self.mf * (direct + self._surface_indirect(lifted, normals, luminaires))

    def _surface_indirect(self, points, normals, luminaires):
        """Interreflected illuminance (lux, new) at receivers on the room's surfaces: each
        gathered as lying on its nearest face's patch (that patch's plane gives nothing,
        its visibility row is the receiver's)."""
        near = nearest_site(self.mesh.face_centroids, points)
        op = self.rad.gather(points, normals, self.rad.face_patch[near])
        return op(self.solve(luminaires))

    def indirect_at(self, points, normals, luminaires, covering=None):
        """Interreflected illuminance (lux, new installation) at receivers in the air of
        the room, e.g. an observer's eye for the background luminance of UGR
        (``covering``: :meth:`solve`): every patch counts, the floor's too, as far as the
        point itself sees it (:meth:`air_gather` with its own visibility).

        Until round 13 an eye was gathered as lying on its nearest face's patch, whose
        plane then gave nothing: an eye farther from the walls than from the floor saw no
        floor light. Measured (tests/core/design/test_eye_background.py): 16 panels in a
        10 x 10 x 3 m box, eyes at its middle looking along x and y: 56.4 and 57.5 lx
        before, 89.4 and 90.3 now, Radiance 90.2 and 89.4 (-ab 5 -ad 256); the eyes 0.5 m
        from a wall (the CIE 117 observers of a box) 85.0 both times, Radiance 84.5, 84.8."""
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        normals = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
        key = (points.tobytes(), normals.tobytes())
        op = self._air_ops.get(key)
        if op is None:
            if len(self._air_ops) >= 8:
                self._air_ops.clear()
            op = self._air_ops[key] = self.air_gather(points, normals, own_visibility=True)
        return op(self.solve(luminaires, covering))

    def floor_patches(self, points):
        """(k,) patch under each point on the floor (its visibility row: what the point
        sees), the nearest face's patch where no floor lies under it."""
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        m = self.mesh
        floor = np.flatnonzero(m.face_normals[:, 2] > 0.99)
        idx, _ = locate_points(m.triangles[floor][..., :2], points[:, :2])
        patch = np.where(idx >= 0, self.rad.face_patch[floor[np.maximum(idx, 0)]], -1)
        miss = np.flatnonzero(idx < 0)
        if len(miss):
            patch[miss] = self.rad.face_patch[nearest_site(m.face_centroids, points[miss])]
        return patch

    def air_gather(self, points, normals, patch=None, own_visibility=False):
        """:class:`AirGather` of receivers in the air (``patch``: their visibility rows,
        default :meth:`floor_patches`; ``own_visibility``: each receiver's own, by
        segments to the patches' samples: for a few points)."""
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        normals = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
        return AirGather(self.rad, points, normals,
                         self.floor_patches(points) if patch is None else patch,
                         self.bvh if own_visibility else None, self.backend)

    def calibrate(self, key, luminaires, fast_lux):
        """Learn the indirect light per lumen of a catalogue entry (``key``; None: skip) from
        an exact solve of ``luminaires``, and the per-point correction ``exact / fast``.

        ``fast_lux``: the fast model's (maintained) lux of the same luminaires before this
        call, or None. Returns the exact maintained lux, total and direct.
        """
        total, direct = self.exact(luminaires)
        if key is not None:
            flux = sum(lum.flux_lm for lum in luminaires)
            self.indirect_per_lm[key] = (total - direct) / (self.mf * flux)
        if fast_lux is not None:
            with np.errstate(divide="ignore", invalid="ignore"):
                c = np.where(fast_lux > 1e-9, total / fast_lux * self.correction, 1.0)
            self.correction = np.clip(c, 0.2, 5.0)
        return total, direct

    def fast(self, response, flux, keys):
        """Fast maintained lux (k,) of luminaires with unit responses ``response`` (k, L),
        fluxes ``flux`` (L,) lm and catalogue keys (L,) (for their indirect light)."""
        e = response @ flux
        for key in set(keys):
            f = float(np.sum(flux[np.asarray(keys) == key]))
            e = e + self.indirect_per_lm[key] * f
        return self.mf * e * self.correction


class AirGather:
    """Interreflected illuminance at receivers in the air of a room, for any exitance.

    ``op(B)`` with ``B (P,)`` (lm/m^2, the model's patches) gives (k,) lux. Unlike a
    receiver on a surface (:meth:`.RadiosityModel.gather`, whose own plane gives nothing),
    a point in the air belongs to no plane: every patch counts (the floor below it too,
    for a vertical receiver); occlusion is the visibility row of the patch given per
    receiver (:meth:`RoomModel.floor_patches`: the floor patch under it, which sees the
    room as a point above it does, up to what lies between the floor and the point).

    With ``bvh`` (the room's occluders) the visibility is the receiver's own instead:
    of each patch, the area share of its radiosity samples with a clear segment from the
    receiver (a few eyes: UGR's observers; a floor patch at 1.2 m below an eye sees past
    a pillar what the eye does not, 4 % more light in tests/core/design/
    test_eye_background.py).

    Parameters
    ----------
    rad : RadiosityModel
    points, normals : (k, 3) float64, receivers (metres) and unit normals
    patch : (k,) int, each receiver's visibility row (its room); -1: none (receives 0)
    bvh : BVH or None, the room's occluders for the receivers' own visibility
    """

    def __init__(self, rad, points, normals, patch, bvh=None, backend="numpy"):
        from invrad_wb.core.forward.form_factors import form_factor_matrix
        pr = np.where(patch >= 0, rad.patch_room[np.maximum(patch, 0)], -1)
        self.n_points = len(points)
        self._blocks = []
        for room in rad.rooms:
            rows = np.flatnonzero((patch >= 0) & (pr == room.room))
            if len(rows) == 0 or room.patches.n == 0:
                continue
            own = bvh is not None and room.vis is not None
            mat = np.empty((len(rows), room.patches.n), np.float32)
            step = max(1, (64 << 20) // (8 * room.patches.n))
            for s in range(0, len(rows), step):
                r = rows[s:s + step]
                mat[s:s + len(r)] = form_factor_matrix(
                    points[r], normals[r], np.full(len(r), -1), room.patches,
                    point_patch=patch[r] - room.sl.start,
                    visibility=None if own else room.vis,
                    backend=rad.backend, centre=room.centre)
                if own:
                    # receivers at one point (a cylinder's directions) share its rays
                    at, back = np.unique(points[r], axis=0, return_inverse=True)
                    mat[s:s + len(r)] *= _seen_patches(room, at, bvh, backend)[
                        back.reshape(-1)]
            self._blocks.append((rows, room.sl, mat))

    def __call__(self, exitance):
        """(k,) lux for patch exitances (P,) lm/m^2."""
        e = np.zeros(self.n_points)
        b = np.asarray(exitance, dtype=np.float64)
        for rows, sl, mat in self._blocks:
            e[rows] = mat @ b[sl].astype(np.float32)
        return e


def _seen_patches(room, points, bvh, backend):
    """(k, P_room) area share of each patch's radiosity samples (moved ``RAY_EPS_M`` off
    their patch, as the patch-to-patch visibility's points) that each point sees."""
    par = room.sample_parent
    q = room.sample_point + C.RAY_EPS_M * room.patches.normal[par]
    k, n = len(points), len(q)
    hid = segments_occluded(bvh, np.repeat(points, n, axis=0), np.tile(q, (k, 1)), backend)
    seen = (~hid).reshape(k, n) * room.sample_weight
    out = np.zeros((k, room.patches.n))
    for i in range(k):
        out[i] = np.bincount(par, weights=seen[i], minlength=room.patches.n)
    return out.astype(np.float32)


def luminaires_of(positions, normals, fluxes, entries, entry_index, room, photometry=None,
                  axes=None):
    """Luminaire objects of a layout (the catalogue entry's name kept in ``extra``, its
    intensity distribution from ``photometry``: entry name -> Photometry; an entry turned
    'along' or 'across' gets its C0 along the room's longer or shorter plan axis of
    ``axes``, :func:`entry_c0`)."""
    photometry = photometry or {}
    out = []
    for p, n, f, k in zip(positions, normals, fluxes, entry_index):
        e = entries[k]
        extra = {"type": e.name}
        if e.orientation is not None:
            extra["orientation"] = e.orientation
        out.append(Luminaire(p, n, float(f), e.radius_m, room=room, extra=extra,
                             photometry=photometry.get(e.name), c0=entry_c0(e, axes)))
    return out


def entry_c0(entry, axes):
    """World C0 direction (3,) of an entry turned 'along' / 'across' the room: ``axes``
    is ((s, t) plan unit axes (2, 2), size (2,)); None for an entry not turned."""
    if entry.orientation is None or axes is None:
        return None
    ax, size = axes
    long_i = 0 if size[0] >= size[1] else 1
    i = long_i if entry.orientation == "along" else 1 - long_i
    return np.array([ax[i][0], ax[i][1], 0.0])


#: two C planes whose intensities differ by less than this (relative) count as the same:
#: a luminaire so symmetric is not turned
SYMMETRY_TOL = 0.02


def turned_entries(entries, photometry):
    """The catalogue as the search tries it: an entry whose photometry differs between its
    C0 and C90 planes becomes two, C0 laid along the room and across it (EN 12464-1
    designers try both: a batwing panel turned 90 degrees lights a room differently)."""
    out = []
    for e in entries:
        ph = photometry.get(e.name) if photometry else None
        if ph is not None and not _rotationally_symmetric(ph):
            out += [replace(e, orientation="along"), replace(e, orientation="across")]
        else:
            out.append(e)
    return out


def _rotationally_symmetric(ph):
    """Whether a photometry is (nearly) the same in its C0 and C90 planes."""
    t = ph.table
    a, b = t[0], t[90]
    return bool(np.max(np.abs(a - b)) <= SYMMETRY_TOL * max(float(t.max()), 1e-12))
