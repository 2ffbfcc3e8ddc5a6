"""How well a room's located luminaires reproduce its targets, by the locate's own model.

The refinement predicts the illuminance at the room's voting points (direct light with
visibility, plus the interreflected light of its model); :func:`room_fit` turns that
prediction into the fit quality of :mod:`invrad_wb.core.output.fitquality` (relative RMS
over the lit targets, share within 20 %), without a forward render. The pipeline judges
its rooms with a forward render instead (:func:`invrad_wb.app.pipeline.room_verdicts`).
"""
import numpy as np

from invrad_wb.core.output.fitquality import FitQuality, fit_quality


def predicted_lux(prob, lights):
    """(n,) lux the refinement problem ``prob`` predicts at its points for ``lights``."""
    vis = [prob.visibility(L) for L in lights]
    r, _ = prob.residuals(lights, vis)
    return np.exp(r + prob.log_target) - prob.eps_lux


def room_fit(prob, lights):
    """:class:`~invrad_wb.core.output.fitquality.FitQuality` of a room's lights."""
    if prob is None:
        return FitQuality(float("nan"), float("nan"), 0)
    return fit_quality(prob.target, predicted_lux(prob, lights))


def position_sd(prob, lights, sigma=None):
    """How precisely ``prob``'s targets pin ``lights``: per luminaire the standard deviation
    (m) of its position along its worst direction and, with fluxes free, of its flux
    (relative), from the Fisher information of the log residuals at ``lights``
    (the Cramer-Rao bound: no unbiased estimate from these data does better).

    ``sigma``: the targets' relative noise per point (0.05: 5 %); None: estimated from
    the residual left at ``lights`` (its area-weighted root mean square). The bound
    assumes the noise of different points independent (each point one measurement, as
    :func:`~invrad_wb.core.inverse.locate_problem.vertex_points` gives).

    Returns ``(pos_sd (K,), flux_sd (K,) or None)``.
    """
    if not lights:
        return np.zeros(0), None
    lights = prob._own_copies(lights)
    r, F = fisher_of(prob, lights)
    lit = prob.target > 0
    if sigma is None:
        sigma = float(np.sqrt(np.sum(prob.w_area[lit] * r[lit] ** 2)
                              / max(np.sum(prob.w_area[lit]), 1e-300)))
    return sd_of(np.linalg.pinv(F) * sigma ** 2, lights)


def fisher_of(prob, lights):
    """(log residuals (k,), the Fisher information J^T J (n, n) of the log residuals over
    the lit points) of ``prob`` at ``lights``: a RefineProblem, or a streamed
    :class:`~invrad_wb.core.inverse.locate_vertices.VertexProblem` (summed chunk by
    chunk)."""
    if hasattr(prob, "normal_equations"):
        r, F, _g = prob.normal_equations(prob._own_copies(lights), weights=False)
        return r, F
    r, J = prob.residuals(lights, [prob.visibility(L) for L in lights], with_jac=True)
    lit = prob.target > 0
    return r, J[lit].T @ J[lit]


def sd_of(cov, lights):
    """Per luminaire of ``lights`` (their parameters in order in the covariance ``cov``):
    the position sd (the largest axis of its position block) and, with free fluxes, the
    flux sd. Returns ``(pos_sd (K,), flux_sd (K,) or None)``."""
    sizes = [len(L.params()) for L in lights]
    starts = np.concatenate([[0], np.cumsum(sizes)]).astype(int)
    pos, flux = [], []
    for L, a in zip(lights, starts[:-1]):
        npos = L._npos()
        block = cov[a:a + npos, a:a + npos]
        pos.append(float(np.sqrt(max(np.linalg.eigvalsh(block).max(), 0.0))))
        if L.free_flux:
            b = a + len(L.params()) - 1
            flux.append(float(np.sqrt(max(cov[b, b], 0.0))))
    return np.array(pos), (np.array(flux) if flux else None)
