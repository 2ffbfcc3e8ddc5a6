"""How many luminaires, when their fluxes are free: split, merge and remove luminaires of a
fitted arrangement and keep a change when a model-selection criterion tied to the data's
noise level says the data need it.

Votes with a free flux find the light's accumulation points, but where luminaires are
close (a cluster a third of the mounting height apart) or evenly spread (an array at about
the mounting height), one luminaire of their summed flux between them explains most of
their light: greedy selection keeps too few, each too strong; and with noisy targets a
luminaire that fits the noise lowers the cost too, so it keeps too many. Here:

- **split**: a luminaire is replaced by two of half its flux a short way apart (four
  directions, two distances), the pair is fitted with the others held, and the best
  pair of all luminaires is refitted with everything (sparse recovery's greedy pursuit
  with re-fitting, the new atoms found by splitting rather than from a fixed dictionary);
  not where one luminaire with a luminous disk (at most :func:`largest_radius`) explains
  the data as well: the refinement's luminaires are points, and points within an area
  luminaire mimic its light better than one point does;
- **merge**: two near luminaires are replaced by one of their summed flux at their
  flux-weighted centre;
- **remove**: a luminaire is dropped and the others refitted.

A change is kept when it lowers the Bayesian information criterion of the fit,

    BIC = k ln(m) + p ln(k)

with k the lit voting points, m the area-weighted mean square of the log residual (each
residual clipped at :data:`OUTLIER_CLIP` robust standard deviations: a gross error at a
few points is not a luminaire's light) and p
the number of fitted parameters (per luminaire its position on its surface, 2, or in
mid-air, 3, and its flux; a flux shared by luminaires of one kind once:
:mod:`~invrad_wb.core.inverse.locate_ties`). The noise level enters through m: the gain
a luminaire must bring, k ln(m_before / m_after) > 3 ln(k), is a fixed number of noise
variances. m is held at least :data:`MODEL_FLOOR` squared: a forward model's own error
(interpolated targets, the interreflection of patches) is not noise a further luminaire
should fit.

Measured with bench/bench_count.py (5 % noise, interreflection): see its docstring.
"""
import numpy as np

from invrad_wb.core.model.scene import plane_basis
# the smallest root-mean-square log residual the criterion believes (0.3 %, the greedy
# selection's too): below it the remaining misfit is the model's, not the data's noise
from invrad_wb.core.inverse.select import MODEL_FLOOR

#: split distances, as fractions of the mounting distance to the lit points below, and
#: directions (degrees) in the luminaire's plane
SPLIT_FRACTIONS = (0.1, 0.25)
SPLIT_DIRECTIONS = (0.0, 45.0, 90.0, 135.0)

#: pairs closer than this fraction of their mounting distance are tried as one luminaire
MERGE_FRACTION = 0.5

#: Levenberg-Marquardt steps of a refit after a change
REFIT_STEPS = 100

#: the largest luminous disk (radius, m) taken as one luminaire when the photometry does
#: not give its luminous area: a 600 mm round panel (and twice the refinement's
#: ``separation_m``, the distance below which two luminaires are not separate fixtures)
EXTENDED_RADIUS_M = 0.3

#: radii of the luminous disk tried in place of a split, as multiples of the one with the
#: pieces' second moment
EXTENDED_RADII = (0.75, 1.0, 1.25, 1.5)

#: at most this many accepted changes per room (a bound on the time spent)
MAX_CHANGES = 40

#: residuals beyond this many robust standard deviations count as that many in the
#: criterion (:func:`robust_mean_square`): gross errors at a few points, not light
OUTLIER_CLIP = 4.0


def robust_mean_square(r, w):
    """Area-weighted (``w``, summing to 1) mean square of the log residuals ``r``, each
    clipped at :data:`OUTLIER_CLIP` times their robust scale (1.4826 times the median
    absolute residual, at least :data:`MODEL_FLOOR`).

    A luminaire's light changes the residual at the many points it lights; a gross error
    at a few points (a target vertex whose shadow ray grazed a mesh edge, a faulty
    reading) is not light a further luminaire should explain. Unclipped, two such
    vertices among 2998 (l_room, direct light, 16 % and 12 % off) raised the mean square
    of the true arrangement to 1.5 times the floor, and a third luminaire of 102 lm that
    moved the other's visibility off the edge paid for itself. With Gaussian noise the
    clip touches about 1 point in 16000."""
    r = np.abs(np.asarray(r, dtype=np.float64))
    s = max(1.4826 * float(np.median(r)), MODEL_FLOOR) if len(r) else MODEL_FLOOR
    r = np.minimum(r, OUTLIER_CLIP * s)
    return float(np.sum(w * r * r))


def _mean_square(prob, lights):
    """Area-weighted robust mean square of the log residual over the points
    (:func:`robust_mean_square`; the separation term left out)."""
    vis = [prob.visibility(L) for L in lights]
    r, _ = prob.residuals(lights, vis)
    return robust_mean_square(r, prob.w_area)


def _params(lights):
    """The fit's parameter count: each luminaire's position and flux, a flux shared by
    luminaires of one kind (:attr:`~invrad_wb.core.inverse.refine.Light.flux_group`)
    counted once."""
    groups = [getattr(L, "flux_group", -1) if getattr(L, "free_flux", False) else -1
              for L in lights]
    return (len({gr for gr in groups if gr >= 0}) + sum(gr < 0 for gr in groups)
            + sum(2 if L.kind == "surface" else 3 for L in lights))


def bic(prob, lights, k=None):
    """The criterion of the module docstring for ``lights`` (lower is better)."""
    k = len(prob.target) if k is None else k
    return bic_of(_mean_square(prob, lights), _params(lights), k)


def bic_of(mean_square, params, k):
    """The criterion from the robust mean square, the parameter count and the lit points."""
    return k * np.log(max(mean_square, MODEL_FLOOR ** 2)) + params * np.log(k)


def _mount_distance(prob, L):
    """A luminaire's typical distance to the points it lights most (m): the median
    distance to the 10 % nearest points in front of it."""
    d = prob.positions - L.position
    front = d @ L.normal > 0
    if not np.any(front):
        return 1.0
    dist = np.linalg.norm(d[front], axis=1)
    return float(max(0.3, np.percentile(dist, 10)))


def _basis(L):
    if L.kind == "surface" and L.u is not None:
        return L.u, L.v
    return plane_basis(L.facing())


def _disk(L, centre, scale, radius):
    """Point luminaires that together are a lambertian-area disk of ``radius`` about
    ``centre`` in L's plane with L's flux scale ``scale`` (the forward model's disk
    quadrature, :func:`~invrad_wb.core.model.luminaires.disk_quadrature`); L's
    interreflection per unit flux is shared out with the flux."""
    from invrad_wb.core.model.luminaires import disk_quadrature
    qp, qw = disk_quadrature()
    u, v = _basis(L)
    out = []
    for (a, b), w in zip(qp, qw):
        q = L.copy()
        q.position = centre + radius * (a * u + b * v)
        q.flux_scale = float(scale * w)
        out.append(q)
    return out


def largest_radius(prob):
    """The largest luminous disk (m) one luminaire may be: the photometry's luminous area
    where it gives one, else :data:`EXTENDED_RADIUS_M`."""
    area = getattr(prob.photometry, "luminous_area_m2", None) if prob.photometry else None
    if area:
        return float(np.sqrt(area / np.pi))
    return EXTENDED_RADIUS_M


def _moved(prob, L, pos, scale):
    """A copy of L at ``pos`` with flux scale ``scale`` (its interreflection scaled with
    it, as computed where L was), kept in its allowed region; None if it cannot be."""
    q = L.copy()
    q.position = np.asarray(pos, dtype=np.float64)
    q.flux_scale = float(scale)
    if prob.inside is not None:
        q = prob.inside(q)
    return q


class CountSearch:
    """Split / merge / remove around a fitted arrangement (``fit``: a
    :class:`~invrad_wb.core.inverse.locate_fit._RoomFit` whose problem has free fluxes)."""

    def __init__(self, fit, deadline=None):
        self.fit, self.prob = fit, fit.prob
        self.k = int(np.sum(self.prob.target > 0)) or len(self.prob.target)
        self.deadline = deadline

    def score(self, lights):
        return bic(self.prob, lights, self.k)

    def _late(self):
        import time
        return self.deadline is not None and time.time() > self.deadline

    def run(self, lights, cost):
        """(lights, cost) with the count the criterion chooses."""
        trace = self.fit.trace
        best = self.score(lights)
        for _ in range(MAX_CHANGES):
            if self._late():
                trace.append({"count_search": "time limit"})
                break
            step = None
            for move in (self.remove, self.merge, self.split):
                got = move(lights, best)
                if got is not None:
                    step = got
                    break
            if step is None:
                break
            what, lights, cost, b = step
            self.fit.rejected_split = None
            trace.append({"count_search": what, "lights": len(lights), "bic_before": best,
                          "bic_after": b})
            best = b
        return lights, cost

    def _refit(self, lights):
        # close luminaires with free fluxes lie in a long flat valley (flux moves between
        # them as they move): more steps than a fit of known fluxes needs
        if self.fit.s.optimiser == "lm":
            lights, cost = self.prob.levenberg_marquardt(lights, iterations=REFIT_STEPS)
        else:
            lights, cost = self.fit.opt(lights)
        lights, cost = self.fit.converge(lights, cost)
        return lights, cost, self.score(lights)

    def remove(self, lights, best):
        """The first luminaire whose removal (others refitted) lowers the criterion."""
        if len(lights) < 2:
            return None
        order = sorted(range(len(lights)), key=lambda i: lights[i].flux_scale)
        for i in order:
            rest = lights[:i] + lights[i + 1:]
            # a luminaire the data clearly need: without a refit the criterion is far worse
            if self.score(rest) > best + 10 * np.log(self.k) * 3:
                continue
            got, c, b = self._refit(rest)
            if b < best:
                return "remove", got, c, b
        return None

    def merge(self, lights, best):
        """The first near pair whose replacement by one luminaire lowers the criterion."""
        prob = self.prob
        pairs = []
        for i in range(len(lights)):
            for j in range(i + 1, len(lights)):
                a, b = lights[i], lights[j]
                if a.facing() @ b.facing() < 0.9:
                    continue
                d = float(np.linalg.norm(a.position - b.position))
                reach = MERGE_FRACTION * min(_mount_distance(prob, a), _mount_distance(prob, b))
                if d < reach:
                    pairs.append((d, i, j))
        for d, i, j in sorted(pairs):
            a, b = lights[i], lights[j]
            s = a.flux_scale + b.flux_scale
            centre = (a.flux_scale * a.position + b.flux_scale * b.position) / s
            big = a if a.flux_scale >= b.flux_scale else b
            one = _moved(prob, big, centre, s)
            if one is None:
                continue
            # the merged luminaire's interreflection: the pair's, per unit flux
            if a.indirect is not None and b.indirect is not None:
                one.indirect = (a.flux_scale * a.indirect + b.flux_scale * b.indirect) / s
                one.indirect_grad = None
            rest = [L for k, L in enumerate(lights) if k not in (i, j)]
            got, c, sc = self._refit(rest + [one])
            if sc < best:
                return "merge", got, c, sc
        return None

    def split(self, lights, best):
        """The best split of any luminaire into two, if it lowers the criterion.

        None at once when no split can: a split adds at least 3 parameters (a surface
        luminaire's position and flux) and the mean square cannot fall below
        :data:`MODEL_FLOOR` squared, so a fit already near the floor has nothing to gain
        (the same answer, without the pair fits: measured on bench_aim's free-flux rooms,
        where the found luminaires reproduce the targets to the model's own error, the
        split trials were 10-19 CPU s per room)."""
        prob, fit = self.prob, self.fit
        fit.rejected_split = None
        if best <= self.k * np.log(MODEL_FLOOR ** 2) + (_params(lights) + 3) * np.log(self.k):
            return None
        trials = []
        for i, L in enumerate(lights):
            if self._late():
                break
            others = lights[:i] + lights[i + 1:]
            fixed = prob.fixed_light(others) if others else None
            u, v = _basis(L)
            h = _mount_distance(prob, L)
            best_i = None
            for frac in SPLIT_FRACTIONS:
                for deg in SPLIT_DIRECTIONS:
                    t = np.radians(deg)
                    e = np.cos(t) * u + np.sin(t) * v
                    off = 0.5 * frac * h * e
                    a = _moved(prob, L, L.position + off, 0.5 * L.flux_scale)
                    b = _moved(prob, L, L.position - off, 0.5 * L.flux_scale)
                    if a is None or b is None:
                        continue
                    pair, c = fit.opt([a, b], fixed=fixed, iterations=12)
                    if best_i is None or c < best_i[0]:
                        best_i = (c, pair)
            if best_i is not None:
                trials.append((best_i[0], i, best_i[1]))
        near = None
        for c, i, pair in sorted(trials, key=lambda x: x[0])[:3]:
            got, cost, sc = self._refit(lights[:i] + lights[i + 1:] + pair)
            if sc < best and not self._one_extended(got[:-2], got[-2:], sc):
                return "split", got, cost, sc
            if sc >= best and (near is None or sc < near[0]):
                near = (sc, got)
        # the best split the criterion turned down on these points: the last refit on
        # every target vertex of a finely meshed room judges it again with their
        # information (locate_fit._RoomFit.count_on_every_vertex)
        fit.rejected_split = None if near is None else near[1]
        return None

    def _one_extended(self, rest, pieces, split_score):
        """Whether one luminaire with a luminous disk (its size one more parameter)
        explains the data at least as well as ``pieces`` (a split's pair), by the
        criterion. The refinement's luminaires are points: a single area luminaire (a
        disk 0.6 m across at 3 m leaves a 0.5 % residual as a point, above
        :data:`MODEL_FLOOR`) is mimicked better by two or three points within it, and
        without this the split divides it. The disk is centred at the pieces'
        flux-weighted centre with their summed flux, its radius scanned about the one
        with their second moment (:data:`EXTENDED_RADII`), at most :func:`largest_radius`:
        pieces spread wider than a luminaire is large are not one luminaire."""
        prob = self.prob
        s = sum(p.flux_scale for p in pieces)
        centre = sum(p.flux_scale * p.position for p in pieces) / s
        m2 = sum(p.flux_scale * float(np.sum((p.position - centre) ** 2)) for p in pieces) / s
        r0, rmax = float(np.sqrt(2.0 * m2)), largest_radius(prob)   # a disk's is R^2 / 2
        if r0 > rmax:
            return False
        big = max(pieces, key=lambda p: p.flux_scale)
        one = big.copy()
        if all(p.indirect is not None for p in pieces):
            one.indirect = sum(p.flux_scale * p.indirect for p in pieces) / s
            one.indirect_grad = None
        p_one = _params(rest) + _params([one]) + 1
        for f in EXTENDED_RADII:
            disk = _disk(one, centre, s, min(f * r0, rmax))
            b = bic_of(_mean_square(prob, rest + disk), p_one, self.k)
            if b <= split_score:
                self.fit.trace.append({"count_search": "split kept as one luminous disk",
                                       "radius_m": round(min(f * r0, rmax), 3),
                                       "bic_disk": b, "bic_split": split_score})
                return True
        return False


#: :func:`regroup`: luminaires closer than this fraction of their mounting distance are
#: one group (a cluster at 0.3 x the mounting height is; an array at 0.8 x is not)
GROUP_FRACTION = 0.6

#: :func:`regroup`: rotations of the regular polygon start, per turn of one vertex
POLYGON_ROTATIONS = 4

#: :func:`regroup`: the candidate dictionary, a square grid this fraction of the mounting
#: distance apart within this fraction of it around each member
DICTIONARY_STEP = 0.05
DICTIONARY_RADIUS = 0.35


#: :func:`close_groups`: a luminaire whose position the data pin this many times less
#: precisely than the median luminaire's (Cramer-Rao, :func:`~invrad_wb.core.inverse.
#: fitcheck.position_sd`) is poorly pinned; poorly pinned neighbours closer than
#: :data:`PINNED_FRACTION` of their mounting distance are one group too (the inner four
#: of a 4 x 4 array at 0.8 x the mounting height: 12 cm against 1-2 cm)
POORLY_PINNED = 3.0
PINNED_FRACTION = 1.0


def close_groups(prob, lights, fraction=GROUP_FRACTION):
    """Lists of indices of ``lights`` linked by pairs facing the same way closer than
    ``fraction`` of the smaller of their mounting distances (:func:`_mount_distance`), or
    both poorly pinned (:data:`POORLY_PINNED`) and closer than :data:`PINNED_FRACTION` of
    it; only groups of two or more."""
    from invrad_wb.core.geometry.components import component_labels
    from invrad_wb.core.inverse.fitcheck import position_sd
    n = len(lights)
    h = [_mount_distance(prob, L) for L in lights]
    sd = position_sd(prob, lights)[0] if n > 2 else np.zeros(n)
    loose = sd > POORLY_PINNED * np.median(sd)
    pairs = []
    for i in range(n):
        for j in range(i + 1, n):
            a, b = lights[i], lights[j]
            reach = (PINNED_FRACTION if loose[i] and loose[j] else fraction) * min(h[i], h[j])
            if a.facing() @ b.facing() > 0.9 and np.linalg.norm(a.position - b.position) < reach:
                pairs.append((i, j))
    out = {}
    for i, r in enumerate(component_labels(n, pairs)):
        out.setdefault(int(r), []).append(i)
    return [g for g in out.values() if len(g) > 1]


def _polygon_starts(prob, members):
    """The group as a regular polygon of as many equal luminaires at its flux-weighted
    centre, its RMS radius, :data:`POLYGON_ROTATIONS` rotations (the members' own
    arrangement is often a local minimum where flux traded against position)."""
    s = sum(L.flux_scale for L in members)
    c = sum(L.flux_scale * L.position for L in members) / s
    rad = float(np.sqrt(np.mean([np.sum((L.position - c) ** 2) for L in members])))
    u, v = _basis(members[0])
    n = len(members)
    out = []
    for rot in range(POLYGON_ROTATIONS):
        a0 = 2 * np.pi * rot / (POLYGON_ROTATIONS * n)
        new = [_moved(prob, L, c + rad * (np.cos(a0 + 2 * np.pi * k / n) * u
                                          + np.sin(a0 + 2 * np.pi * k / n) * v), s / n)
               for k, L in enumerate(members)]
        if all(q is not None for q in new):
            out.append(("polygon", new))
    return out


def _dictionary_start(prob, members, fixed):
    """Non-negative least squares over a local dictionary of point luminaires (a grid
    around each member, :data:`DICTIONARY_STEP`, :data:`DICTIONARY_RADIUS`) of what the
    rest of the room leaves, relative residual, area-weighted; its support is gathered
    into as many luminaires as the group has by a flux-weighted k-means seeded farthest
    first from the strongest atom. Each atom's interreflection per unit flux: the
    members' mean. None if it fails."""
    from scipy.optimize import nnls
    h = min(_mount_distance(prob, L) for L in members)
    rad, step = DICTIONARY_RADIUS * h, DICTIONARY_STEP * h
    grid = np.arange(-rad, rad + 1e-9, step)
    atoms, seen = [], []
    for L in members:
        u, v = _basis(L)
        for a in grid:
            for b in grid:
                if a * a + b * b > rad * rad:
                    continue
                p = L.position + a * u + b * v
                if any(np.linalg.norm(p - q) < 0.5 * step for q in seen):
                    continue
                q = _moved(prob, L, p, 1.0)
                if q is not None:
                    atoms.append(q)
                    seen.append(q.position)
    n = len(members)
    if len(atoms) < n:
        return None
    E, _ = prob.lights_of(atoms, [prob.visibility(q) for q in atoms])
    A = E.T
    if all(L.indirect is not None for L in members):
        A = A + (sum(L.indirect for L in members) / n)[:, None]
    lit = prob.target > 0
    row = np.sqrt(prob.w_area[lit]) / (prob.target[lit] + prob.eps_lux)
    rest = prob.target - prob.indirect - fixed
    x, _ = nnls(A[lit] * row[:, None], rest[lit] * row)
    on = x > 0
    if np.count_nonzero(on) < n:
        return None
    P, x = np.array(seen)[on], x[on]
    C = [P[np.argmax(x)]]
    while len(C) < n:
        d = np.min(np.linalg.norm(P[:, None] - np.array(C)[None], axis=2), axis=1)
        C.append(P[np.argmax(x * d * d)])
    C = np.array(C)
    for _ in range(30):
        lab = np.argmin(np.linalg.norm(P[:, None] - C[None], axis=2), axis=1)
        for k in range(n):
            if x[lab == k].sum() > 0:
                C[k] = (x[lab == k, None] * P[lab == k]).sum(axis=0) / x[lab == k].sum()
    lab = np.argmin(np.linalg.norm(P[:, None] - C[None], axis=2), axis=1)
    new = [_moved(prob, L, C[k], float(x[lab == k].sum())) for k, L in enumerate(members)]
    if any(q is None or not q.flux_scale > 0 for q in new):
        return None
    return [("dictionary", new)]


def regroup(prob, lights, cost, refit, trace=None):
    """Fluxes free: each group of close luminaires (:func:`close_groups`) refitted from
    other starts than its own arrangement, the rest of the room as it is: a regular
    polygon of equal luminaires (:func:`_polygon_starts`) and the non-negative least
    squares of a local dictionary (:func:`_dictionary_start`); each start refitted jointly
    with every luminaire (``refit(lights) -> (lights, cost)``), the lowest cost kept.
    The count stays (the count search chose it).

    Why: close luminaires with free fluxes lie in a long, rough valley (flux moves between
    them as they move) with several minima; the split-and-refit search ends in the one
    its splits lead to. Measured on bench_count's cluster4_0.3h (four 2500 lm 0.9 m apart
    at 3 m, 5 % noise, every vertex of a 0.2 m mesh): the search's answer costs 0.0010816,
    refitted from the true arrangement 0.0010743; from the polygon starts 0.0010742 (max
    error 76.7 -> 27 % in flux, 42 -> 35 cm, as far as the truth's own refit). In
    locate (bench_count --diagnose, flux unknown, 5 % noise, 0.2 m): the found answer's
    cost above the truth's refit, in noise variances, 15 -> 0.8 (cluster4), 40 -> 2.3
    (array16_0.8h: its inner four, 51-82 cm -> 21-38 cm off, sd 12 cm), 5 -> 1.6
    (cluster3_mixed, 169 -> 42 % in flux); each luminaire within 0.5 m in 7 of 7 scenes
    (4 before); rooms without such groups keep their answer.
    """
    if not prob.free_flux or len(lights) < 2:
        return lights, cost
    for _pass in range(REGROUP_PASSES):
        got = _regroup_pass(prob, lights, cost, refit, trace)
        if got is None:
            break
        lights, cost = got
    return lights, cost


#: :func:`regroup`: at most this many accepted changes (a changed group can leave another,
#: or itself, in a new valley; the groups are found again after each)
REGROUP_PASSES = 3


def _regroup_pass(prob, lights, cost, refit, trace):
    """One pass of :func:`regroup` over the groups; (lights, cost) if any changed."""
    changed = False
    for group in close_groups(prob, lights):
        members = [lights[i] for i in group]
        others = [L for k, L in enumerate(lights) if k not in group]
        fixed = prob.fixed_light(others) if others else np.zeros(len(prob.target))
        starts = _polygon_starts(prob, members) + (
            _dictionary_start(prob, members, fixed) or [])
        best = None
        for what, new in starts:
            got, c = refit(others + [prob.with_indirect(q) for q in new])
            if trace is not None:
                trace.append({"regroup": what, "group": len(group), "cost_before": cost,
                              "cost_after": c})
            if c < cost and (best is None or c < best[1]):
                best = (got, c)
        if best is not None:
            (lights, cost), changed = best, True
            break      # the indices of the other groups are those of the old list
    return (lights, cost) if changed else None
