"""Aimed luminaires as unknowns (``locate --aim free``, issue 23).

The thesis' votes assume each luminaire faces along the normal of the surface it is on. An
adjustable spot (a ceiling gimbal aimed 15-60 degrees off vertical at a painting) votes for
nothing there: its light arrives from a direction the votes do not consider.

Global search from the lit footprint: a beam's light on a surface is brightest near where
its axis meets it, so every *hot spot* of the targets (a local maximum of the target
illuminance, taken at the lux-weighted centre of its bright neighbourhood) is a place some
luminaire may be aimed at. For every hot spot and every apex on a grid over the room's
mounting surfaces (the surface vote maps, :data:`APEX_STEP_M` apart) from which the hot spot
lies within the largest tilt, a luminaire at the apex aimed at the hot spot is scored
alone: the area-weighted squared error of linear illuminance with its light (its flux the
least-squares one when the fluxes are free; :meth:`_Scorer.cost_of` says why not the
refinement's log cost). The best apexes of each hot spot (distinct,
:data:`KEEP_PER_SPOT`) are polished by a pattern search over the apex and the axis' meeting
point (:func:`_polish`) and join the vote peaks (which become aimable too: a downlight is
an aimable luminaire whose fitted tilt is 0) as candidates, all ranked by that score; the joint refinement (:mod:`invrad_wb.core.inverse.refine`) then fits the aim
(two gnomonic coordinates, tilt at most ``max_tilt_deg``) with the position and the flux.

The scoring ignores occlusion (the refinement does not).
"""
import numpy as np

from invrad_wb.core.inverse.locate_count import CountSearch
from invrad_wb.core.inverse.refine import LOG_SCALE_LIMIT, Light
from invrad_wb.core.model.aiming import aimed_c0

#: apex grid spacing on the mounting surfaces (metres)
APEX_STEP_M = 0.3
#: radius (m) within which a hot spot is the brightest target point (same facing)
HOT_RADIUS_M = 0.4
#: at most this many hot spots per room (brightest relative to their surroundings first)
MAX_HOT_SPOTS = 24
#: apexes kept per hot spot, at least ``APEX_APART_M`` apart
KEEP_PER_SPOT = 2
APEX_APART_M = 0.6
#: luminaires scored per batch (memory: batch x points x 3 float64)
BATCH = 64


def hot_spots(positions, normals, lux, radius=HOT_RADIUS_M, most=MAX_HOT_SPOTS):
    """(h, 3) aim points and (h, 3) their normals: local maxima of the target illuminance
    over points facing the same way, each moved to the lux-weighted centre of the points
    around it brighter than half its peak; ranked by the peak over the median of its
    surroundings (a dim spot on a dark wall counts as much as a bright one)."""
    from scipy.spatial import cKDTree
    lit = np.flatnonzero(lux > 0)
    if not len(lit):
        return np.zeros((0, 3)), np.zeros((0, 3))
    P, Nn, E = positions[lit], normals[lit], lux[lit]
    # a spot counts where it is at least 1 % of the brightest target (noise on dark
    # surfaces, a few lux beside nothing, is not a beam)
    floor = 0.01 * float(E.max())
    tree = cKDTree(P)
    near = tree.query_ball_point(P, radius)
    wide = tree.query_ball_point(P, 2.5 * radius)
    spots = []
    for i, nb in enumerate(near):
        nb = np.asarray(nb)
        same = nb[Nn[nb] @ Nn[i] > 0.9]
        if E[i] < E[same].max() or E[i] < floor:
            continue
        wb = np.asarray(wide[i])
        wb = wb[Nn[wb] @ Nn[i] > 0.9]
        bright = wb[E[wb] > 0.5 * E[i]]
        w = E[bright] ** 2
        centre = (P[bright] * w[:, None]).sum(0) / w.sum()
        contrast = E[i] / max(float(np.median(E[wb])), floor)
        spots.append((contrast * np.sqrt(E[i]), centre, Nn[i]))
    spots.sort(key=lambda t: -t[0])
    spots = spots[:most]
    return (np.array([s[1] for s in spots]).reshape(-1, 3),
            np.array([s[2] for s in spots]).reshape(-1, 3))


def apex_grid(canvas, step=APEX_STEP_M):
    """Mounting positions: (n, 3) points, (n, 3) mount normals, (n,) map indices, on
    every surface vote map's allowed pixels, about ``step`` apart."""
    P, M, K = [], [], []
    for k, m in enumerate(canvas.maps):
        if m.kind != "surface":
            continue
        s = max(1, int(round(step / m.pixel)))
        centres = m.pixel_centres()
        mask = m.mask.copy()
        sub = np.zeros_like(mask)
        sub[s // 2::s, s // 2::s] = True
        pick = mask & sub
        pts = centres[pick]
        P.append(pts)
        M.append(np.repeat(np.asarray(m.normal, np.float64)[None], len(pts), 0))
        K.append(np.full(len(pts), k))
    if not P:
        return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, int)
    return np.concatenate(P), np.concatenate(M), np.concatenate(K)


#: the lone scores use at most this many of the room's voting points (every n-th)
SCORE_POINTS = 1200


class _Scorer:
    """The refinement problem's cost on a subset of its points, for many lone luminaires
    at once (no occlusion, no interreflection of their own)."""

    def __init__(self, prob, most=SCORE_POINTS):
        step = max(1, int(np.ceil(len(prob.positions) / most)))
        sl = slice(0, None, step)
        self.sl = sl
        self.pos, self.nrm = prob.positions[sl], prob.normals[sl]
        self.target, self.log_target = prob.target[sl], prob.log_target[sl]
        self.base = prob.indirect[sl]
        w = prob.w_area[sl]
        self.w = w / w.sum()
        self.eps, self.c, self.flux = prob.eps_lux, prob.robust_scale, prob.flux
        phot = prob.photometry
        self.phot = phot
        # rotationally symmetric: the intensity depends on gamma only
        self.sym = None if phot is None or not np.allclose(phot.table, phot.table[:1]) \
            else phot.table[0]
        self._pp = np.einsum("kj,kj->k", self.pos, self.pos)
        self._pn = np.einsum("kj,kj->k", self.pos, self.nrm)
        self.cost0 = self.cost_of(np.zeros((1, len(self.pos))))[0]
        self.wT = self.w * self.target

    def add_base(self, light):
        """Score against the light (k,) of luminaires already accepted, added to the base
        (the cost without a candidate becomes theirs)."""
        self.base = self.base + light[self.sl]
        self.cost0 = self.cost_of(np.zeros((1, len(self.pos))))[0]

    def direct(self, C, N, Mn):
        """(K, k) lux of luminaires of the problem's flux at ``C`` aimed ``N``, mounted
        facing ``Mn``.

        Every projection of the direction luminaire -> point is a matrix product of the
        (K, 3) luminaire vectors with the (k, 3) points (d . a = p . a - c . a, |d|^2 =
        |p|^2 + |c|^2 - 2 p . c): no (K, k, 3) array (measured on the bench lobby,
        --seed 4: the footprint scoring 13.4 s CPU before)."""
        P = self.pos
        pp = self._pp

        def along(A):                      # (K, k): d . A_K
            return A @ P.T - np.einsum("Kj,Kj->K", C, A)[:, None]
        r2 = np.maximum(pp[None] + np.einsum("Kj,Kj->K", C, C)[:, None] - 2.0 * (C @ P.T),
                        1e-12)
        r = np.sqrt(r2)
        # cos at the receiver: -n . d / r, with n . d = n . p - n . c (n per point)
        cs = (C @ self.nrm.T - self._pn[None]) / r
        front = along(Mn) > 0
        cg = along(N) / r
        if self.phot is None:
            i_lm = np.maximum(cg, 0.0) / np.pi
        elif self.sym is not None:
            i_lm = self._sym_lookup(cg)
        else:
            U = _aimed_c0_many(Mn, N)
            V = np.cross(N, U)
            local = np.stack([along(U) / r, along(V) / r, cg], axis=-1)
            i_lm = self.phot.intensity_per_lm(local)
        return np.where((cs > 0) & front, self.flux * i_lm * cs / r2, 0.0)

    #: samples of the symmetric intensity over t = sin(gamma / 2) in [0, 1] (gamma
    #: about 0.06 degrees apart: t is nearly proportional to gamma)
    SYM_SAMPLES = 2049

    def _sym_lookup(self, cg):
        """The symmetric intensity (per lumen) at cos(gamma) ``cg``: linear in a table
        over t = sin(gamma / 2) = sqrt((1 - cg) / 2) (a square root instead of arccos
        and a search per point; the same curve within 1e-3 of its peak)."""
        if getattr(self, "_sym_t", None) is None:
            t = np.linspace(0.0, 1.0, self.SYM_SAMPLES)
            self._sym_t = np.interp(np.degrees(2.0 * np.arcsin(t)),
                                    np.arange(len(self.sym)), self.sym)
        x = np.sqrt(np.clip(0.5 * (1.0 - cg), 0.0, 1.0)) * (self.SYM_SAMPLES - 1)
        i0 = np.minimum(x.astype(np.intp), self.SYM_SAMPLES - 2)
        f = x - i0
        tab = self._sym_t
        return tab[i0] * (1.0 - f) + tab[i0 + 1] * f

    def cost_of(self, E):
        """Area-weighted squared error of linear illuminance (K,).

        Not the refinement's robust log cost: alone, a luminaire spreading a little light
        over the many points other luminaires light lowers the log cost more than the
        spot that explains its own footprint exactly (measured on a gallery: a grazing
        wall candidate 0.34, the true ceiling spot 0.24), and ranks first; in linear
        light the brightest footprints go first and overshoot costs as much as a
        shortfall (matching pursuit)."""
        r = E + self.base[None] - self.target[None]
        return (self.w[None] * r * r).sum(1)

    def score(self, C, N, Mn, free_flux):
        """(costs (K,), flux scales (K,)) of each luminaire alone, its flux the least
        squares one (within the refinement's limits) when ``free_flux``."""
        E = self.direct(C, N, Mn)
        scale = np.ones(len(C))
        if free_flux:
            rest = self.target - self.base
            num = E @ (self.w * rest)
            den = np.maximum(
                             (E * E) @ self.w, 1e-300)
            lim = np.exp(LOG_SCALE_LIMIT)
            scale = np.clip(num / den, 1.0 / lim, lim)
            E = E * scale[:, None]
        return self.cost_of(E), scale


def _aimed_c0_many(Mn, N):
    """(K, 3) :func:`invrad_wb.core.model.aiming.aimed_c0` of many luminaires."""
    from invrad_wb.core.model.scene import plane_basis
    out = np.empty_like(N)
    for m in np.unique(Mn, axis=0):
        sel = np.all(Mn == m, axis=1)
        u, _ = plane_basis(m)
        a = N[sel]
        v = np.cross(m, a)
        c = a @ m
        # Rodrigues: R u = u + v x u + v x (v x u) / (1 + c)
        vu = np.cross(v, u)
        out[sel] = u + vu + np.cross(v, vu) / (1.0 + c)[:, None]
    return out


def footprint_candidates(run, s, lux=None, light=None, most=MAX_HOT_SPOTS):
    """Aimed candidates (list of :class:`Light`, best first) from the hot spots of a
    room's targets (module docstring), each with its lone score in ``peak_score``.

    ``lux`` (k,): the hot spots of this light instead of the targets' (the light the
    accepted luminaires leave unexplained); ``light`` (k,): the accepted luminaires' light,
    which each candidate is then scored beside; ``most``: hot spots at most."""
    canvas = run.canvas
    pts = run.points
    H, Hn = hot_spots(pts.positions, pts.normals, pts.lux if lux is None else lux,
                      most=most)
    P, Mn, K = apex_grid(canvas)
    if not len(H) or not len(P):
        return []
    scorer = _Scorer(run.problem)
    if light is not None:
        scorer.add_base(light)
    cost0 = scorer.cost0
    cos_max = np.cos(np.radians(s.max_tilt_deg))
    jobs = []
    for h, hn in zip(H, Hn):
        d = h - P
        dist = np.linalg.norm(d, axis=1)
        ok = (np.einsum("ij,ij->i", d, Mn) > cos_max * dist) & ((P - h) @ hn > 0.05) \
            & (dist > 0.2)
        idx = np.flatnonzero(ok)
        if not len(idx):
            continue
        aims = d[idx] / dist[idx, None]
        costs, scales = [], []
        for b in range(0, len(idx), BATCH):
            sl = slice(b, b + BATCH)
            c, sc = scorer.score(P[idx[sl]], aims[sl], Mn[idx[sl]], run.free_flux)
            costs.append(c)
            scales.append(sc)
        costs, scales = np.concatenate(costs), np.concatenate(scales)
        kept = []
        for j in np.argsort(costs):
            if costs[j] >= cost0 or len(kept) >= KEEP_PER_SPOT:
                break
            if any(np.linalg.norm(P[idx[j]] - P[idx[i]]) < APEX_APART_M for i in kept):
                continue
            kept.append(j)
        jobs += [(K[idx[j]], P[idx[j]], h, hn, Mn[idx[j]]) for j in kept]
    out = [_aimed_light(canvas, job[0], p, a, s, scale=sc, score=(cost0 - c) / cost0)
           for job, (p, a, sc, c) in zip(jobs, _polish_many(scorer, canvas, jobs,
                                                             run.free_flux, cos_max))]
    out.sort(key=lambda L: -L.peak_score)
    # two grid apexes of one hot spot may polish to the same luminaire
    uniq = []
    for L in out:
        if not any(np.linalg.norm(L.position - U.position) < 0.05
                   and L.normal @ U.normal > np.cos(np.radians(2.0)) for U in uniq):
            uniq.append(L)
    return uniq


def lone_score(run, light, base):
    """The score :func:`footprint_candidates` gives, beside the light ``base`` (k,), to
    the luminaire ``light`` as it stands: the share of the cost it removes."""
    scorer = _Scorer(run.problem)
    scorer.add_base(base)
    mount = light.mount if light.mount is not None else light.normal
    c, _ = scorer.score(light.position[None], light.normal[None],
                        np.asarray(mount, np.float64)[None], run.free_flux)
    return float((scorer.cost0 - c[0]) / scorer.cost0)


#: pattern search of :func:`_polish`: first and last step (metres), most iterations
POLISH_STEP_M = (0.1, 0.02)
POLISH_ITERATIONS = 40


def _polish(scorer, canvas, k, apex, h, hn, mount, free_flux, cos_max):
    """A grid apex aimed at a hot spot, improved by a pattern search over the apex on its
    surface and the point the axis meets near the hot spot (4 parameters, steps halved
    from 0.1 to 0.02 m): the grid's 0.3 m and a footprint's peak beside its axis are too
    coarse for a narrow beam. Returns (position, aim, flux scale, lone cost)."""
    from invrad_wb.core.model.scene import plane_basis
    m = canvas.maps[k]
    hu, hv = plane_basis(hn)

    def make(X):
        P = apex + X[:, 0:1] * m.u + X[:, 1:2] * m.v
        A = h + X[:, 2:3] * hu + X[:, 3:4] * hv - P
        A = A / np.linalg.norm(A, axis=1, keepdims=True)
        return P, A

    x = np.zeros(4)
    P, A = make(x[None])
    c, sc = scorer.score(P, A, mount[None], free_flux)
    best = (float(c[0]), float(sc[0]))
    step, its = POLISH_STEP_M[0], 0
    moves = np.vstack([np.eye(4), -np.eye(4)])
    while step >= POLISH_STEP_M[1] - 1e-12 and its < POLISH_ITERATIONS:
        its += 1
        X = x + step * moves
        P, A = make(X)
        ok = (A @ mount >= cos_max) & _on_map(canvas, k, P)
        if not ok.any():
            step /= 2
            continue
        c, sc = scorer.score(P[ok], A[ok], np.broadcast_to(mount, (int(ok.sum()), 3)),
                             free_flux)
        i = int(np.argmin(c))
        if c[i] < best[0]:
            x = X[ok][i]
            best = (float(c[i]), float(sc[i]))
        else:
            step /= 2
    P, A = make(x[None])
    return P[0], A[0], best[1], best[0]


def _polish_many(scorer, canvas, jobs, free_flux, cos_max):
    """:func:`_polish` of many grid apexes at once (``jobs``: (map index, apex, hot spot,
    its normal, mount normal) each): every pattern-search iteration scores the moves of
    all apexes still searching in one batch (the same search per apex; measured on
    bench_aim's free-flux lobby --seed 6: 129 polishes, 5555 score calls and 8.4 s of a
    63 s profile one at a time). Returns [(position, aim, flux scale, lone cost)]."""
    from invrad_wb.core.model.scene import plane_basis
    n = len(jobs)
    if not n:
        return []
    maps = [canvas.maps[job[0]] for job in jobs]
    apex = np.array([job[1] for job in jobs], dtype=np.float64)
    hit = np.array([job[2] for job in jobs], dtype=np.float64)
    mount = np.array([job[4] for job in jobs], dtype=np.float64)
    mu = np.array([m.u for m in maps], dtype=np.float64)
    mv = np.array([m.v for m in maps], dtype=np.float64)
    huv = [plane_basis(job[3]) for job in jobs]
    hu = np.array([b[0] for b in huv])
    hv = np.array([b[1] for b in huv])
    kk = np.array([job[0] for job in jobs])

    def make(X, J):
        """Apexes and aims (len(J), 3) of the parameters X (len(J), 4) of jobs J."""
        P = apex[J] + X[:, 0:1] * mu[J] + X[:, 1:2] * mv[J]
        A = hit[J] + X[:, 2:3] * hu[J] + X[:, 3:4] * hv[J] - P
        return P, A / np.linalg.norm(A, axis=1, keepdims=True)

    def score(P, A, J):
        cs, scs = [], []
        for b in range(0, len(J), 8 * BATCH):
            sl = slice(b, b + 8 * BATCH)
            c, sc = scorer.score(P[sl], A[sl], mount[J[sl]], free_flux)
            cs.append(c)
            scs.append(sc)
        return np.concatenate(cs), np.concatenate(scs)

    x = np.zeros((n, 4))
    every = np.arange(n)
    c, sc = score(*make(x, every), every)
    best_c, best_s = c.astype(np.float64), sc.astype(np.float64)
    step = np.full(n, POLISH_STEP_M[0])
    its = np.zeros(n, dtype=int)
    moves = np.vstack([np.eye(4), -np.eye(4)])
    while True:
        act = np.flatnonzero((step >= POLISH_STEP_M[1] - 1e-12) & (its < POLISH_ITERATIONS))
        if not len(act):
            break
        its[act] += 1
        J = np.repeat(act, len(moves))
        X = (x[act][:, None, :] + step[act][:, None, None] * moves[None]).reshape(-1, 4)
        P, A = make(X, J)
        ok = np.einsum("ij,ij->i", A, mount[J]) >= cos_max
        for k in np.unique(kk[act]):
            rows = np.flatnonzero(kk[J] == k)
            ok[rows] &= _on_map(canvas, k, P[rows])
        rows = np.flatnonzero(ok)
        c, sc = score(P[rows], A[rows], J[rows]) if len(rows) else (np.zeros(0), np.zeros(0))
        for a in act:
            mine = np.flatnonzero(J[rows] == a)
            if not len(mine):
                step[a] /= 2
                continue
            i = mine[int(np.argmin(c[mine]))]
            if c[i] < best_c[a]:
                x[a] = X[rows[i]]
                best_c[a], best_s[a] = float(c[i]), float(sc[i])
            else:
                step[a] /= 2
    P, A = make(x, every)
    return [(P[j], A[j], float(best_s[j]), float(best_c[j])) for j in range(n)]


def _on_map(canvas, k, P):
    """(n,) bool: :meth:`VoteCanvas.map_contains` of the points ``P`` (n, 3) on map ``k``,
    the pixel test for all at once and the face test only beside the faces' border (the
    pattern search asked 80,000 times, one point at a time: 13 s of 148 s wall in a
    profile of bench_aim's free-flux lobby)."""
    m = canvas.maps[k]
    d = np.asarray(P, dtype=np.float64) - m.origin
    i = np.floor((d @ m.u) / m.pixel).astype(np.int64)
    j = np.floor((d @ m.v) / m.pixel).astype(np.int64)
    out = (i >= 0) & (i < m.shape[0]) & (j >= 0) & (j < m.shape[1])
    idx = np.flatnonzero(out)
    out[idx] = m.mask[i[idx], j[idx]]
    if m.face_test is None:
        return out
    idx = np.flatnonzero(out)
    border = idx[~m.face_test.inner[i[idx], j[idx]]]
    for n in border:
        out[n] = canvas.map_contains(k, P[n])
    return out


def _aimed_light(canvas, k, position, aim, s, scale=1.0, score=0.0):
    m = canvas.maps[k]
    return Light(kind="surface", position=np.asarray(position, np.float64).copy(),
                 normal=np.asarray(aim, np.float64).copy(), map_index=int(k), plane=m.plane,
                 peak_score=float(score), origin=m.origin.copy(), u=m.u.copy(),
                 v=m.v.copy(), flux_scale=float(scale),
                 mount=np.asarray(m.normal, np.float64).copy(),
                 max_tilt=float(s.max_tilt_deg))


#: hot spots of the unexplained light scored per pursuit step, and most steps
PURSUIT_SPOTS = 4
PURSUIT_STEPS = 24
#: a pursuit step must remove this share of the cost without any luminaire (the floor
#: :func:`invrad_wb.core.inverse.select.greedy_select` had before its noise-aware rule;
#: the pursuit keeps it)
PURSUIT_MIN_GAIN_TOTAL = 0.005


def footprint_pursuit(run, s, significant=0.2, spots=PURSUIT_SPOTS, steps=PURSUIT_STEPS):
    """Aimed candidates found one after another (matching pursuit over footprints): the
    best footprint candidate of the light still unexplained (:func:`footprint_candidates`
    over the ``spots`` brightest hot spots of the target less the light of those found so
    far, where that is more than ``significant`` of a point's target), scored beside
    them, is taken and its light (with its estimated interreflection) added, while it
    removes ``s.min_gain`` of the cost left and :data:`PURSUIT_MIN_GAIN_TOTAL` of the
    empty one. Returns the candidates in the order found.

    Scored alone against the whole target, the beams of a wall wash that overlap lose to
    a wide candidate from far away that covers a little of every beam (measured on the
    bench lobby, seed 4: for the hot spot of an outer wall-wash beam the best apex was on
    the opposite wall, the true spot ranked below it at 0.136 of the cost against 0.144);
    beside the beams already found, what is left of each beam is its own."""
    prob, pts = run.problem, run.points
    light = np.zeros(len(pts.lux))
    out, columns = [], []
    cost_empty = None
    for _ in range(steps):
        left = pts.lux - prob.indirect - light
        lux = np.where((pts.lux > 0) & (left > significant * pts.lux), left, 0.0)
        if not np.any(lux > 0):
            break
        found = footprint_candidates(run, s, lux=lux, light=light, most=spots)
        if not found:
            break
        best = found[0]
        scorer = _Scorer(prob)
        if cost_empty is None:
            cost_empty = scorer.cost0
        scorer.add_base(light)
        gain = best.peak_score * scorer.cost0
        if gain < s.min_gain * scorer.cost0 or gain < PURSUIT_MIN_GAIN_TOTAL * cost_empty:
            break
        out.append(best)
        if not run.free_flux:
            light = light + prob.fixed_light([prob.with_indirect(best)])
            continue
        # fluxes free: all fluxes found so far refitted together (orthogonal matching
        # pursuit); alone, the first candidate's flux grows to cover its neighbours'
        # light too, and what it leaves shows no beam (the bench lobby, free flux: the
        # pursuit stopped after 2 of 5)
        unit = best.copy()
        unit.flux_scale = 1.0
        columns.append(prob.fixed_light([prob.with_indirect(unit)]))
        scales = _nonnegative_fluxes(np.column_stack(columns), pts.lux - prob.indirect,
                                     prob.w_area)
        for L, f in zip(out, scales):
            L.flux_scale = float(f)
        light = np.column_stack(columns) @ scales
    return out


def _nonnegative_fluxes(E, target, w):
    """Flux scales (n,) >= 0 of the columns of ``E`` (k, n) that best give ``target``
    (k,) in area-weighted least squares, within the refinement's limits."""
    from scipy.optimize import nnls
    sw = np.sqrt(np.maximum(w, 0.0))
    x, _ = nnls(E * sw[:, None], target * sw)
    lim = np.exp(LOG_SCALE_LIMIT)
    return np.clip(x, 1.0 / lim, lim)


def aimed_candidates(run, s, cands):
    """The candidates of ``locate --aim free``: the vote peaks' surface candidates made
    aimable (mounted where they are, aim free) and the footprint candidates, all ranked
    by their lone score; mid-air (pendant) candidates keep their fixed aim and rank."""
    scorer = _Scorer(run.problem)
    cost0 = scorer.cost0
    ranked = []
    for L in cands:
        if L.kind != "surface":
            ranked.append((L, None))
            continue
        A = L.copy()
        A.mount = np.asarray(L.normal, np.float64).copy()
        A.max_tilt = float(s.max_tilt_deg)
        c, _ = scorer.score(A.position[None], A.normal[None], A.mount[None], run.free_flux)
        ranked.append((A, float((cost0 - c[0]) / cost0)))
    for L in footprint_candidates(run, s):
        ranked.append((L, L.peak_score))
    scored = sorted([t for t in ranked if t[1] is not None], key=lambda t: -t[1])
    # pendant candidates keep their place in the vote order, after the scored ones
    return [L for L, _ in scored] + [L for L, sc in ranked if sc is None]


def aim_extra(light):
    """Result extras of an aimed luminaire: its mount normal, tilt and pan (degrees),
    and its photometry's C = 0 axis."""
    from invrad_wb.core.model.aiming import tilt_pan
    t, p = tilt_pan(light.normal, light.mount)
    return {"mount_normal": [round(float(x), 6) for x in light.mount],
            "tilt_deg": round(t, 3), "pan_deg": round(p, 3)}, aimed_c0(light.mount,
                                                                        light.normal)


#: :func:`footprint_merge`: two luminaires whose light overlaps by more than this share
#: (of the weaker one's) are tried as one; footprint candidates tried per pair; pairs
#: tried in a row without a merge before it stops; most merges. Measured on bench_aim's
#: free-flux lobby --seed 6: the ghost wall light's light lies 1.0 inside the spot's;
#: neighbouring wall-wash beams overlap 0.32-0.57, and 21 trials of all pairs above 0.3
#: cost 31 CPU s, none kept; a ghost lies (almost) wholly inside the footprint it shares
MERGE_OVERLAP = 0.75
MERGE_TRIES = 2
MERGE_PATIENCE = 2
MERGE_MOST = 4


def _overlap(Ea, Eb, w):
    """The share of the weaker light (area-weighted) that the other light covers:
    sum w min(Ea, Eb) / min(sum w Ea, sum w Eb)."""
    lo = min(float(w @ Ea), float(w @ Eb))
    return float(w @ np.minimum(Ea, Eb)) / lo if lo > 0 else 0.0


def footprint_merge(fit, search, lights, cost, significant=0.2, overlap=MERGE_OVERLAP,
                    tries=MERGE_TRIES, patience=MERGE_PATIENCE, most=MERGE_MOST):
    """``--aim free`` with free fluxes: two luminaires whose *light* overlaps (more than
    ``overlap`` of the weaker one's) replaced by one footprint candidate of what the
    others leave unexplained, kept when the count search's criterion (``search``: a
    :class:`~invrad_wb.core.inverse.locate_count.CountSearch`) falls.

    The count search merges luminaires that are close; aimed luminaires that share one
    footprint may be far apart: with free fluxes a beam's light can be traded between a
    spot and a second luminaire elsewhere (a wall light) that lights the same place, and
    each refit only moves light between the two (measured on bench_aim's free-flux lobby
    --seed 6: a 242 lm wall light beside the 981 lm ceiling spot at 34 cm and 4.8 degrees
    from the true one, whose 1200 lm alone explain the light; neither removing the wall
    light nor splitting leaves that local minimum). The pair's footprint found again
    from the light left (:func:`footprint_candidates`, a global search over apexes and
    aim points beside the others' light), refined alone beside the others, then with
    everything (:meth:`CountSearch._refit`). Pairs most overlapping first; after a merge
    the pairs are looked at again (at most ``most`` merges); ``patience`` pairs in a row
    without a merge end it."""
    run, prob, s = fit.run, fit.prob, fit.s
    pts = run.points
    w = prob.w_area
    best = search.score(lights)
    merges = trials = 0
    changed = True
    while changed and merges < most and len(lights) >= 2:
        changed = False
        own = [prob.fixed_light([L]) for L in lights]
        pairs = sorted(((_overlap(own[i], own[j], w), i, j) for i in range(len(lights))
                        for j in range(i + 1, len(lights))), reverse=True)
        misses = 0
        for ov, i, j in pairs:
            if ov < overlap or misses >= patience or search._late():
                break
            rest = [L for k, L in enumerate(lights) if k not in (i, j)]
            light = sum((own[k] for k in range(len(lights)) if k not in (i, j)),
                        np.zeros(len(w)))
            left = pts.lux - prob.indirect - light
            lux = np.where((pts.lux > 0) & (left > significant * pts.lux), left, 0.0)
            if not np.any(lux > 0):
                continue
            for cand in footprint_candidates(run, s, lux=lux, light=light,
                                             most=PURSUIT_SPOTS)[:tries]:
                trials += 1
                alone, _c = fit.opt([prob.with_indirect(cand)], fixed=light)
                got, c, b = search._refit(rest + alone)
                if b < best:
                    lights, cost, best = got, c, b
                    merges, changed = merges + 1, True
                    break
            if changed:
                break
            misses += 1
    fit.trace.append({"footprint_merges": merges, "trials": trials, "bic_after": best})
    return lights, cost


class AimedCountSearch(CountSearch):
    """The count search of ``--aim free`` with free fluxes: after a split is kept,
    :func:`footprint_merge` at once (a split's pieces that share one footprint replaced by
    one footprint candidate) before the next change is looked for.

    A luminaire that stands in for a spot elsewhere (a wall light lighting a floor spot's
    footprint) leaves the fit above the model floor; the split's pieces let the others
    settle where they belong, and the pieces' shared footprint then gives the spot.
    Without the merge in between the search went on splitting the pieces (measured on
    bench_aim's free-flux lobby --seed 8: three splits and a merge to seven luminaires,
    23 CPU s, before :func:`footprint_merge` made them five)."""

    def split(self, lights, best):
        got = super().split(lights, best)
        if got is None:
            return None
        what, lights, cost, b = got
        merged, c2 = footprint_merge(self.fit, self, lights, cost)
        if merged is lights:
            return got
        return what + ", footprint merged", merged, c2, self.score(merged)
