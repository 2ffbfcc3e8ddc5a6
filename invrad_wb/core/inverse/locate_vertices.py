"""The last refit on every target vertex of a finely meshed room, streamed in chunks.

A camera-derived or dense luxmeter map has hundreds of thousands to millions of target
vertices a room. Each is a measurement of its own: the Cramer-Rao bound of the luminaires'
positions falls as 1 / sqrt(vertices) (bench/bench_count.py: 5 % noise per vertex, twelve
4000 lm downlights with free fluxes, 5.8 cm at 7800 vertices, 0.8 cm needs about 400 000).
The count search, selection and regroup keep to a bounded subset
(:data:`~invrad_wb.core.inverse.locate_problem.VERTEX_POINTS_MAX`); :class:`VertexProblem`
then refits their answer on every vertex:

* the Levenberg-Marquardt normal equations ``J^T W J`` and ``J^T W r`` are accumulated over
  chunks of :data:`CHUNK_POINTS` vertices (no (vertices, parameters) Jacobian, no
  (luminaires, vertices) light array is ever held): memory is bounded by the chunk, plus
  about 80 bytes per vertex for the vertices themselves;
* the direct light is exact at every vertex (the refinement's own model, per chunk);
* the interreflected light of each luminaire is the subset problem's radiosity gather
  (exact at the subset's vertices) interpolated to every vertex
  (:class:`IndirectInterpolator`, locally linear on each plane): indirect light is smooth,
  and gathering the radiosity solution at a million vertices costs a form factor per
  vertex and patch at every refresh; so is its position gradient where the subset problem
  has one (:attr:`~invrad_wb.core.inverse.refine.RefineProblem.indirect_gradient`, as in
  locate's last refit: the interreflection then follows each luminaire's moves, and the
  refit's minimum is the likelihood's).

The same steps, cost and stopping rules as :meth:`RefineProblem.levenberg_marquardt`
(:func:`~invrad_wb.core.inverse.optim.levenberg_marquardt` with Marquardt damping of the
IRLS-weighted normal equations): on the same points, with the interpolation the identity,
the chunked refit equals the unchunked one up to the order of summation
(tests/core/inverse/test_locate_vertices.py).
"""
import numpy as np

from invrad_wb.core.inverse import optim
from invrad_wb.core.inverse.refine import RefineProblem
from invrad_wb.core.inverse.tiedparams import tied_fit

#: vertices per chunk of the streamed refit: the largest arrays of a chunk are the
#: refinement's (luminaires, chunk) light planes and the (chunk, parameters) Jacobian,
#: about 1.5 kB per vertex at 20 luminaires with free fluxes: 75 MB
CHUNK_POINTS = 50_000

#: at most this many target vertices in the streamed refit (a random subset beyond it):
#: the vertices, their chunks' precomputed arrays and the interpolation weights take about
#: 250 bytes each, 1 GB at this many
VERTICES_MAX = 4_000_000

#: visibility masks a chunk keeps (rooms with occluders): a byte per vertex each, so 64 MB
#: per million vertices at most
VIS_CACHE_MASKS = 64

#: :class:`IndirectInterpolator`: neighbours of each vertex among the subset's points
INTERP_NEIGHBOURS = 8

#: :class:`IndirectInterpolator`: a fine point whose linear weights sum to more than this
#: in absolute value (far extrapolation from neighbours all on one side, a room's corner
#: with a sparse subset) takes their inverse-distance mean instead
EXTRAPOLATION_MAX = 10.0


class IndirectInterpolator:
    """Values known at ``coarse`` points of a scene's planes, taken to ``fine`` points.

    Each fine point gets the weighted least-squares plane (value = a + b u + c v, weights
    1 / (d^2 + h^2), ``h`` the distance of its nearest neighbour) through its
    :data:`INTERP_NEIGHBOURS` nearest coarse points on the same scene plane: exact for
    values linear along the plane, and at a coarse point itself (it is its own nearest
    neighbour at distance 0 and dominates). A plane with fewer than three coarse points
    takes their inverse-distance mean. Points of a plane with none get 0.

    ``apply(values, rows)`` -> the fine points' values (``rows``: a slice of them).
    Memory: INTERP_NEIGHBOURS x 8 bytes per fine point (int32 indices, float32 weights:
    the values interpolated are changes of a few per cent, 1e-7 of them is nothing).
    """

    def __init__(self, coarse_pos, coarse_plane, fine_pos, fine_plane,
                 neighbours=INTERP_NEIGHBOURS, identical=False):
        self.n_fine = len(fine_pos)
        self.identity = bool(identical)
        if self.identity:
            return
        from scipy.spatial import cKDTree
        k = int(neighbours)
        self.idx = np.zeros((self.n_fine, k), dtype=np.int32)
        self.w = np.zeros((self.n_fine, k), dtype=np.float32)
        for pl in np.unique(fine_plane):
            rows = np.flatnonzero(fine_plane == pl)
            cols = np.flatnonzero(coarse_plane == pl)
            if len(cols) == 0:
                continue
            kk = min(k, len(cols))
            tree = cKDTree(coarse_pos[cols])
            for s in range(0, len(rows), 200_000):
                r = rows[s:s + 200_000]
                d, j = tree.query(fine_pos[r], k=kk)
                d, j = d.reshape(len(r), kk), j.reshape(len(r), kk)
                self.idx[r, :kk] = cols[j]
                self.w[r, :kk] = self._weights(fine_pos[r], coarse_pos[cols[j]], d)

    @staticmethod
    def _weights(p, q, d):
        """(m, k) linear weights of the k neighbours ``q`` (m, k, 3) of points ``p``."""
        m, k = d.shape
        h2 = np.maximum(d[:, :1] ** 2, 1e-18)
        wd = 1.0 / (d * d + h2)
        idw = wd / wd.sum(axis=1, keepdims=True)
        if k < 3:
            return idw
        # local coordinates in the plane of the neighbours (their own principal axes)
        off = q - p[:, None, :]                                        # (m, k, 3)
        mean = off.mean(axis=1, keepdims=True)
        cov = np.einsum("mki,mkj->mij", off - mean, off - mean)
        _, vec = np.linalg.eigh(cov)                                   # ascending
        u = np.einsum("mki,mi->mk", off, vec[:, :, 2])
        v = np.einsum("mki,mi->mk", off, vec[:, :, 1])
        X = np.stack([np.ones_like(u), u, v], axis=2)                  # (m, k, 3)
        XtW = np.swapaxes(X * wd[..., None], 1, 2)                     # (m, 3, k)
        A = XtW @ X
        A[:, np.arange(3), np.arange(3)] += 1e-12 * np.maximum(
            np.einsum("mii->mi", A).max(axis=1, keepdims=True), 1e-300)
        # the value at p is the intercept a: weights = e0^T A^-1 X^T W
        try:
            sol = np.linalg.solve(A, XtW)                              # (m, 3, k)
        except np.linalg.LinAlgError:
            return idw
        lin = sol[:, 0, :]
        # degenerate neighbourhoods (collinear points, far extrapolation): the
        # inverse-distance mean
        bad = ~np.all(np.isfinite(lin), axis=1) | (np.abs(lin).sum(axis=1) > EXTRAPOLATION_MAX)
        lin[bad] = idw[bad]
        return lin

    def apply(self, values, rows=slice(None)):
        """``values`` (coarse,) or (coarse, c) -> the fine points' (m,) or (m, c)."""
        values = np.asarray(values, dtype=np.float64)
        if self.identity:
            return values[rows]
        if values.ndim == 2:
            return np.einsum("mk,mkc->mc", self.w[rows].astype(np.float64),
                             values[self.idx[rows]])
        return np.einsum("mk,mk->m", self.w[rows].astype(np.float64),
                         values[self.idx[rows]])


class VertexProblem:
    """A :class:`RefineProblem` on every target vertex of a room, in chunks.

    ``pts``: the vertices (:class:`~invrad_wb.core.inverse.sampling.VotingPoints`);
    ``base``: the room's refinement problem on a subset of them (its settings, allowed
    region, occluders, photometry, interreflection model and calibration are this one's;
    a luminaire's ``indirect`` stays at ``base``'s points and is interpolated here).
    ``base_plane``: the scene plane of each of ``base``'s points. ``identical``: ``base``'s
    points are ``pts`` themselves (no interpolation).

    Offers what the last refit and bench/bench_count.py use of a refinement problem:
    :meth:`cost`, :meth:`levenberg_marquardt`, :meth:`refresh_indirect`,
    :meth:`with_indirect`, :meth:`fisher`, ``target``, ``flux``, ``free_flux``.
    """

    _own_copies = RefineProblem._own_copies
    _packing = RefineProblem._packing
    with_indirect = RefineProblem.with_indirect
    _estimate_scale = RefineProblem._estimate_scale
    refresh_indirect = RefineProblem.refresh_indirect

    def __init__(self, pts, base, base_plane=None, chunk=CHUNK_POINTS, identical=False,
                 indirect_model=None):
        self.base = base
        self.pts = pts
        self.indirect_model = indirect_model
        self._exact = None
        self.flux = base.flux
        self.free_flux = base.free_flux
        self.free_aim = base.free_aim
        self.inside = base.inside
        self.robust_scale = base.robust_scale
        self.indirect_exact = base.indirect_exact
        self.indirect_estimate = base.indirect_estimate
        # a luminaire's interreflection gradient at base's points, interpolated here as
        # its value is (:meth:`_at`)
        self.indirect_gradient = getattr(base, "indirect_gradient", False)
        self.indirect_gradient_of = base.indirect_gradient_of
        self.stats = base.stats                # the interreflection calibration is shared
        self.separation_m = base.separation_m
        self.target = pts.lux
        pos = self.target[self.target > 0]
        self.eps_lux = max(0.5, 0.02 * float(np.median(pos))) if len(pos) else 1.0
        total = float(pts.area.sum())
        self.w_area = pts.area / total
        self.interp = IndirectInterpolator(base.positions, base_plane, pts.positions,
                                           pts.plane, identical=identical)
        self.chunks = []
        for s in range(0, len(pts), max(1, int(chunk))):
            sl = slice(s, min(s + int(chunk), len(pts)))
            sub = RefineProblem(positions=pts.positions[sl], normals=pts.normals[sl],
                                target=pts.lux[sl], flux=base.flux, area=pts.area[sl],
                                bvh=base.bvh, inside=base.inside,
                                occluded_fn=base.occluded_fn,
                                robust_scale=base.robust_scale, eps_lux=self.eps_lux,
                                indirect=self.interp.apply(base.indirect, sl),
                                free_flux=base.free_flux, photometry=base.photometry,
                                free_aim=base.free_aim)
            sub.w_area = self.w_area[sl]
            sub.separation_m = base.separation_m
            # visibility masks kept per chunk (a byte per vertex each): at most
            # VIS_CACHE_MASKS of them, not the 512 of a voting-point problem
            sub.VIS_CACHE_SIZE = VIS_CACHE_MASKS
            self.chunks.append((sl, sub))
        self.chunks[0][1]._sep_w = self._separation_weight()

    def __len__(self):
        return len(self.target)

    # ------------------------------------------------------------------ pieces
    def _separation_weight(self):
        """As :meth:`RefineProblem._separation_weight`: sqrt(0.01 x the cost without any
        luminaire), here on every vertex."""
        c = sum(sub.cost_of(sub.residuals([], [])[0]) for _sl, sub in self.chunks)
        return float(np.sqrt(0.01 * c))

    def separation(self, lights, with_jac=False):
        sub = self.chunks[0][1]
        sub.separation_m = self.separation_m
        return sub.separation(lights, with_jac)

    def separation_cost(self, lights):
        if len(lights) < 2:
            return 0.0
        r, _ = self.separation(lights)
        return float(np.sum(r * r))

    def exact_indirect(self, lights, *more):
        """Gather each luminaire's interreflected light exactly at every vertex (one pass
        of the radiosity model's form factors over the vertices, in chunks, for all of
        them at once) and keep it; from then on a luminaire's interreflection here is
        that exact value plus the interpolated change of its value at ``base``'s points
        (:meth:`_at`): the last refit moves luminaires by centimetres, and the change
        is smooth where the value itself is not (near the room's edges, measured:
        tests/core/inverse/test_locate_vertices.py). Needs ``indirect_model`` (the
        base problem's :class:`~invrad_wb.core.inverse.locate_problem._Indirect`); the
        lights keep their order in the refit that follows (the values are per index).
        Memory: 4 bytes per vertex and luminaire.

        ``more``: other arrangements gathered in the same pass, not kept: returned, one
        per arrangement (None where it has no interreflection to gather), for
        :meth:`use_exact`. The pass costs its form factors (0.36 ms a vertex for
        array16's room, bench/bench_count.py), hardly the number of luminaires: the
        count check on every vertex (locate_fit._RoomFit.count_on_every_vertex) had
        a pass of its own for its one other arrangement."""
        m = self.indirect_model
        groups = [lights, *more]
        if m is None or self.interp.identity or not lights:
            return [None] * len(more)
        ok = [bool(g) and all(L.indirect is not None for L in g) for g in groups]
        todo = [L for g, y in zip(groups, ok) if y for L in g]
        if not todo:
            return [None] * len(more)
        B = np.stack([m.exitance([L], self.flux) for L in todo], axis=1)        # (P, K)
        fine = gather_at(m.model, self.pts, B)                                  # (k, K)
        out, col = [], 0
        for g, y in zip(groups, ok):
            if not y:
                out.append(None)
                continue
            out.append([(np.array(L.indirect, dtype=np.float64), fine[:, col + i])
                        for i, L in enumerate(g)])
            col += len(g)
        if out[0] is not None:
            self._exact = out[0]
        return out[1:]

    def use_exact(self, values):
        """Keep ``values`` (one of :meth:`exact_indirect`'s returned arrangements) as the
        exact interreflection of the lights refitted next, in their order."""
        self._exact = values

    def _at(self, lights, sl):
        """Shallow copies of ``lights`` with their interreflection at chunk ``sl``."""
        out = []
        exact = self._exact if (self._exact is not None
                                and len(self._exact) == len(lights)) else None
        for i, L in enumerate(lights):
            q = object.__new__(type(L))
            q.__dict__.update(L.__dict__)
            if L.indirect is not None:
                if exact is None:
                    q.indirect = self.interp.apply(L.indirect, sl)
                else:
                    c0, f0 = exact[i]
                    q.indirect = f0[sl] + self.interp.apply(L.indirect - c0, sl)
                if L.indirect_grad is not None:
                    q.indirect_grad = self.interp.apply(L.indirect_grad, sl)
            out.append(q)
        return out

    def _vis(self, sub, lights):
        return [sub.visibility(L) for L in lights]

    # ------------------------------------------------------------------ model
    def residuals(self, lights):
        """(k,) log residuals on every vertex (no Jacobian: see :meth:`normal_equations`)."""
        r = np.empty(len(self.target))
        for sl, sub in self.chunks:
            r[sl] = sub.residuals(self._at(lights, sl), self._vis(sub, lights))[0]
        return r

    def cost_of(self, r):
        c = self.robust_scale
        return float(np.sum(self.w_area * c * c * (np.sqrt(1.0 + (r / c) ** 2) - 1.0)))

    def cost(self, lights, vis_list=None, extra=None):
        if extra is not None:
            raise ValueError("VertexProblem.cost: no fixed light")
        return self.cost_of(self.residuals(lights)) + self.separation_cost(lights)

    def normal_equations(self, lights, vis=None, weights=True):
        """(r (k,), A = J^T W J (n, n), g = J^T W r (n,)) over every vertex, chunk by
        chunk; ``W`` the IRLS weights of the pseudo-Huber cost (w_area / sqrt(1 +
        (r / c)^2)), or with ``weights=False`` the identity on the lit vertices (the
        Fisher information of the log residuals, :meth:`fisher`). ``vis``: per chunk the
        luminaires' visibility (computed where None)."""
        n = sum(L.n_params() for L in lights)
        A, g = np.zeros((n, n)), np.zeros(n)
        r = np.empty(len(self.target))
        c = self.robust_scale
        for ci, (sl, sub) in enumerate(self.chunks):
            v = self._vis(sub, lights) if vis is None else vis[ci]
            rc, J = sub.residuals(self._at(lights, sl), v, True)
            r[sl] = rc
            if weights:
                w = sub.w_area / np.sqrt(1.0 + (rc / c) ** 2)
            else:
                w = (sub.target > 0).astype(np.float64)
            JtW = (J * w[:, None]).T
            A += JtW @ J
            g += JtW @ rc
        return r, A, g

    def fisher(self, lights):
        """The Fisher information J^T J of the log residuals over the lit vertices at
        ``lights`` (as :func:`~invrad_wb.core.inverse.fitcheck.position_sd` forms it)
        and the lights' own copies (their parameters)."""
        lights = self._own_copies(lights)
        return self.normal_equations(lights, weights=False)[1], lights

    # ------------------------------------------------------------------ optimiser
    def levenberg_marquardt(self, lights, iterations=25, tol=1e-7, fixed=None):
        """:meth:`RefineProblem.levenberg_marquardt` on every vertex: the same trial steps
        (Marquardt damping of the IRLS-weighted normal equations, the separation term as
        quadratic rows), acceptance, projection into the allowed region, visibility
        refresh (a luminaire moved more than 2 cm) and stopping rules; the normal
        equations summed over chunks. Returns (lights, cost)."""
        if fixed is not None:
            raise ValueError("VertexProblem.levenberg_marquardt: no fixed light")
        lights = self._own_copies(lights)
        if not lights:
            return lights, self.cost([])
        x0, unpack = self._packing(lights)
        k, n = len(self.target), len(x0)
        pairs = len(lights) * (len(lights) - 1) // 2
        vis = [self._vis(sub, lights) for _sl, sub in self.chunks]
        vis_at = [L.position.copy() for L in lights]

        def fun(x, _idx, jac):
            new = unpack(x[0])
            if jac:
                for i, L in enumerate(new):
                    if np.linalg.norm(L.position - vis_at[i]) > 0.02:
                        for ci, (_sl, sub) in enumerate(self.chunks):
                            vis[ci][i] = sub.visibility(L)
                        vis_at[i] = L.position.copy()
            if jac:
                r, A, g = self.normal_equations(new, vis)
            else:
                r = np.empty(k)
                for ci, (sl, sub) in enumerate(self.chunks):
                    r[sl] = sub.residuals(self._at(new, sl), vis[ci])[0]
            if pairs:
                rp, Jp = self.separation(new, jac)
                r = np.concatenate([r, rp, np.zeros(pairs - len(rp))])
                if jac and len(rp):
                    A += Jp.T @ Jp
                    g += Jp.T @ rp
            if not jac:
                return r[None]
            return r[None], (A[None], g[None])

        def cost(r):
            return np.array([self.cost_of(r[0, :k]) + float(r[0, k:] @ r[0, k:])])

        def step(Ag, _r, lam):
            A, g = Ag
            A = A.copy()
            D = np.maximum(np.einsum("nii->ni", A), 1e-12) * lam[:, None]
            diag = np.einsum("nii->ni", A)
            diag += D
            dx, ok = optim._solve(A, g)
            return -dx, ok

        def project(x_old, x_new, _idx):
            moved = [self.inside(M) for M in unpack(x_new[0])]
            if any(M is None for M in moved):
                moved = [L if M is None else M for L, M in zip(unpack(x_old[0]), moved)]
            return np.concatenate([L.params() for L in moved])[None]
        project = None if self.inside is None else project
        if self.free_flux:              # luminaires of one kind share a flux (tiedparams)
            x0, step, project = tied_fit(lights, x0, step, project, normal=True)

        res = optim.levenberg_marquardt(
            fun, x0[None], cost=cost, step=step, project=project, max_iter=None,
            max_steps=iterations, max_tries=8, ftol=tol, xtol=1e-5, lam_up=10.0,
            lam_min=1e-9, lam_max=np.inf)
        assert res.x.shape[1] == n
        return unpack(res.x[0]), float(res.cost[0])


def gather_at(model, pts, B, chunk=20_000):
    """(k, L) float32 interreflected lux at the points ``pts`` (their positions, normals
    and faces' patches, as :class:`~invrad_wb.core.inverse.locate_problem._Indirect`
    gathers) for the exitances ``B`` (P, L): the model's form factors row chunk by row
    chunk (never the (k, P) matrix)."""
    B = np.asarray(B, dtype=np.float64).reshape(model.n_patches, -1)
    out = np.zeros((len(pts), B.shape[1]), dtype=np.float32)
    patch = model.face_patch[pts.face]
    room_of = np.where(patch >= 0, model.patch_room[np.maximum(patch, 0)], -1)
    for room in model.rooms:
        rows = np.flatnonzero((patch >= 0) & (room_of == room.room))
        for s in range(0, len(rows), chunk):
            r = rows[s:s + chunk]
            F = model._form_factors(room, pts.positions[r], pts.normals[r],
                                    patch[r] - room.sl.start)
            out[r] = F @ B[room.sl]
    return out


def position_sd(prob, lights, sigma):
    """:func:`~invrad_wb.core.inverse.fitcheck.position_sd` (the Cramer-Rao bound, the
    noise ``sigma`` given) of a :class:`VertexProblem`, its Fisher information summed
    over chunks. Returns ``(pos_sd (K,), flux_sd (K,) or None)``."""
    if not lights:
        return np.zeros(0), None
    from invrad_wb.core.inverse.fitcheck import sd_of
    F, lights = prob.fisher(lights)
    return sd_of(np.linalg.pinv(F) * sigma ** 2, lights)
