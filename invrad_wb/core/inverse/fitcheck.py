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
