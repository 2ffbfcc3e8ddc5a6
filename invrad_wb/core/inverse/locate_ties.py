"""Luminaires of one kind: free fluxes that the data cannot tell apart tied to one
(beyond the thesis).

With the flux unknown every luminaire has a flux parameter of its own. In a dense array or
a close cluster a luminaire's flux trades against its own position and its neighbours'
(more light here, the luminaire a little closer there): sixteen 2500 lm downlights at 0.8 x
the mounting height on a 0.2 m mesh with 5 % noise pin their positions to 17.4 cm (the
worst luminaire's Cramer-Rao sd) with free fluxes and to 8.5 cm with the flux given. Real
installations are mostly of one or a few kinds, and then the data say so: the fitted
fluxes agree within their noise. Here the fitted fluxes are grouped, the groups' fluxes
tied (one parameter each, :attr:`~invrad_wb.core.inverse.refine.Light.flux_group`), the
arrangement refitted, and the tied fit kept when the same criterion that chooses the
luminaire count (:func:`~invrad_wb.core.inverse.locate_count.bic_of`: the misfit in noise
variances plus ln(points) per parameter) prefers it. The sixteen's tied bound is that of
the flux given, 8.5 cm; their fluxes' sd 0.06 % instead of 10.7 %.

The groups: luminaires in the order of their fitted log flux, neighbouring groups merged,
the cheapest merge first, while a merge costs less than the criterion's ln(points) for
the parameter it saves. A merge's cost is the growth of the Wald statistic of the groups'
ties, (theta_S - t)^T Sigma_S^-1 (theta_S - t) at the best common t, with Sigma_S the
covariance of group S's log fluxes (the Fisher information of the log residuals at the
fit, the noise from the fit's own residual). Fluxes that differ by several of their sd
(2000 / 3500 / 5000 lm at 1.6 % sd) stay apart.
"""
import time

import numpy as np

from invrad_wb.core.inverse.fitcheck import fisher_of
from invrad_wb.core.inverse.locate_count import _params, bic_of, robust_mean_square
from invrad_wb.core.inverse.tiedparams import flux_ties


def flux_groups(theta, cov, penalty):
    """Groups (lists of indices) of the log fluxes ``theta`` (K,) with covariance ``cov``
    (K, K) that may share one flux: neighbours in flux order merged, the cheapest first
    (the growth of the groups' Wald statistic), while a merge costs less than
    ``penalty``. Returns the groups, each in increasing flux."""
    theta = np.asarray(theta, dtype=np.float64)
    groups = [[int(i)] for i in np.argsort(theta, kind="stable")]
    cost = [0.0] * len(groups)
    while len(groups) > 1:
        trials = [_wald(theta, cov, groups[j] + groups[j + 1]) - cost[j] - cost[j + 1]
                  for j in range(len(groups) - 1)]
        j = int(np.argmin(trials))
        if not trials[j] < penalty:
            break
        merged = groups[j] + groups[j + 1]
        groups[j:j + 2] = [merged]
        cost[j:j + 2] = [_wald(theta, cov, merged)]
    return groups


def _wald(theta, cov, members):
    """The Wald statistic of ``members``' log fluxes all equal: (theta_S - t)^T P
    (theta_S - t) at the best common t, P the inverse of their covariance."""
    th = theta[members]
    P = np.linalg.pinv(cov[np.ix_(members, members)])
    one = np.ones(len(members))
    t = float(one @ P @ th) / max(float(one @ P @ one), 1e-300)
    d = th - t
    return float(d @ P @ d)


def common_flux(theta, cov, members):
    """The best common log flux of ``members`` (the inverse-covariance weighted mean)."""
    th = theta[members]
    P = np.linalg.pinv(cov[np.ix_(members, members)])
    one = np.ones(len(members))
    w = one @ P
    if not float(w @ one) > 0:
        return float(np.mean(th))
    return float(w @ th) / float(w @ one)


def _residuals(prob, lights):
    if hasattr(prob, "normal_equations"):
        return prob.residuals(lights)
    return prob.residuals(lights, [prob.visibility(L) for L in lights])[0]


def _tied_state(prob, lights):
    """(robust mean square of the log residuals, log flux (m,) and covariance (m, m) of
    each flux parameter of ``lights``' fit on ``prob`` (a tied group's one parameter
    once), the lights of each parameter (lists of indices))."""
    r, F = fisher_of(prob, prob._own_copies(lights))
    ms = robust_mean_square(r, prob.w_area)
    n = F.shape[0]
    T = flux_ties(lights)
    T = np.eye(n) if T is None else T
    cov = T @ np.linalg.pinv(T.T @ F @ T) @ T.T * ms
    ends = np.cumsum([L.n_params() for L in lights]) - 1       # each log flux: its last
    col = np.argmax(T[ends], axis=1)
    params, members = np.unique(col, return_inverse=True)
    first = [int(np.flatnonzero(members == j)[0]) for j in range(len(params))]
    theta = np.log([lights[i].flux_scale for i in first])
    C = cov[np.ix_(ends[first], ends[first])]
    return ms, theta, C, [list(np.flatnonzero(members == j)) for j in range(len(params))]


#: :func:`tie_fluxes`: at most this many rounds of grouping and refitting (each round's
#: tied fit proposes merges of its groups again: a first fit with many free fluxes is
#: the least precise, its groups the smallest)
TIE_ROUNDS = 4


def tie_fluxes(prob, lights, refit, trace=None, rounds=TIE_ROUNDS):
    """``lights`` (free fluxes, fitted on ``prob``) with the fluxes the data cannot tell
    apart tied (module docstring): groups proposed from the fit's Fisher information,
    the tied arrangement refitted by ``refit`` (lights -> lights, on ``prob``) and kept
    when its criterion is lower; repeated from the tied fit (its groups merged further)
    while that lowers the criterion, at most ``rounds`` times. Returns the lights (tied
    or as they were)."""
    if len(lights) < 2 or not all(L.free_flux for L in lights):
        return lights
    k = int(np.sum(prob.target > 0)) or len(prob.target)
    best, b_best = lights, None
    one_kind_tried = turned_down = False
    for _round in range(rounds):
        ms, theta, cov, items = _tied_state(prob, best)
        if b_best is None:
            b_best = bic_of(ms, _params(best), k)
        merged = flux_groups(theta, cov, np.log(k))
        if len(merged) == len(items) or turned_down:
            if len(items) == 1 or one_kind_tried:
                break
            # the groups' fluxes differ by more than their local sd: from a fit that
            # their different fluxes hold off the truth (close luminaires, few points)
            # all of one kind may still fit better, judged by its own refit
            merged, one_kind_tried = [list(range(len(items)))], True
        tied = [L.copy() for L in best]
        for gi, group in enumerate(merged):
            who = [i for j in group for i in items[j]]
            scale = float(np.exp(common_flux(theta, cov, group)))
            for i in who:
                tied[i].flux_group = gi if len(who) > 1 else -1
                tied[i].flux_scale = scale
        t0 = time.process_time()
        tied = refit(tied)
        t_refit = time.process_time() - t0
        b_tied = bic_of(robust_mean_square(_residuals(prob, tied), prob.w_area),
                        _params(tied), k)
        entry = {"flux_ties": sorted((len(g) for g in _groups_of(tied)), reverse=True),
                 "bic_before": b_best, "bic_after": b_tied, "kept": bool(b_tied < b_best),
                 "refit_cpu_s": round(t_refit, 2)}
        if trace is not None:
            trace.append(entry)
        turned_down = not b_tied < b_best
        if turned_down:
            if one_kind_tried or len(merged) == 1:
                break
            continue
        best, b_best = tied, b_tied
    return best


def _groups_of(lights):
    """Indices of ``lights`` per flux group (luminaires of their own flux alone)."""
    out = {}
    for i, L in enumerate(lights):
        out.setdefault(L.flux_group if L.flux_group >= 0 else ("own", i), []).append(i)
    return list(out.values())
