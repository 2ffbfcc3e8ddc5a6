"""Interreflected light: a radiosity solve per room on patches, gathered at any receiver.

Method
------
* **Rooms are independent**: patches only exchange light with patches of the same room id.
* **Patches**: each plane's triangles are clustered by a grid in the plane's (u, v) basis
  (triangle centroids, :meth:`Plane.to_plane_coords`), cell about ``patch_size`` metres
  (default per room: about ``constants.RADIOSITY_TARGET_PATCHES`` patches, never smaller
  than ``RADIOSITY_MIN_PATCH_M`` nor than the mesh's triangles). The cell count per plane is
  rounded so the cells tile the plane evenly. A patch has its area, its plane's normal, an
  area-weighted reflectance, an area centroid, a representative point *on* the surface (the
  centroid of its triangle nearest to the area centroid) and a radius (centroid to its
  farthest triangle corner). Virtual faces (work planes) become patches that receive but
  never reflect (reflectance 0, so they emit nothing and their form factors are skipped).
* **Point-to-patch form factor** ``F(p -> j)`` for a receiver point ``p`` with normal ``m``:
  near a patch (``|p - c_j| < RADIOSITY_NEAR_FACTOR * radius_j``) the exact
  differential-area-to-polygon formula (Lambert / Nusselt contour integral)
  ``F = -1/(2 pi) sum_edges gamma_e m . unit(R_e x R_e+1)`` summed over the patch's
  triangles (counter-clockwise seen from their front, hence the sign), each clipped at the
  receiver's tangent plane; beyond ``(RADIOSITY_NEAR_FACTOR + RADIOSITY_NEAR_BLEND) *
  radius_j`` the point approximation ``A_j cos_i cos_j / (pi r^2)`` to the patch centroid;
  in between the two are blended linearly in ``r^2``, so the form factor is continuous in
  the receiver position (no seams in the light; float32 and float64 agree everywhere).
  Patches on the receiver's own plane give 0, and so do patches whose plane the receiver
  lies behind. A receiver within ``RAY_EPS_M`` of a patch's plane (a point on a room edge,
  which would lie on the polygon's contour) is moved ``RAY_EPS_M`` in front of it for that
  patch; scene vertices are first stepped ``2 RAY_EPS_M`` into their own faces
  (:meth:`RadiosityModel.vertex_receivers`), so that room corners get the limit from inside.
* **Visibility** ``V(i, j)`` between patches: one segment per unordered pair of patches
  facing each other (both cosines > 0), between points next to their representative points
  (:attr:`PatchSet.ray_point`), each moved ``RAY_EPS_M`` off its surface; other pairs count
  as visible (their form factor is 0 or a near-field sliver). Rays are tested against the
  faces that can block anything in the room (:meth:`RadiosityModel._blocker_faces`:
  pillars, partitions, re-entrant walls; none in a convex room), which gives the scene
  BVH's answer at a fraction of the cost. Receivers inherit their patch's row,
  ``V(point_patch, j)``: gathering casts no new rays.
* **Patch-to-patch form factors** ``F_ij``: the area-weighted mean of ``F(s -> j) V(i, j)``
  over ``q x q`` sub-patch sample points ``s`` of patch ``i`` (``q =
  RADIOSITY_RECEIVER_SUBDIV``; each sample is the representative point of a sub-cell of the
  patch's grid cell). With ``q = 1`` this is the form factor from the representative point.
  With OpenCL the samples' sum is taken on the device (:func:`patch_form_factors`): the host
  receives the P x P matrix, not q^2 P rows.
* **Solve** ``B = rho (E + F B)`` per room (``B`` patch exitance, lm/m^2; ``E`` mean direct
  illuminance on the patch, lux), for one or many right-hand sides at once: directly, by
  the LU factors of ``I - rho F`` made on the room's first solve and kept (rooms of at most
  ``RADIOSITY_DIRECT_MAX_PATCHES`` patches, with the model's own reflectances); otherwise
  by Jacobi iteration to a relative change below ``RADIOSITY_TOL`` (at most
  ``RADIOSITY_MAX_ITER`` sweeps).
* **Gather**: the interreflected illuminance at receivers is
  ``E_ind(p) = sum_j F(p -> j) V(patch(p), j) B_j``, with the same near/far form factor.

Costs and reuse
---------------
Everything that depends on geometry only is computed once per model (and
:meth:`RadiosityModel.for_scene` caches models on the scene): patches (O(m log m)),
visibility (at most P^2/2 rays per room, only facing pairs, none in convex rooms), the
patch matrix (``q^2 P`` receivers x ``P`` patches; memory ``P^2`` float64) and, on first use
of :meth:`RadiosityModel.indirect_at_vertices`, the vertex gather matrix (``n_room x
P_room`` float32 per room, ``4 n P`` bytes; above ``RADIOSITY_GATHER_MAX_MB`` it is not
stored and the form factors are recomputed at each application instead). After that,
:meth:`solve` costs two O(P^2) triangular solves once the room's LU factors (O(P^3), made on
its first solve) are there (O(P^2) per Jacobi sweep, about ``log(tol) / log(rho_max)``
sweeps, where they do not apply) and a gather one (k x P) matrix product: cheap enough to
call many times (joint refinement).

Measured on the 2-core PoCL machine, a 6 x 4 x 3 m room meshed at 8 cm (17658 vertices,
1180 patches): model 0.25-0.5 s (OpenCL) / 1-1.4 s (numpy), vertex gather matrix 0.25 s /
3.5 s, then solve ~10-20 ms by Jacobi (16 sweeps at rho = 0.5), under 1 ms with the LU
factors (0.06 s once), and gather ~5 ms per call. With a
floor-to-ceiling pillar (594k rays against 1.5k blocker triangles): model 0.4-0.55 s /
2.6 s.

Backends: ``opencl`` computes the form factors with ``kernels/radiosity.cl`` (float32,
``float16``/``float8`` vectors) and the visibility with ``kernels/occlusion.cl``; ``numpy``
is the float64 twin (vectorised, chunked to bounded memory) and needs no OpenCL.
"""
import time
import warnings

import numpy as np

from invrad_wb import constants as C
from invrad_wb.errors import SettingsError
from invrad_wb.core.geometry.bvh import BVH
from invrad_wb.core.accel.device import check_backend, get_env  # noqa: F401 - R.get_env
from invrad_wb.core.accel.registry import implementation
# the parts of the method, each in its module (their names stay importable from here)
from invrad_wb.core.forward.patches import (  # noqa: F401
    PatchSet, _cluster_stats, _grid_cells, default_patch_size)
from invrad_wb.core.forward.form_factors import (  # noqa: F401
    _form_factors_numpy, _pair_form_factors_numpy, form_factor_matrix, patch_form_factors,
    point_triangle_form_factor)
from invrad_wb.core.forward.visibility import patch_visibility  # noqa: F401
from invrad_wb.core.forward.nearfield import _near_field_correction


# ---------------------------------------------------------------------------- visibility


# ---------------------------------------------------------------------------- the model

_LAPACK = None


def _lapack():
    """``(lu_factor, lu_solve, one_thread)``: scipy's LU (loaded on the first direct
    solve, not with this module; its LAPACK module alone where scipy.linalg is not imported
    yet, :func:`~invrad_wb.core.accel.lapack.lu_functions`: the same numbers) and a context
    keeping BLAS on one thread while it runs, made once scipy's BLAS is loaded
    (:func:`~invrad_wb.core.accel.workers.blas_one_thread_limiter`): the factors, and so
    every result after them, do not depend on the machine's cores nor on where the room
    runs."""
    global _LAPACK
    if _LAPACK is None:
        # built whole, then bound in one step: two threads' first solves at once (the
        # GUI runs a design in a worker thread) each see None or the whole tuple
        from invrad_wb.core.accel.lapack import lu_functions
        from invrad_wb.core.accel.workers import blas_one_thread_limiter
        lu_factor, lu_solve = lu_functions()
        _LAPACK = (lu_factor, lu_solve, blas_one_thread_limiter())
    return _LAPACK


class _Room:
    """Geometry-only data of one room (patch slice, patches, visibility, patch matrix)."""

    def __init__(self, room, sl, patches, cell):
        self.room = room
        self.sl = sl
        self.patches = patches
        self.cell = cell
        self.centre = patches.centroid.mean(axis=0) if patches.n else np.zeros(3)
        self.vis = None
        self.F = None
        self.lu = None          # LU factors of I - rho F (RadiosityModel._factors)
        self.support = None     # hull vertices of the patches' direct-light samples
        self.blockers = np.zeros(0, dtype=np.int64)


class GatherOperator:
    """Interreflected illuminance at fixed receivers for any patch exitance.

    ``op(B)`` with ``B (P,)`` or ``(P, L)`` (lm/m^2, all patches of the model) returns
    ``(k,)`` or ``(k, L)`` float64 lux: ``E_ind = sum_j F(p -> j) V(patch(p), j) B_j``.
    The per-room blocks of the (k x P) matrix are stored as float32 unless one exceeds
    ``constants.RADIOSITY_GATHER_MAX_MB``; then that block is recomputed in row chunks at
    each call (bounded memory, slower).

    Attributes
    ----------
    n_points : int
    n_patches : int
    """

    def __init__(self, model, points, normals, point_patch):
        self.model = model
        self.n_points = len(points)
        self.n_patches = model.n_patches
        self._blocks = []
        pr = np.where(point_patch >= 0, model.patch_room[np.maximum(point_patch, 0)], -1)
        for room in model.rooms:
            rows = np.flatnonzero((point_patch >= 0) & (pr == room.room))
            if len(rows) == 0:
                continue
            args = (points[rows], normals[rows], point_patch[rows] - room.sl.start)
            nbytes = 4 * len(rows) * room.patches.n
            if nbytes <= C.RADIOSITY_GATHER_MAX_MB << 20:
                mat = model._stored_form_factors(room, args)
                if mat is None:
                    mat = np.empty((len(rows), room.patches.n), np.float32)
                    for s, blk in self._chunks(room, args):
                        mat[s:s + len(blk)] = blk
                self._blocks.append((rows, room, mat, None))
            else:
                self._blocks.append((rows, room, None, args))

    def _chunks(self, room, args):
        """Yield (first row, form-factor rows) of a block in chunks of bounded memory."""
        pts, nrm, pp = args
        step = max(1, (C.RADIOSITY_CL_CHUNK_MB << 20) // (8 * max(1, room.patches.n)))
        for s in range(0, len(pts), step):
            yield s, self.model._form_factors(room, pts[s:s + step], nrm[s:s + step],
                                              pp[s:s + step])

    def __call__(self, exitance):
        b = np.asarray(exitance, dtype=np.float64)
        if b.shape[0] != self.n_patches:
            raise ValueError(f"exitance has {b.shape[0]} rows for {self.n_patches} patches")
        out = np.zeros((self.n_points,) + b.shape[1:])
        for rows, room, mat, args in self._blocks:
            br = b[room.sl]
            if mat is not None:
                out[rows] = mat @ br.astype(np.float32)
                continue
            for s, blk in self._chunks(room, args):
                out[rows[s:s + len(blk)]] = blk @ br
        return out

    def matrix(self):
        """The dense (k, P) float64 gather matrix (zero between rooms)."""
        out = np.zeros((self.n_points, self.n_patches))
        for rows, room, mat, args in self._blocks:
            if mat is None:
                mat = self.model._form_factors(room, *args)
            out[np.ix_(rows, np.arange(room.sl.start, room.sl.stop))] = mat
        return out


class RadiosityModel:
    """Luminaire-independent radiosity model of a scene (see the module docstring).

    Parameters
    ----------
    scene : Scene
    backend : {'opencl', 'numpy', 'auto'}
    patch_size : float, optional
        Patch edge in metres for all rooms (default: chosen per room).
    occlusion : bool
        Test patch-to-patch visibility through the scene; False: everything visible.

    Attributes
    ----------
    n_patches : int
        P, all rooms together (patches of a room are contiguous).
    face_patch : (m,) int64
        Patch of each face.
    vertex_patch : (n,) int64
        Patch of each vertex (-1 for vertices of no face).
    patch_room, patch_plane : (P,) int64
    patch_area : (P,) float64, m^2
    patch_normal, patch_point, patch_centroid : (P, 3) float64
    patch_reflectance : (P,) float64 (0 for virtual patches)
    room_patch_size : dict room id -> patch edge used (metres)
    timings : dict of seconds: 'patches', 'visibility', 'form_factors', 'vertex_gather'
    n_rays : int
        Visibility segments tested.
    """

    def __init__(self, scene, backend="opencl", patch_size=None, occlusion=True):
        self.backend = check_backend(backend)
        self.scene = scene
        self.occlusion = bool(occlusion)
        if patch_size is not None:
            try:
                patch_size = float(patch_size)
            except (TypeError, ValueError):
                raise SettingsError(f"patch_size must be a number of metres, got"
                                    f" {patch_size!r}")
            if not np.isfinite(patch_size) or patch_size <= 0:
                raise SettingsError(f"patch_size is {patch_size} m: must be > 0")
        self.patch_size = patch_size
        self.timings = {}
        t0 = time.perf_counter()
        self._build_patches(patch_size)
        t1 = time.perf_counter()
        self.timings["patches"] = t1 - t0
        self.n_rays = 0
        if self.occlusion:
            for room in self.rooms:
                room.blockers = self._blocker_faces(room)
                if len(room.blockers) == 0:
                    continue  # a convex room: no segment inside it can be blocked, V = 1
                bvh = BVH(scene.triangles[room.blockers])
                room.vis, nr = patch_visibility(room.patches, bvh, self.backend)
                self.n_rays += nr
        t2 = time.perf_counter()
        self.timings["visibility"] = t2 - t1
        for room in self.rooms:
            room.F = self._patch_matrix(room)
        self.timings["form_factors"] = time.perf_counter() - t2
        self._vertex_op = None

    #: the scene attribute that holds its models (a per-process cache: a pickled scene
    #: leaves it out, :attr:`invrad_wb.core.model.scene.Scene._PROCESS_CACHES`)
    CACHE = "_radiosity"

    @staticmethod
    def _key(backend, patch_size, occlusion):
        try:
            size_key = None if patch_size is None else float(patch_size)
        except (TypeError, ValueError):
            size_key = repr(patch_size)  # refused by the constructor
        return (check_backend(backend), size_key, bool(occlusion))

    @classmethod
    def for_scene(cls, scene, backend="opencl", patch_size=None, occlusion=True):
        """The model of ``scene`` for these settings, built once and cached on the scene."""
        cache = scene.__dict__.setdefault(cls.CACHE, {})
        key = cls._key(backend, patch_size, occlusion)
        model = cache.get(key)
        if model is None:
            model = cls(scene, backend=backend, patch_size=patch_size, occlusion=occlusion)
            cache[key] = model
        return model

    @classmethod
    def cached(cls, scene, backend="opencl", patch_size=None, occlusion=True):
        """The model :meth:`for_scene` built for these settings, or None (nothing built)."""
        return getattr(scene, cls.CACHE, {}).get(cls._key(backend, patch_size, occlusion))

    @classmethod
    def forget(cls, scene):
        """Drop the scene's models (their memory; the next :meth:`for_scene` rebuilds)."""
        scene.__dict__.pop(cls.CACHE, None)

    # ------------------------------------------------------------------ construction
    def _build_patches(self, patch_size):
        sc = self.scene
        m = len(sc.faces)
        q = max(1, int(C.RADIOSITY_RECEIVER_SUBDIV))
        face_patch = np.full(m, -1, dtype=np.int64)
        face_sub = np.full(m, -1, dtype=np.int64)
        planes = sc.planes
        cent = sc.face_centroids
        self.rooms = []
        self.room_patch_size = {}
        p_plane, p_normal = [], []
        n_total, s_total = 0, 0
        for r in sc.rooms:
            r = int(r)
            faces = np.flatnonzero(sc.face_room == r)
            cell = patch_size if patch_size is not None else default_patch_size(sc, faces)
            self.room_patch_size[r] = cell
            start = n_total
            for pl in planes:
                if pl.room != r:
                    continue
                key, subkey = _grid_cells(pl, cent[pl.faces], cell, q)
                uk, inv = np.unique(key, return_inverse=True)
                us, sinv = np.unique(subkey, return_inverse=True)
                face_patch[pl.faces] = n_total + inv.reshape(-1)
                face_sub[pl.faces] = s_total + sinv.reshape(-1)
                p_plane.append(np.full(len(uk), pl.index))
                p_normal.append(np.repeat(pl.normal[None], len(uk), 0))
                n_total += len(uk)
                s_total += len(us)
            self.rooms.append((r, slice(start, n_total), faces, cell))
        self.n_patches = n_total
        self.face_patch = face_patch
        self.patch_plane = np.concatenate(p_plane) if p_plane else np.zeros(0, np.int64)
        self.patch_normal = np.concatenate(p_normal) if p_normal else np.zeros((0, 3))
        a = sc.face_areas
        virt = sc.face_virtual
        self.patch_area = np.bincount(face_patch, weights=a, minlength=n_total)
        rho = np.where(virt, 0.0, sc.face_reflectance)
        self.patch_reflectance = (np.bincount(face_patch, weights=a * rho, minlength=n_total)
                                  / np.maximum(self.patch_area, 1e-300))
        self.patch_virtual = np.bincount(face_patch, weights=(~virt).astype(float),
                                         minlength=n_total) == 0
        self.patch_reflectance[self.patch_virtual] = 0.0
        # the reflectances the direct solve's factors are for (a caller may change
        # patch_reflectance for a while: then solve iterates)
        self._own_reflectance = self.patch_reflectance.copy()
        self.patch_room = np.zeros(n_total, dtype=np.int64)
        self.patch_point = np.zeros((n_total, 3))
        self.patch_centroid = np.zeros((n_total, 3))
        rooms = []
        for r, sl, faces, cell in self.rooms:
            self.patch_room[sl] = r
            fp = face_patch[faces] - sl.start
            tri = sc.vertices[sc.faces[faces]]     # this room's (not every face's) copy
            ps = PatchSet(tri, fp, self.patch_plane[sl], self.patch_normal[sl],
                          reflectance=self.patch_reflectance[sl],
                          emits=~self.patch_virtual[sl])
            self.patch_point[sl] = ps.point
            self.patch_centroid[sl] = ps.centroid
            room = _Room(r, sl, ps, cell)
            # receiver samples of the patch matrix: representative points of sub-cells
            fs = face_sub[faces]
            us, sinv = np.unique(fs, return_inverse=True)
            sinv = sinv.reshape(-1)
            s_area, _, s_point, _, s_rep = _cluster_stats(tri, sinv, len(us))
            s_parent = fp[s_rep]
            order = np.argsort(s_parent, kind="stable")
            room.sample_point = s_point[order]
            room.sample_parent = s_parent[order]
            room.sample_weight = (s_area / ps.area[s_parent])[order]
            rooms.append(room)
        self.rooms = rooms
        vp = np.full(len(sc.vertices), -1, dtype=np.int64)
        vp[sc.faces.reshape(-1)] = np.repeat(face_patch, 3)
        self.vertex_patch = vp

    def _blocker_faces(self, room):
        """Faces that can block a segment between two points of the room: (k,) int64.

        The room's *hull planes* are its planes with all its (reflecting) vertices in
        front; the room lies in the convex region H they bound, and so does any segment
        between two of its points. A face can only cross such a segment if it reaches into
        H, i.e. if no hull plane has all its corners behind or on it. That excludes the
        room's own faces on hull planes (walls, floor and ceiling of a box) and the faces
        of rooms beyond them, and keeps pillars, partitions, re-entrant walls and anything
        else inside. A convex room has no blockers at all: its rays need no test. Testing
        against these faces only gives the same answer as the whole scene (rooms must not
        overlap), at a fraction of the cost. Virtual faces never block.
        """
        sc = self.scene
        real = ~sc.face_virtual
        own = (sc.face_room == room.room) & real
        if not own.any():
            return np.zeros(0, dtype=np.int64)
        pts = sc.vertices[np.unique(sc.faces[own])]
        tol = 2.0 * C.PLANE_OFFSET_TOL_M
        cand = np.flatnonzero(real)
        tri = sc.vertices[sc.faces[cand]]
        keep = np.ones(len(cand), dtype=bool)
        for pl in sc.planes:
            if pl.room != room.room or pl.is_virtual:
                continue
            if np.min(pl.signed_distance(pts)) < -tol:
                continue  # not a hull plane: the room reaches behind it
            keep &= np.max(tri @ pl.normal + pl.offset, axis=1) > tol
        return cand[keep]

    def vertex_receivers(self):
        """Receiver points for the scene's vertices: each moved 2 RAY_EPS_M into its faces.

        A vertex at a room corner lies on two other planes at once; stepping it into the
        fan of its faces (towards the mean of their centroids, within its own plane) makes
        its form factors the limit from inside the room.

        Returns
        -------
        points (n, 3) float64 metres, normals (n, 3) float64
        """
        sc = self.scene
        n = len(sc.vertices)
        csum = np.zeros((n, 3))
        corners = sc.faces.reshape(-1)
        cen = np.repeat(sc.face_centroids, 3, axis=0)
        for k in range(3):
            csum[:, k] = np.bincount(corners, weights=cen[:, k], minlength=n)
        cnt = np.bincount(corners, minlength=n)
        d = csum / np.maximum(cnt, 1)[:, None] - sc.vertices
        nrm = sc.vertex_normals
        d -= np.einsum("ij,ij->i", d, nrm)[:, None] * nrm
        length = np.linalg.norm(d, axis=1)
        step = np.where(length > 1e-12, 2.0 * C.RAY_EPS_M / np.maximum(length, 1e-300), 0.0)
        return sc.vertices + step[:, None] * d, nrm

    def _form_factors(self, room, points, normals, local_patch):
        """(k, P_room) form factors x visibility for receivers of one room."""
        ps = room.patches
        return form_factor_matrix(points, normals, ps.plane[local_patch], ps,
                                  point_patch=local_patch, visibility=room.vis,
                                  backend=self.backend, centre=room.centre)

    def _stored_form_factors(self, room, args):
        """(k, P_room) float32 form factors of a gather block, the kernel's output as it
        is read back (a view of its padded rows: the same numbers as
        :meth:`_form_factors`, without copying them into a second array); None on the
        numpy backend (its float64 rows are stored as float32 chunk by chunk)."""
        from invrad_wb.core.forward import form_factors as ff
        if implementation("form_factors", self.backend) is not ff._form_factors_opencl:
            return None
        pts, nrm, local = args
        ps = room.patches
        out = np.empty((len(pts), ff.padded_patches(ps.n)), np.float32)
        ff.form_factor_rows_opencl(pts, nrm, ps.plane[local], ps, local, room.vis,
                                   room.centre, out)
        return out[:, :ps.n]

    def _patch_matrix(self, room):
        """(P_room, P_room) float64 patch-to-patch form factors (sub-sample mean)."""
        ps = room.patches
        if ps.n == 0:
            return np.zeros((0, 0))
        par = room.sample_parent
        F = patch_form_factors(room.sample_point, ps.normal[par], ps, par,
                               room.sample_weight, room.vis, self.backend, room.centre)
        F[:, ~ps.emits] = 0.0
        return F

    # ------------------------------------------------------------------ light
    def patch_direct_from_vertices(self, vertex_lux):
        """Area-weighted mean direct illuminance of each patch.

        Parameters
        ----------
        vertex_lux : (n,) or (n, L) float64, lux at the scene's vertices (linear over faces)

        Returns
        -------
        (P,) or (P, L) float64, lux
        """
        v = np.asarray(vertex_lux, dtype=np.float64)
        n = len(self.scene.vertices)
        if v.shape[0] != n:
            raise ValueError(f"{v.shape[0]} vertex values for {n} vertices")
        face_val = v[self.scene.faces].mean(axis=1)
        w = self.scene.face_areas
        inv_area = 1.0 / np.maximum(self.patch_area, 1e-300)
        if face_val.ndim == 1:
            return np.bincount(self.face_patch, weights=w * face_val,
                               minlength=self.n_patches) * inv_area
        return np.stack([np.bincount(self.face_patch, weights=w * face_val[:, c],
                                     minlength=self.n_patches) * inv_area
                         for c in range(face_val.shape[1])], axis=1)

    def patch_direct(self, luminaires, bvh=None, occlusion=True, backend=None, progress=None):
        """Mean direct illuminance of each patch (P,) lux, from the luminaires themselves.

        Each patch's light is sampled at its representative point, except near a
        luminaire, where the light falls off as 1/r^2 within the patch: there the patch
        gets the luminaire's flux times the exact point-to-polygon form factor (the one the
        gather uses near a patch, blended to the point rule as there) over its area, scaled
        by what the sample says of the luminaire's distribution, emitter and shadow at the
        point (its direct light there over a Lambertian point emitter's). Measured for a
        2000 lm downlight 0.1 m from a wall of a 5 x 4 x 2.5 m box: patch means of vertex
        values put 1515 lm on the surfaces, representative points alone 2543 lm, this 2000.

        A luminaire with a ``room`` lights only the patches of that room (as the direct
        light of :func:`~invrad_wb.core.forward.render.render`). ``progress(fraction)``
        is told the share of (luminaire, patch) pairs done.
        """
        from invrad_wb.core.forward.direct import direct_illuminance, emitter_extent
        from invrad_wb.core.geometry.bvh import cull_occluders
        backend = self.backend if backend is None else backend
        occlusion = bool(occlusion) and bvh is not None
        pts, nrm = self.patch_points()
        out = np.zeros(self.n_patches)
        parts = []
        for room in self.rooms:
            lums = [L for L in luminaires if L.room is None or int(L.room) == room.room]
            if lums and room.patches.n:
                parts.append((room, lums))
        work = np.cumsum([0] + [r.patches.n * len(l) for r, l in parts], dtype=np.float64)
        work /= max(work[-1], 1.0)
        for k, (room, lums) in enumerate(parts):
            sl, ps = room.sl, room.patches
            lo, hi = work[k], work[k + 1]
            step = None if progress is None else (
                lambda f, lo=lo, hi=hi: progress(lo + (hi - lo) * 0.8 * f))
            p, n = pts[sl] + nrm[sl] * 1e-4, nrm[sl]
            # the occluders that can shadow these patches from these luminaires (None:
            # none can, a convex room); the same answers as the whole BVH. The patches'
            # hull is the same at every call: its vertices are kept (with them as the
            # receivers the culling gives the same triangles; the refinement's 20 calls
            # took the hull of 1200 points each)
            if occlusion and room.support is None:
                from invrad_wb.core.geometry.bvh import _support_points
                room.support = _support_points(p)
            room_bvh = (cull_occluders(bvh, emitter_extent(lums), room.support)
                        if occlusion else None)
            out[sl] = direct_illuminance(p, n, lums, bvh=room_bvh,
                                         occlusion=room_bvh is not None, backend=backend,
                                         progress=step)
            out[sl] += _near_field_correction(ps, p, n, lums, room_bvh,
                                              room_bvh is not None)
            if progress is not None:
                progress(hi)
        return out

    def patch_points(self):
        """Representative point (on the surface) and normal of every patch: (P, 3) each."""
        if getattr(self, "_patch_points", None) is None:
            pts = np.zeros((self.n_patches, 3))
            nrm = np.zeros((self.n_patches, 3))
            for room in self.rooms:
                pts[room.sl] = room.patches.point
                nrm[room.sl] = room.patches.normal
            self._patch_points = (pts, nrm)
        return self._patch_points

    def solve(self, patch_direct):
        """Patch exitance from reflection: ``B = rho (E + F B)`` per room.

        With the model's own reflectances (those it was built with) and a room of at most
        ``constants.RADIOSITY_DIRECT_MAX_PATCHES`` patches, the system ``(I - rho F) B =
        rho E`` is solved directly: its LU factors are computed on the room's first solve
        and kept (the matrix does not depend on the light), so each later solve costs two
        triangular solves. Otherwise (reflectances changed on the model, e.g. a design's
        luminous openings, or a larger room) by Jacobi iteration to a relative change
        below ``RADIOSITY_TOL`` (at most ``RADIOSITY_MAX_ITER`` sweeps).

        Measured on the 2-core machine (office example and l_room, 1180 and 1200
        patches, rho 0.3-0.8 and 0.6): factors 0.05-0.06 CPU s once, then 0.6 ms per
        solve instead of 11-16 ms (19-21 Jacobi sweeps); Jacobi was within 1e-5 of it.

        Parameters
        ----------
        patch_direct : (P,) or (P, L) float64, lux
            Mean direct illuminance per patch (L independent right-hand sides).

        Returns
        -------
        (P,) or (P, L) float64, lm/m^2. The number of Jacobi sweeps (0: direct solves
        only) is kept in ``self.last_iterations``.
        """
        e = np.asarray(patch_direct, dtype=np.float64)
        if e.shape[0] != self.n_patches:
            raise ValueError(f"{e.shape[0]} patch values for {self.n_patches} patches")
        out = np.zeros_like(e)
        self.last_iterations = 0
        for room in self.rooms:
            er = e[room.sl]
            rho = self.patch_reflectance[room.sl]
            lu = self._factors(room, rho)
            if e.ndim == 2:
                rho = rho[:, None]
            b = rho * er
            if not np.any(b):
                continue
            if lu is not None:
                _, lu_solve, one_thread = _lapack()
                with one_thread():
                    out[room.sl] = lu_solve(lu, b, check_finite=False)
                continue
            for it in range(1, C.RADIOSITY_MAX_ITER + 1):
                bn = rho * (er + room.F @ b)
                change = float(np.max(np.abs(bn - b)))
                b = bn
                if change <= C.RADIOSITY_TOL * float(np.max(np.abs(b))):
                    break
            else:
                warnings.warn(f"radiosity of room {room.room} did not converge in"
                              f" {C.RADIOSITY_MAX_ITER} iterations (relative change"
                              f" {change / max(float(np.max(np.abs(b))), 1e-300):.2g})",
                              RuntimeWarning)
            self.last_iterations = max(self.last_iterations, it)
            out[room.sl] = b
        return out

    def _factors(self, room, rho):
        """LU factors of a room's ``I - rho F`` (scipy's ``lu_factor``), made on first use;
        None where the direct solve does not apply (reflectances other than the model's
        own, more than ``RADIOSITY_DIRECT_MAX_PATCHES`` patches)."""
        if room.patches.n > C.RADIOSITY_DIRECT_MAX_PATCHES or room.patches.n == 0:
            return None
        if not np.array_equal(rho, self._own_reflectance[room.sl]):
            return None
        if room.lu is None:
            lu_factor, _, one_thread = _lapack()
            t = time.perf_counter()
            a = -rho[:, None] * room.F
            a[np.diag_indices_from(a)] += 1.0
            with one_thread():
                room.lu = lu_factor(a, overwrite_a=True, check_finite=False)
            self.timings["factors"] = self.timings.get("factors", 0.0) + (
                time.perf_counter() - t)
        return room.lu

    def gather(self, points, normals, point_patch):
        """Operator giving the interreflected illuminance at receivers for any exitance.

        Parameters
        ----------
        points : (k, 3) float64, metres
        normals : (k, 3) float64, unit receiver normals
        point_patch : (k,) int
            Patch each receiver lies on (its room, plane and visibility row); -1: none
            (receives 0).

        Returns
        -------
        GatherOperator
            ``op(B)`` -> (k,) lux for ``B (P,)``; ``op.matrix()`` -> dense (k, P). Building
            it computes the form factors once (k x P_room per room).
        """
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        normals = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
        point_patch = np.asarray(point_patch, dtype=np.int64).reshape(-1)
        if not len(points) == len(normals) == len(point_patch):
            raise ValueError("points, normals and point_patch must have the same length")
        if np.any(point_patch >= self.n_patches):
            raise ValueError(f"point_patch refers to patch {int(point_patch.max())} of"
                             f" {self.n_patches}")
        return GatherOperator(self, points, normals, point_patch)

    def vertex_gather(self):
        """The :class:`GatherOperator` of the scene's vertices (built once)."""
        if self._vertex_op is None:
            t = time.perf_counter()
            pts, nrm = self.vertex_receivers()
            self._vertex_op = self.gather(pts, nrm, self.vertex_patch)
            self.timings["vertex_gather"] = time.perf_counter() - t
        return self._vertex_op

    def indirect_at_vertices(self, vertex_direct):
        """Interreflected illuminance at the scene's vertices.

        Parameters
        ----------
        vertex_direct : (n,) or (n, L) float64, lux (direct illuminance at the vertices)

        Returns
        -------
        (n,) or (n, L) float64, lux
        """
        b = self.solve(self.patch_direct_from_vertices(vertex_direct))
        return self.vertex_gather()(b)

    def __repr__(self):
        return (f"RadiosityModel({self.n_patches} patches in {len(self.rooms)} room(s),"
                f" backend={self.backend!r}, occlusion={self.occlusion})")
