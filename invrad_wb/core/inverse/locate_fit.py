"""The search of one room's luminaires from its peaks (:class:`_RoomFit`: greedy selection,
swaps, residual and grid seeds, spreading crowded pairs) and the post-processing that
runs it (:func:`_postprocess`)."""
import time

import numpy as np

from invrad_wb import constants as C

from invrad_wb.core.inverse.peaks import find_peaks
from invrad_wb.core.inverse.refine import LOG_SCALE_LIMIT, Light
from invrad_wb.core.inverse.select import greedy_select, joint_swap, swap_search
from invrad_wb.core.inverse.locate_placement import (_light_from_peak, _prefer_mounted,
                                                     _snap_to_surfaces)
from invrad_wb.core.inverse.locate_problem import FREE_FLUX_MIN_GAIN_TOTAL, _ladder_peaks


def _postprocess(run, s, flux, progress=None, deadline=None, allow_votes=True):
    """Peaks of one room's votes, then (``s.refine``) the joint refinement.

    Sets ``run.peaks``, ``run.lights``, ``run.cost`` and ``run.trace``. ``allow_votes``:
    whether the overlap step may vote again (False when post-processing is redone).
    """
    if run.free_flux:
        peaks = _ladder_peaks(run, s)
    else:
        peaks, _ = find_peaks(run.canvas, run.votes, threshold=s.threshold,
                              neighbourhood=s.neighbourhood_m, max_peaks=s.max_candidates)
    run.peaks = peaks
    if not s.refine:
        run.lights = [_light_from_peak(p, run.canvas) for p in peaks]
        for L in run.lights:
            L.score = L.peak_score / 255.0
        return
    fit = _RoomFit(run, s)
    # CPU seconds of this process: the same room stops at the same point on a busy machine
    t_start = time.process_time()
    run.stopped_after_s = None

    def unexplained(lights):
        """Past the time bound with a poor fit: the further searches are skipped."""
        if run.stopped_after_s is not None:
            return True
        spent = time.process_time() - t_start
        if spent > C.LOCATE_UNEXPLAINED_LIMIT_S and fit_quality(fit.prob, lights) > s.poor_fit:
            run.stopped_after_s = round(spent, 1)
            fit.trace.append({"stopped": "time bound on a poor fit", "seconds": spent})
            return True
        return False
    cands = [_light_from_peak(p, run.canvas, flux) for p in peaks]
    if s.aim == "free":
        from invrad_wb.core.inverse.aim import aimed_candidates
        cands = aimed_candidates(run, s, cands)
    lights, cost = fit.select(cands, progress, deadline)
    # aimed beams that overlap (a wall wash): a second global search, the footprint
    # candidates found one after another beside those found before, where the fit is poor
    # (fluxes free: unless the fit is near-exact; light traded between overlapping beams
    # leaves a fit that is not poor, but wrong: measured on bench_aim's free-flux lobby
    # --seed 5, the first selection's two merged footprints and a wall light where two
    # beams overlap, mean absolute log deviation 0.044; the pursuit's 0.018, then 5/5)
    if (s.aim == "free" and fit_quality(fit.prob, lights) > (
            NEAR_EXACT_FIT if run.free_flux else s.poor_fit) and not unexplained(lights)):
        lights, cost = fit.pursuit(lights, cost, cands)
    # light that several luminaires share: vote again with a fraction of each point's
    # light (thesis 5.2) and offer those peaks too
    if (run.vote_fn is not None and s.overlap_levels > 1 and not run.free_flux
            and fit_quality(fit.prob, lights) > s.poor_fit and not unexplained(lights)):
        lights, cost = fit.overlap(lights, cost, cands, allow_votes)
    # fluxes free: a weak luminaire beside a strong one may have no clear peak on any
    # rung while the strong one's light is in the votes; vote again with what the
    # accepted luminaires leave unexplained
    # (--aim free: not when the cost is already below what a luminaire must remove to be
    # kept, FREE_FLUX_MIN_GAIN_TOTAL of the empty room's: the selection could add none of
    # the new peaks; measured on bench_aim's free-flux rooms, 3-5 CPU s and 7 vote casts
    # each that never changed the answer)
    if (run.free_flux and run.vote_fn is not None and allow_votes and lights
            and not (s.aim == "free" and cost <= FREE_FLUX_MIN_GAIN_TOTAL * fit.prob.cost([]))
            and not unexplained(lights)):
        lights, cost = fit.residual(lights, cost, cands)
    # still poor: light spread evenly by many luminaires (a uniform work plane) has no
    # accumulation points at all; seed the refinement with regular arrangements of n
    # luminaires on the ceiling and keep the best refined answer
    if (s.overlap_levels > 1 and fit_quality(fit.prob, lights) > s.poor_fit
            and not unexplained(lights)):
        lights, cost = fit.grid(lights, cost, cands, flux)
    # aimed beams that overlap (a wall wash) leave hot spots between the true axes: seed
    # again from the light the accepted luminaires leave unexplained
    if s.aim == "free" and lights and cost > 1e-3 * fit.prob.cost([]):
        lights, cost = fit.aim_residual(lights, cost, cands)
    if run.seeds:
        lights, cost = fit.seeded(lights, cost, cands, run.seeds)
    # fluxes free: split, merge and remove luminaires while the data's noise level says
    # they need it (close clusters, even arrays, luminaires that only fit the noise)
    if run.free_flux and lights and not unexplained(lights):
        from invrad_wb.core.inverse.locate_count import CountSearch
        if s.aim == "free":
            from invrad_wb.core.inverse.aim import AimedCountSearch as CountSearch
        search = CountSearch(fit, deadline)
        lights, cost = search.run(lights, cost)
        # aimed luminaires that share a footprint, however far apart: one in their place
        if s.aim == "free" and not unexplained(lights):
            from invrad_wb.core.inverse.aim import footprint_merge
            lights, cost = footprint_merge(fit, search, lights, cost)
    # targets per vertex: a last refit on every target vertex of the room, not only the
    # voting points (each vertex is a measurement of its own: more data, less noise)
    lights, cost = fit.polish(lights, cost)
    lights, cost = fit.spread(lights, cost)
    # final scores: how much worse the fit is without each luminaire
    prob = fit.prob
    cost = prob.cost(lights) if lights else cost
    for i, L in enumerate(lights):
        c_rest = prob.cost(lights[:i] + lights[i + 1:])
        L.score = float((c_rest - cost) / max(c_rest, 1e-12))
    run.lights, run.cost, run.trace = lights, cost, fit.trace
    from invrad_wb.core.inverse.fitcheck import room_fit
    run.fit = room_fit(prob, lights)          # relative RMS, share within 20 % (no render)


#: a footprint pursuit candidate this close to a luminaire found (metres), aimed within
#: this many degrees of it, proposes nothing new (:meth:`_RoomFit.pursuit`)
PURSUIT_SAME_M = 0.25
PURSUIT_SAME_DEG = 10.0


class _RoomFit:
    """The refinement steps of one room; they share its problem, optimiser and trace.

    Each step takes and returns ``(lights, cost)``: a list of :class:`Light` and the
    refinement cost (:meth:`RefineProblem.cost`, dimensionless).
    """

    def __init__(self, run, s):
        self.run, self.s, self.prob = run, s, run.problem
        self.opt = (self.prob.levenberg_marquardt if s.optimiser == "lm"
                    else self.prob.evolution_strategy)
        self.trace = []
        # the count search's best split turned down on its points (locate_count.split)
        self.rejected_split = None

    def _greedy(self, cands, **kwargs):
        if self.prob.free_flux and self.s.aim == "free":
            # aimed luminaires keep the former floor of the empty room's cost (not measured
            # there without it); otherwise, fluxes free or given, a luminaire is judged
            # against the data's noise alone (select.greedy_select: min_gain of the current
            # cost and BIC, both costs held at least the model floor)
            kwargs.setdefault("min_gain_total", FREE_FLUX_MIN_GAIN_TOTAL)
        return greedy_select(self.prob, cands, min_gain=self.s.min_gain,
                             optimiser=self.s.optimiser, **kwargs)

    def select(self, cands, progress=None, deadline=None):
        """Greedy selection from the peak candidates, swaps when the fit is not near-exact,
        then each luminaire's own interreflection (:meth:`settle`)."""
        prob, s = self.prob, self.s
        lights, cost, self.trace = self._greedy(cands, progress=progress, deadline=deadline)
        cost0 = prob.cost([])
        lights, cost = self.tidy(lights, cost)
        # each luminaire's own interreflected light from the radiosity model replaces its
        # estimate; refit, look for missing/surplus luminaires, until nothing moves
        lights, cost = self.settle(lights, cost, cands)
        # judged with the exact interreflection (the estimate's error alone kept the
        # office example above the bar: 40 swap refits, none kept, half its time)
        if lights and cost > 1e-3 * cost0:
            # not the near-exact fit a set of the right luminaires gives: try swaps
            lights, cost, nswap = swap_search(prob, lights, cands, min_gain=s.min_gain,
                                              optimiser=s.optimiser, screen=s.aim == "free",
                                              deadline=deadline)
            self.trace.append({"swaps": nswap, "cost_after": cost})
            if nswap:
                # swapped luminaires may have made others redundant (or two may coincide)
                lights, cost, t2 = self._greedy([], initial=lights)
                self.trace += t2
                lights, cost = self.tidy(lights, cost)
                lights, cost = self.settle(lights, cost, cands)
        return lights, cost

    def tidy(self, lights, cost):
        """Snap mid-air luminaires to surfaces, prefer mounted ones, refit if any moved."""
        lights = _snap_to_surfaces(lights, self.run.canvas, self.run.scene)
        if any(L.kind == "free" for L in lights):
            lights = _prefer_mounted(self.prob, lights, self.run.canvas, self.s.optimiser)
            lights, cost = self.opt(lights)
        return lights, cost

    def converge(self, lights, cost, rounds=8):
        """Refit until every luminaire's interreflection was computed where it now is."""
        prob = self.prob
        for _round in range(rounds):
            lights, changed = prob.refresh_indirect(lights, moved=0.005)
            if not changed:
                return lights, cost
            lights, cost = self.opt(lights)
        # out of rounds: make the indirect light exact for the final positions anyway
        lights, _ = prob.refresh_indirect(lights, moved=0.0)
        return lights, prob.cost(lights)

    def settle(self, lights, cost, cands):
        """Exact interreflection for the luminaires, with re-selection from ``cands``."""
        for _round in range(2):
            lights, changed = self.prob.refresh_indirect(lights, moved=0.005)
            if not changed:
                break
            lights, cost = self.opt(lights)
            lights, cost, t2 = self._greedy(cands, initial=lights)
            self.trace += t2
            lights, cost = self.tidy(lights, cost)
        return self.converge(lights, cost)

    def overlap(self, lights, cost, cands, allow_votes):
        """Candidates from votes as if 2, 3 ... luminaires shared each point's light; a
        fresh selection over all candidates, kept if better."""
        run, s = self.run, self.s
        extra = []
        for share in range(2, s.overlap_levels + 1):
            if share not in run.extra_votes:
                if not allow_votes:
                    continue   # post-processing again never votes again
                run.extra_votes[share] = run.vote_fn(share)
            pk, _ = find_peaks(run.canvas, run.extra_votes[share], threshold=s.threshold,
                               neighbourhood=s.neighbourhood_m, max_peaks=s.max_candidates)
            extra += pk
        extra.sort(key=lambda p: -p.score)
        more = [_light_from_peak(p, run.canvas) for p in extra]
        # a fresh selection over all candidates (the first may be a local optimum that
        # adding luminaires cannot leave)
        return self._reselect(lights, cost, more, cands, "overlap_votes",
                              patience=2 * s.overlap_levels + 10)

    def _reselect(self, lights, cost, more, cands, what, **greedy):
        """A selection over ``more + cands`` (``greedy``: its options), tidied and settled;
        the better of it and (``lights``, ``cost``), traced under ``what``."""
        alt, c_alt, t2 = self._greedy(more + cands, **greedy)
        alt, c_alt = self.tidy(alt, c_alt)
        alt, c_alt = self.settle(alt, c_alt, more + cands)
        self.trace += [{what: len(more), "cost_before": cost, "cost_after": c_alt}] + t2
        if c_alt < cost:
            return alt, c_alt
        return lights, cost

    def residual(self, lights, cost, cands, significant=0.2):
        """Free-flux ladder votes with each point's light that ``lights`` do not explain
        (where that is more than ``significant`` of its target); their peaks join the
        candidates of a selection that starts from ``lights``; kept if better."""
        run, s, prob = self.run, self.s, self.prob
        target = prob.target          # the refinement's targets (at the points' corners)
        rest = target - prob.fixed_light(lights)
        lux = np.where((target > 0) & (rest > significant * target), rest, 0.0)
        if not np.any(lux > 0):
            return lights, cost
        ladder = {f: run.vote_fn(f / run.flux, lux=lux) for f in run.ladder_votes}
        more = [_light_from_peak(p, run.canvas, run.flux)
                for p in _ladder_peaks(run, s, ladder)]
        return self._reselect(lights, cost, more, cands, "residual_votes", initial=lights)

    def pursuit(self, lights, cost, cands):
        """``--aim free``, the first selection's fit poor: a fresh selection with the
        footprint pursuit's candidates (:func:`invrad_wb.core.inverse.aim.
        footprint_pursuit`) first, in the order found, then ``cands``; kept if better.

        Not the first search: where wide beams overlap (the bench shop's flood spots on
        two tables) the pursuit's first pick is a beam between them that covers both, and
        the selection from it ends worse than the one from the lone-scored candidates
        (measured: 2 of 4 found, 2 spurious, where the lone-scored list finds all 4)."""
        from invrad_wb.core.inverse.aim import footprint_pursuit
        more = footprint_pursuit(self.run, self.s)
        # nothing new: every candidate is at a luminaire found, aimed about as it is (a
        # selection from them would start where the first one ended)
        if not more or all(any(np.linalg.norm(M.position - L.position) < PURSUIT_SAME_M
                               and M.normal @ L.normal > np.cos(np.radians(PURSUIT_SAME_DEG))
                               for L in lights) for M in more):
            self.trace.append({"footprint_pursuit": len(more), "new": 0})
            return lights, cost
        return self._reselect(lights, cost, more, cands, "footprint_pursuit")

    def aim_residual(self, lights, cost, cands, significant=0.2, tries=2, max_evals=24,
                     spots=4):
        """``--aim free``, the fit not near-exact: re-seed each luminaire from what the
        others leave unexplained. Least needed first, luminaire i is taken out; the hot
        spots (the ``spots`` brightest) of the light the rest leave unexplained where i
        lit (both more than ``significant`` of a point's target) give footprint
        candidates scored beside the rest (:func:`invrad_wb.core.inverse.aim.
        footprint_candidates`: a global search over apexes and aim points, not a local
        move); of the best ``tries``, those that score better than luminaire i where it
        stands are refined alone beside the rest, and one that then lowers the cost is
        refined jointly with them and replaces i if the cost falls by ``min_gain``.
        Overlapping beams (a wall wash) put the first hot spots between the true axes;
        with a neighbour's light fixed, the one left shows where its own beam is. After a
        replacement: a selection from the candidates (a luminaire now missing or
        redundant) and the interreflection settled."""
        from invrad_wb.core.inverse.aim import footprint_candidates, lone_score
        run, prob, s = self.run, self.prob, self.s
        pts = run.points
        evals = swaps = 0
        improved = True
        while improved and evals < max_evals:
            improved = False
            order = sorted(range(len(lights)), key=lambda i: lights[i].score or 0.0)
            for i in order:
                rest = lights[:i] + lights[i + 1:]
                light = prob.fixed_light(rest)
                left = pts.lux - prob.indirect - light
                # where luminaire i lit: its light, not the others', is re-seeded
                own = prob.fixed_light(lights[i:i + 1])
                lux = np.where((pts.lux > 0) & (left > significant * pts.lux)
                               & (own > significant * pts.lux), left, 0.0)
                if not np.any(lux > 0):
                    continue
                # a candidate is refined only if, scored alone beside the rest, it explains
                # more than luminaire i where it stands (cheap: no refinement, no
                # interreflection; the right luminaire beats its re-seeds)
                mine = lone_score(run, lights[i], light)
                for cand in footprint_candidates(run, s, lux=lux, light=light,
                                                 most=spots)[:tries]:
                    if evals >= max_evals:
                        break
                    if not cand.peak_score > mine:
                        continue
                    evals += 1
                    alone, c1 = self.opt([prob.with_indirect(cand)], fixed=light)
                    if not c1 < cost:
                        continue
                    kept = joint_swap(self.opt, rest + alone, cost, s.min_gain)
                    if kept is not None:
                        (lights, cost), swaps, improved = kept, swaps + 1, True
                        break
                if improved:
                    break
        self.trace.append({"aim_residual_swaps": swaps, "evals": evals, "cost_after": cost})
        if swaps:
            lights, cost, t2 = self._greedy(cands, initial=lights)
            self.trace += t2
            lights, cost = self.tidy(lights, cost)
            lights, cost = self.settle(lights, cost, cands)
            for i, L in enumerate(lights):
                c_rest = prob.cost(lights[:i] + lights[i + 1:])
                L.score = float((c_rest - cost) / max(c_rest, 1e-12))
        return lights, cost

    def grid(self, lights, cost, cands, flux):
        """Regular ceiling arrangements of n luminaires of ``flux`` lm as seeds; the best
        refined arrangement (with vote candidates added) is kept if better."""
        prob = self.prob
        scanned = []
        for n in _seed_counts(self.run, flux):
            seeds = _grid_seeds(self.run.canvas, n)
            if not seeds:
                continue
            if self.run.free_flux:
                # start from the lumen-method share of one of n luminaires
                for L in seeds:
                    L.flux_scale = float(np.clip(_flux_need(self.run) / (n * flux),
                                                 np.exp(-LOG_SCALE_LIMIT),
                                                 np.exp(LOG_SCALE_LIMIT)))
            seeds = [prob.with_indirect(L) for L in seeds]
            got, c = self.opt(seeds)
            self.trace.append({"grid_seed": n, "cost_after": c})
            scanned.append((c, n, got))
            if c > 1.5 * min(x[0] for x in scanned):
                break   # past the best count
        best = None
        # the scan used estimated interreflection: settle the three best counts exactly
        for c, n, got in sorted(scanned, key=lambda x: x[0])[:3]:
            got, c = self.converge(got, c)
            self.trace.append({"grid_seed_exact": n, "cost_after": c})
            if best is None or c < best[1]:
                best = (got, c)
        if best is None:
            return lights, cost
        # no pruning of the best arrangement: for evenly spread light every luminaire of
        # it does its share; the same with vote candidates added / surplus ones pruned
        alt, c_alt = best
        alt2, c_alt2 = self.settle(alt, c_alt, cands)
        if c_alt2 < c_alt:
            alt, c_alt = alt2, c_alt2
        if c_alt < cost:
            return alt, c_alt
        return lights, cost

    def seeded(self, lights, cost, cands, seeds):
        """Start from given luminaires (:class:`Luminaire`, in the room's frame) as well:
        snapped to the room's surfaces (pendants stay in mid-air; others off every
        surface are dropped), refined, pruned or added to from ``cands``, settled; kept
        if better than (``lights``, ``cost``)."""
        start = []
        for lum in seeds:
            n = np.asarray(lum.normal, dtype=np.float64)
            L = Light(kind="free", position=np.asarray(lum.position, np.float64).copy(),
                      normal=n / np.linalg.norm(n), map_index=-1,
                      flux_scale=float(lum.flux_lm) / self.run.flux if self.run.flux else 1.0)
            L = _snap_to_surfaces([L], self.run.canvas, self.run.scene)[0]
            if L.kind == "surface" or (getattr(lum, "extra", None) or {}).get("mount") == "pendant":
                start.append(self.prob.with_indirect(L))
        if not start:
            return lights, cost
        got, c = self.opt(start)
        alt, c_alt, t2 = self._greedy(cands, initial=got)
        alt, c_alt = self.tidy(alt, c_alt)
        alt, c_alt = self.settle(alt, c_alt, cands)
        self.trace += [{"seeded": len(start), "of": len(seeds), "cost_before": cost,
                        "cost_after": c_alt}] + t2
        if c_alt < cost:
            return alt, c_alt
        return lights, cost

    def polish(self, lights, cost, rounds=4):
        """With targets per vertex, a last joint refit of ``lights`` on every target vertex
        of the room (:func:`~invrad_wb.core.inverse.locate_problem.vertex_points`), with
        the same settings, interreflection model and allowed region; the refitted lights
        are brought back to the room's problem (their interreflection there) and returned
        with its cost. Skipped when the room's points already are as many, for a poor fit
        (``s.poor_fit``: the luminaires do not explain the targets; more of them does not
        help) and for ``--aim free`` (not measured there). Fluxes free, groups of close
        or poorly pinned luminaires are then refitted from other starts
        (:func:`~invrad_wb.core.inverse.locate_count.regroup`). The points are at most
        :data:`~invrad_wb.core.inverse.locate_problem.VERTEX_POINTS_MAX` vertices (an
        even subset); a room with more is refitted once more on every one of them
        (:meth:`polish_every_vertex`, streamed in chunks). Fluxes free, the fluxes the
        data cannot tell apart are then tied, one per kind of luminaire
        (:mod:`~invrad_wb.core.inverse.locate_ties`), on the last refit's points: every
        vertex, the subset, or the room's own problem (:meth:`tie`). In such a room each
        luminaire's interreflection follows its position to first order in these refits
        (:attr:`~invrad_wb.core.inverse.refine.RefineProblem.indirect_gradient`): held
        between refreshes, the refit stopped off the likelihood's minimum (bench/
        bench_count.py, 2026-11-26 (h11): cluster4 at 0.019 m 11.3 -> 2.2 cm).

        Measured (bench/bench_count.py scenes, 5 % noise per vertex, refitted from the
        true arrangement over 6 noise draws, voting points at their corners -> every
        vertex): RMS position error with free fluxes 8.3 -> 5.9 cm (twelve 4000 lm on a
        2.5 x 3 m grid), 20.3 -> 16.7 cm (sixteen at 0.8 x the mounting height), 21.3 ->
        18.9 cm (four at 0.3 x); with the flux given (points as they are -> every
        vertex) 2.7 -> 2.3, 7.5 -> 6.4, 14.8 -> 14.1 cm."""
        run, prob, s = self.run, self.prob, self.s
        if (not lights or run.remake is None or s.aim == "free" or run.stopped_after_s
                is not None or fit_quality(prob, lights) > s.poor_fit):
            return lights, cost
        from invrad_wb.core.inverse import locate_problem as lp
        _refine_problem = lp._refine_problem
        pts = lp.vertex_points(run.scene, most=lp.VERTEX_POINTS_MAX)   # read at call time
        if pts is None or len(pts) <= len(prob.target):
            return self.tie(prob, lights, cost)
        _s, backend, photometry, has_rho = run.remake
        big, big_indirect = _refine_problem(run.scene, pts, run.canvas, run.occluders, s,
                                            run.flux, backend, has_rho, {"radiosity": 0.0},
                                            photometry)
        big.free_flux = prob.free_flux
        # the interreflection's dependence on the positions in the last refit's model
        # (RefineProblem.indirect_gradient): its minimum is then the likelihood's. Only
        # where the room is refitted on every vertex afterwards (finely meshed targets,
        # more than the subset): there the bias of holding it dominates the noise
        # (cluster4 at 0.019 m 11.3 -> 2.2 cm); on rooms of at most the subset it gave
        # mixed results at 0.2 m (array9 8.9 -> 3.0 cm, array12_issue 15.6 -> 22.3,
        # array20 7.7 -> 9.6) and took the office example's fit from 0.14 to 0.45 cm
        # and its refinement 0.16 CPU s longer (bench_cli, 2026-11-26)
        big.indirect_gradient = lp.target_vertex_count(run.scene) > len(pts)
        # free fluxes of close luminaires lie in a long flat valley: the count search's steps
        opt = ((lambda L: big.levenberg_marquardt(L, iterations=100)) if s.optimiser == "lm"
               else big.evolution_strategy)

        def refit(got):
            for _round in range(rounds):
                got, _c = opt(got)
                got, changed = big.refresh_indirect(got, moved=0.005)
                if not changed:
                    break
            return got, big.cost(got)
        got = _rebase(big, lights)
        c_start = big.cost(got)
        got, c_got = refit(got)
        # the refit's own move (regroup reorders the luminaires)
        moved = max(float(np.linalg.norm(a.position - b.position)) for a, b in zip(lights, got))
        if big.free_flux:
            # close luminaires with free fluxes: other starts of each group (the count
            # search's split arrangement is one minimum of several), the lowest cost kept
            from invrad_wb.core.inverse.locate_count import regroup
            got, c_got = regroup(big, got, c_got, refit, self.trace)
        self.trace.append({"polish_points": len(pts), "cost_before": c_start,
                           "cost_after": big.cost(got),
                           "moved_m": round(moved, 4)})
        # more target vertices than that subset: the same refit on every one, streamed
        # (fluxes of one kind tied there); else the ties judged on the subset
        if s.optimiser == "lm":
            every = self.polish_every_vertex(big, big_indirect, pts, got, rounds)
            if every is got and big.free_flux:          # the subset is every vertex
                from invrad_wb.core.inverse.locate_ties import tie_fluxes
                every = tie_fluxes(big, got, lambda L: refit(L)[0], self.trace)
            got = every
        back = _rebase(prob, got)
        c_back = prob.cost(back)
        return back, c_back

    def polish_every_vertex(self, sub, sub_indirect, sub_pts, lights, rounds=4):
        """The last refit of :meth:`polish` (Levenberg-Marquardt, interreflection
        refreshed where a luminaire moved more than 5 mm, at most ``rounds`` times) on
        every target vertex of the room (at most :data:`~invrad_wb.core.inverse.
        locate_vertices.VERTICES_MAX`), streamed in chunks
        (:class:`~invrad_wb.core.inverse.locate_vertices.VertexProblem`), from
        ``lights``, the answer on the subset problem ``sub`` (its points ``sub_pts``):
        direct light exact at every vertex, each luminaire's interreflection gathered
        exactly at every vertex once, then its change interpolated from ``sub``'s points.
        Fluxes free, those the data cannot tell apart are then tied there
        (:mod:`~invrad_wb.core.inverse.locate_ties`). Returns the refitted lights (their
        interreflection at ``sub``'s points); ``lights`` itself where the room has no
        more vertices than ``sub``.

        Measured (bench/bench_count.py, 5 % noise per vertex, flux unknown): see its
        docstring, the rows of 2026-11-26 (h10)."""
        from invrad_wb.core.inverse import locate_problem as lp
        from invrad_wb.core.inverse import locate_vertices as lv
        if not lights:
            return lights
        every = lp.vertex_points(self.run.scene, most=lv.VERTICES_MAX)
        if every is None or len(every) <= len(sub_pts):
            return lights
        vp = lv.VertexProblem(every, sub, sub_pts.plane, indirect_model=sub_indirect)
        # the split the count check below judges, gathered in the same pass as these
        alt = (_rebase(sub, self.rejected_split)
               if sub.free_flux and self.rejected_split is not None else None)
        alt_exact = vp.exact_indirect(lights, *([alt] if alt is not None else []))
        c_start = vp.cost(lights)
        got = _streamed_refit(vp, lights, rounds)
        moved = max(float(np.linalg.norm(a.position - b.position))
                    for a, b in zip(lights, got))
        self.trace.append({"polish_vertices": len(every), "cost_before": c_start,
                           "cost_after": vp.cost(got), "moved_m": round(moved, 4)})
        if alt is not None:
            got = self.count_on_every_vertex(vp, sub, got, rounds, alt, alt_exact[0])
        if vp.free_flux:
            from invrad_wb.core.inverse.locate_ties import tie_fluxes
            got = tie_fluxes(vp, got, lambda L: _streamed_refit(vp, L, rounds), self.trace)
        return got

    def tie(self, prob, lights, cost):
        """Free fluxes the data cannot tell apart tied to one
        (:func:`~invrad_wb.core.inverse.locate_ties.tie_fluxes`) on the room's own
        problem ``prob``, refitted until each luminaire's interreflection is computed
        where it is (:meth:`converge`). Not for aimed luminaires (``--aim free``), the
        evolution strategy, a poor fit or a stopped room. Returns (lights, cost)."""
        s, run = self.s, self.run
        if (not prob.free_flux or len(lights) < 2 or s.aim == "free" or s.optimiser != "lm"
                or run.stopped_after_s is not None or fit_quality(prob, lights) > s.poor_fit):
            return lights, cost
        from invrad_wb.core.inverse.locate_ties import tie_fluxes

        def refit(L):
            return self.converge(*self.opt(L))[0]
        got = tie_fluxes(prob, lights, refit, self.trace)
        return (lights, cost) if got is lights else (got, prob.cost(got))

    def count_on_every_vertex(self, vp, sub, got, rounds, alt=None, alt_exact=None):
        """The count search's best split that its criterion turned down on the subset
        (``rejected_split``: one luminaire more, refitted there) judged again by the same
        criterion (:func:`~invrad_wb.core.inverse.locate_count.bic`) on every target
        vertex of the streamed problem ``vp``, both arrangements refitted there: kept when
        it is lower. The subset's criterion runs out of information first in dense arrays
        (array16_0.8h at a 0.07 m mesh: the 16th luminaire's split gained 3.8 on 20 000
        vertices; a 0.013 m mesh's subset turned it down, 15 of 16); each vertex is a
        measurement of its own, and the gain of a luminaire the data hold grows with
        them while the penalty grows as ln(vertices). ``alt``: the split rebased on
        ``sub`` (default: ``rejected_split``'s); ``alt_exact``: its interreflection at
        every vertex, gathered with ``got``'s start (:meth:`VertexProblem.exact_indirect`'s
        ``more``; None: a pass of its own). Returns ``got`` or the split."""
        from invrad_wb.core.inverse.locate_count import _params, bic_of, robust_mean_square
        k = int(np.sum(vp.target > 0)) or len(vp.target)

        def score(lights):
            return bic_of(robust_mean_square(vp.residuals(lights), vp.w_area),
                          _params(lights), k)
        b_got = score(got)                   # with got's exact interreflection (vp._exact)
        got_exact = vp._exact
        if alt is None:
            alt = _rebase(sub, self.rejected_split)
        if alt_exact is None:
            vp.exact_indirect(alt)
        else:
            vp.use_exact(alt_exact)
        alt = _streamed_refit(vp, alt, rounds)
        b_alt = score(alt)
        self.trace.append({"count_search": "every vertex", "lights": len(alt),
                           "bic_before": b_got, "bic_after": b_alt,
                           "kept": bool(b_alt < b_got)})
        if b_alt < b_got:
            return alt
        vp.use_exact(got_exact)              # got's again, for what follows on vp
        return got

    def spread(self, lights, cost):
        """Luminaires crowded in pairs moved apart where that costs the fit (almost)
        nothing: requirements (500 lx here, 300 lx beyond an open border) leave a flat
        cost on which the refinement can end with pairs half a metre apart, which read
        as doubled fixtures. Where two luminaires facing the same way are closer than
        :data:`SPREAD_TRIGGER` of the lumen-method spacing (:func:`_lumen_spacing`), the
        arrangement is refitted with the separation term reaching 1, 0.75 and 0.5
        spacings in turn; the first refit whose data cost (without the separation term)
        is within :data:`SPREAD_TOLERANCE` of the current one is kept. Not for a fit
        within :data:`NEAR_EXACT_FIT` (mean absolute log deviation): targets that a set of
        luminaires meets (nearly) exactly keep their answer.

        Measured on FZK-Haus' Kueche + Wohnen zone (1500 lm, 500 / 300 lx): pairs
        0.50 and 0.57 m apart; apart to 0.70 m for +0.5 % data cost, to 1.00 m for +2 %.
        """
        run, prob = self.run, self.prob
        if run.free_flux or len(lights) < 2 or fit_quality(prob, lights) <= NEAR_EXACT_FIT:
            return lights, cost       # a near-exact fit: its pairs are real
        gap = _closest_pair(lights)
        spacing = _lumen_spacing(run)
        if not (gap < SPREAD_TRIGGER * spacing):
            return lights, cost
        base = cost - prob.separation_cost(lights)
        keep = prob.separation_m
        for frac in (1.0, 0.75, 0.5):
            d0 = frac * spacing
            if d0 <= gap:
                break
            prob.separation_m = d0
            try:
                got, c = self.opt(lights)
                got, c = self.converge(got, c)
                data = c - prob.separation_cost(got)
            finally:
                prob.separation_m = keep
            self.trace.append({"spread_m": round(d0, 3), "closest_before": round(gap, 3),
                               "closest_after": round(_closest_pair(got), 3),
                               "data_cost_before": base, "data_cost_after": data})
            if data <= (1.0 + SPREAD_TOLERANCE) * base:
                return got, prob.cost(got)
        return lights, cost


#: :meth:`_RoomFit.spread`: pairs closer than this fraction of the lumen-method spacing
#: are looked at; a spread arrangement may cost this much more (relative data cost)
SPREAD_TRIGGER = 0.5


SPREAD_TOLERANCE = 0.03


#: a fit closer than this (mean absolute log deviation, :func:`fit_quality`) to its
#: targets is taken as exact: rendered targets of real luminaires (bench_random: at most
#: 0.013 in direct light; with interreflection 14 of 20 scenes below 0.003 and 6 above
#: 0.02, as many as it gets wrong), not requirements (FZK-Haus' Kueche + Wohnen zone: 0.060)
NEAR_EXACT_FIT = 0.02


def _streamed_refit(vp, lights, rounds):
    """The last refit on every vertex (a VertexProblem ``vp``): Levenberg-Marquardt, then
    the interreflection refreshed where a luminaire moved more than 5 mm, at most
    ``rounds`` times."""
    for _round in range(rounds):
        lights, _c = vp.levenberg_marquardt(lights, iterations=100)
        lights, changed = vp.refresh_indirect(lights, moved=0.005)
        if not changed:
            break
    return lights


def _rebase(prob, lights):
    """Copies of ``lights`` with their interreflection at ``prob``'s points (exact where
    it has a radiosity model, else its estimate)."""
    out = []
    for L in lights:
        L = L.copy()
        L.indirect = L.indirect_at = L.indirect_grad = None
        out.append(L)
    if prob.indirect_exact is not None:
        return prob.refresh_indirect(out, moved=0.0)[0]
    return [prob.with_indirect(L) for L in out]


def _closest_pair(lights):
    """Smallest distance (m) between two luminaires facing the same way (inf if none)."""
    best = np.inf
    for i in range(len(lights)):
        for j in range(i + 1, len(lights)):
            if lights[i].normal @ lights[j].normal >= 0.5:
                best = min(best, float(np.linalg.norm(lights[i].position
                                                      - lights[j].position)))
    return best


def _lumen_spacing(run):
    """The spacing (m) of a regular grid of luminaires of the room's flux that gives its
    mean positive target by the lumen method: sqrt(flux x 0.5 / E)."""
    pts = run.points
    lit = np.isfinite(pts.lux) & (pts.lux > 0)
    if not lit.any():
        return 0.0
    e = float(np.sum(pts.lux[lit] * pts.area[lit]) / np.sum(pts.area[lit]))
    return float(np.sqrt(0.5 * run.flux / e))


def _seed_counts(run, flux, most=24):
    """Luminaire counts to try as regular arrangements, around the lumen-method estimate.

    The flux the targets need, sum(E * A) over the targeted points, divided by the flux of
    one luminaire and a utilisation factor of 0.5, gives an estimate n0; counts from 1 to
    2 n0 + 2 are tried (at most ``most``).
    """
    n0 = _flux_need(run) / flux
    if run.free_flux:
        n0 = 12        # any count may do: the fit sets each luminaire's flux
    top = int(min(most, max(2, np.ceil(2 * n0 + 2))))
    return list(range(1, top + 1))


def _grid_seeds(canvas, n):
    """n luminaires in a regular grid over the room's footprint, on the ceiling above.

    The grid covers the bounding box of the footprint (cells of the room's aspect ratio);
    each grid point gets the lowest ceiling-like surface (normal pointing down) above it,
    so sloped and stepped ceilings work. Grid points outside the footprint are dropped.
    """
    g = canvas.grid
    ceil = [k for k, m in enumerate(canvas.maps) if m.kind == "surface" and m.normal[2] < -0.3]
    if g is None or not ceil:
        return []
    ii, jj = np.nonzero(g.footprint & np.isfinite(g.ceiling_z))
    if len(ii) == 0:
        return []
    x0, x1 = g.origin[0] + ii.min() * g.pixel, g.origin[0] + (ii.max() + 1) * g.pixel
    y0, y1 = g.origin[1] + jj.min() * g.pixel, g.origin[1] + (jj.max() + 1) * g.pixel
    aspect = (x1 - x0) / max(y1 - y0, 1e-9)
    nx = max(1, int(round(np.sqrt(n * aspect))))
    ny = int(np.ceil(n / nx))
    out = []
    for a in range(nx):
        for b in range(ny):
            if len(out) >= n:
                break
            x = x0 + (a + 0.5) * (x1 - x0) / nx
            y = y0 + (b + 0.5) * (y1 - y0) / ny
            best = None
            for k in ceil:
                m = canvas.maps[k]
                z = -(m.normal[0] * x + m.normal[1] * y + m.offset) / m.normal[2]
                p = np.array([x, y, z])
                if canvas.map_contains(k, p) and (best is None or z < best[1][2]):
                    best = (k, p)
            if best is None:
                continue
            k, p = best
            m = canvas.maps[k]
            out.append(Light(kind="surface", position=p, normal=m.normal.copy(), map_index=k,
                             plane=m.plane, origin=m.origin.copy(), u=m.u.copy(),
                             v=m.v.copy()))
    return out


def fit_quality(prob, lights):
    """Area-weighted mean absolute log deviation of the prediction from the targets."""
    vis = [prob.visibility(L) for L in lights]
    r, _ = prob.residuals(lights, vis)
    return float(np.sum(prob.w_area * np.abs(r)))


def _flux_need(run):
    """Lamp lumens the room's targets need by the lumen method: sum(E * A) over the targeted
    points over a utilisation factor of 0.5."""
    pts = run.points
    return float(np.sum(np.nan_to_num(pts.lux) * pts.area)) / 0.5
