"""Greedy selection of luminaires from candidates, their pruning and swaps, on a
:class:`~invrad_wb.core.inverse.refine.RefineProblem` (moved out of refine.py, which
keeps the forward model and the optimisers).

A luminaire is kept when it lowers the cost by a clear share of the current cost, the
cost held at least the forward model's own floor (:data:`MODEL_FLOOR`): see
:func:`greedy_select`.
"""
import time

import numpy as np

from invrad_wb.errors import Cancelled, SettingsError


#: the smallest root-mean-square log residual a fit's gain is measured against (0.3 %):
#: below it the misfit is the forward model's own (targets interpolated between vertices,
#: the radiosity patches), not light a further luminaire should explain (measured: four
#: 2500 lm downlights 0.9 m apart, rendered with interreflection, no noise: the true
#: arrangement leaves 0.29 %). The count search's criterion uses it too.
MODEL_FLOOR = 0.003


def floor_cost(problem):
    """The refinement cost (:meth:`RefineProblem.cost_of`) of a log residual of
    :data:`MODEL_FLOOR` at every point."""
    return problem.cost_of(np.full(1, MODEL_FLOOR))


def bic_share(k, p):
    """The share of its cost a fit must lose for ``p`` more parameters to lower the
    Bayesian information criterion ``k ln(m) + p ln(k)`` of ``k`` points (m: the mean
    square residual, proportional to the cost for residuals below the robust scale)."""
    k = max(int(k), 2)
    return 1.0 - np.exp(-p * np.log(k) / k)


def _light_params(problem, L):
    """``problem``'s fitted parameters of one luminaire (its position; its aim and flux
    where they are free)."""
    aim = problem.free_aim and L.mount is not None
    return L._npos() + (2 if aim else 0) + (1 if problem.free_flux else 0)


def greedy_select(problem, candidates, min_gain=0.05, min_gain_total=0.0, max_lights=64,
                  merge_distance=0.25, optimiser="lm", patience=10, progress=None,
                  deadline=None, initial=None):
    """Add candidates best first while they clearly lower the cost; then prune.

    Each candidate is first optimised alone with the accepted luminaires held in place; only
    if that already lowers the cost enough are all luminaires refined jointly and the
    candidate kept.

    The test of a luminaire is tied to the data's noise level, not to the cost of the room
    without luminaires: it must lower the cost by ``min_gain`` of the current cost (and by
    more than the Bayesian information criterion asks for its parameters, which only
    binds for a few hundred points), both costs held at least :func:`floor_cost` (the
    forward model's own error is not light to explain). With noisy targets the current
    cost is at least the noise's, and a luminaire fitted to noise alone lowers it by
    about p / k of it (p parameters, k points: 0.1 % for 3000 points), 50 times less than
    ``min_gain``; a luminaire that explains light lowers it by far more (measured: the
    missing one of sixteen 2500 lm downlights, 5 % noise, by 30 %). The former floor, 0.5
    % of the cost without any luminaire (about the cost of a 6 % residual everywhere),
    rejected that one.

    Parameters
    ----------
    problem : RefineProblem
    candidates : list of Light (best first)
    min_gain : float
        A candidate is kept if it lowers the cost by at least this fraction of the current
        cost (see above) and by ``min_gain_total`` of the cost without any luminaire (0 by
        default); a luminaire is pruned if removing it raises the cost by less than these.
    merge_distance : float, metres
        Candidates this close to an accepted luminaire facing the same way are skipped.
    patience : int
        Stop after this many candidates in a row were rejected.
    initial : list of Light, optional
        Luminaires already accepted (e.g. from an earlier round).

    Returns
    -------
    lights : list of Light, with ``score`` = relative cost increase without it
    cost : float
    trace : list of dict (what happened to each candidate)
    """
    if optimiser not in ("lm", "es"):
        raise SettingsError(f"optimiser must be 'lm' or 'es', got {optimiser!r}")
    opt = problem.levenberg_marquardt if optimiser == "lm" else problem.evolution_strategy
    cost0 = problem.cost([])
    lights = [L.copy() for L in (initial or [])]
    cost = problem.cost(lights) if lights else cost0
    trace = []
    misses = 0

    floor = floor_cost(problem)
    k_lit = int(np.sum(problem.target > 0)) or len(problem.target)

    def enough(before, after, light):
        b, a = max(before, floor), max(after, floor)
        share = max(min_gain, bic_share(k_lit, _light_params(problem, light)))
        return a < b * (1.0 - share) and before - after > min_gain_total * cost0

    for ci, cand in enumerate(candidates):
        if progress is not None and progress(ci / max(len(candidates), 1)) is False:
            raise Cancelled("cancelled during refinement")
        if len(lights) >= max_lights or cost < 1e-4 * cost0 or misses >= patience:
            break
        if deadline is not None and time.time() > deadline:
            trace.append({"candidate": ci, "result": "time limit"})
            break
        near = [L for L in lights if np.linalg.norm(L.position - cand.position) < merge_distance
                and L.facing() @ cand.facing() > 0.5]
        if near:
            trace.append({"candidate": ci, "result": "near accepted luminaire"})
            continue
        cand = problem.with_indirect(cand)
        fixed = problem.fixed_light(lights)
        alone, c_alone = opt([cand], fixed=fixed, iterations=12)
        # with fluxes free, the others' fluxes may have grown to make up for this one's
        # light: a candidate that helps at all alone gets the joint refit too
        if not enough(cost, c_alone, cand) and not (problem.free_flux and c_alone < cost):
            misses += 1
            trace.append({"candidate": ci, "result": "rejected", "cost_before": cost,
                          "cost_after": c_alone})
            continue
        trial, c_trial = opt(lights + alone)
        if enough(cost, c_trial, cand):
            misses = 0
            trace.append({"candidate": ci, "result": "kept", "cost_before": cost,
                          "cost_after": c_trial})
            lights, cost = trial, c_trial
        else:
            misses += 1
            trace.append({"candidate": ci, "result": "rejected", "cost_before": cost,
                          "cost_after": c_trial})
    lights, cost = _prune(problem, lights, cost, opt, enough, max(min_gain_total * cost0, floor),
                          trace)
    _score(problem, lights, cost)
    return lights, cost, trace


def _prune(problem, lights, cost, opt, enough, floor, trace):
    """Drop luminaires the cost does not need (a later one may have taken over their job);
    returns (lights, cost)."""
    changed = True
    while changed and len(lights) > 1:
        changed = False
        for i in range(len(lights)):
            rest = lights[:i] + lights[i + 1:]
            # clearly needed (removing it triples the cost): no refit of the others. Not
            # with fluxes free: the others' refitted fluxes may take over its light (a weak
            # ceiling light beside a wall light whose fitted flux was 5 % low: 10x the cost
            # without a refit, 30x lower with one)
            if not problem.free_flux and problem.cost(rest) > 3.0 * cost + floor:
                continue
            rest_opt, c_rest = opt(rest)
            if not enough(c_rest, cost, lights[i]):
                trace.append({"pruned": i, "cost_before": cost, "cost_after": c_rest})
                lights, cost = rest_opt, c_rest
                changed = True
                break
    return lights, cost


def _score(problem, lights, cost):
    """Each luminaire's score: the relative cost increase without it."""
    for i, L in enumerate(lights):
        rest = lights[:i] + lights[i + 1:]
        c_rest = problem.cost(rest)
        L.score = float((c_rest - cost) / max(c_rest, 1e-12))


def joint_swap(opt, trial, cost, min_gain):
    """A swap's acceptance: the set ``trial`` (the rest and a replacement) refined jointly
    by ``opt``; (lights, cost) when that lowers ``cost`` by more than the share
    ``min_gain``, else None."""
    lights, c = opt(trial)
    return (lights, c) if c < cost * (1.0 - min_gain) else None


def swap_search(problem, lights, candidates, min_gain=0.05, merge_distance=0.25, tries=8,
                max_evals=40, optimiser="lm", deadline=None, screen=False):
    """Escape a poor greedy answer: replace one luminaire by another candidate.

    Greedy selection cannot undo an early choice (a peak between two overlapping
    luminaires, a ceiling light where a pendant hangs). Each luminaire, least needed first,
    is replaced in turn by the best ``tries`` candidates that are not near another
    luminaire; all are refined jointly and the swap is kept if the cost drops by
    ``min_gain``. Stops after ``max_evals`` refinements.

    ``screen``: each candidate is first refined alone beside the others as they stand
    (their light fixed: a refinement of a few parameters); only one that then lowers the
    cost is refined jointly (``locate --aim free``, where every joint refinement fits
    position and aim of every luminaire). Each screen counts as a refinement.

    Returns
    -------
    lights, cost, swaps (number of swaps kept)
    """
    opt = problem.levenberg_marquardt if optimiser == "lm" else problem.evolution_strategy
    lights = [L.copy() for L in lights]
    cost = problem.cost(lights)
    evals = swaps = 0
    improved = True
    while improved and evals < max_evals:
        improved = False
        order = sorted(range(len(lights)), key=lambda i: lights[i].score)
        for i in order:
            rest = lights[:i] + lights[i + 1:]
            pool = [c for c in candidates
                    if not any(np.linalg.norm(L.position - c.position) < merge_distance
                               and L.facing() @ c.facing() > 0.5 for L in lights)]
            # alternatives near the luminaire first (a pendant under a ceiling light, the
            # other of two overlapping peaks), then the best-scoring elsewhere
            pool.sort(key=lambda c: np.linalg.norm(c.position - lights[i].position))
            dist = [np.linalg.norm(c.position - lights[i].position) for c in pool]
            near = [c for c, d in zip(pool, dist) if d < 1.5]
            far = [c for c, d in zip(pool, dist) if d >= 1.5]
            pool = near[:tries] + far[:tries // 2]
            fixed = None
            for cand in pool:
                if evals >= max_evals or (deadline is not None and time.time() > deadline):
                    return lights, cost, swaps
                evals += 1
                new = problem.with_indirect(cand)
                if screen:
                    if fixed is None:
                        fixed = problem.fixed_light(rest)
                    alone, c1 = opt([new], fixed=fixed)
                    if c1 >= cost:
                        continue
                    evals += 1
                    new = alone[0]
                kept = joint_swap(opt, rest + [new], cost, min_gain)
                if kept is not None:
                    (lights, cost), swaps, improved = kept, swaps + 1, True
                    break
            if improved:
                break
    for i, L in enumerate(lights):
        c_rest = problem.cost(lights[:i] + lights[i + 1:])
        L.score = float((c_rest - cost) / max(c_rest, 1e-12))
    return lights, cost, swaps
