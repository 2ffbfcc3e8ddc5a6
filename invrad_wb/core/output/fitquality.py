"""How well a locate result meets its targets, in numbers and in one line of words.

Two kinds of targets, two kinds of verdict (see :mod:`invrad_wb.core.design.requirements`):

* **exact** targets (rendered or measured light): the *fit quality*, the relative RMS of
  achieved against target over the lit targets, ``sqrt(mean(((a - t) / t)^2))``, and the
  share of lit targets within :data:`WITHIN` (20 %) of their target; a fit worse than
  :data:`POOR_RMS` (10 %) is poor and gets a one-line warning naming the likely causes;
* **requirement** targets (a level on a work plane): the mean Em against the level with
  its tolerance (-10 %/+30 %) and the uniformity U0 = Emin / Em against the value of
  EN 12464-1 for that level, each stated with what it was judged against.

Only numpy; lux in, plain numbers and words out.
"""
from dataclasses import dataclass

import numpy as np

#: a lit target is "within" when its achieved lux is within this fraction of its target
WITHIN = 0.20
#: a fit whose relative RMS is above this is poor
POOR_RMS = 0.10
#: tolerance of the mean on a work plane against its level (fractions)
EM_LOW, EM_HIGH = 0.90, 1.30


@dataclass
class FitQuality:
    """Fit quality over the lit targets (``target > 0``) of a room.

    rms_relative : relative RMS deviation (0.05 = 5 %)
    within_share : share of lit targets within :data:`WITHIN` of their target (0..1)
    targets : number of lit targets judged
    """
    rms_relative: float
    within_share: float
    targets: int

    @property
    def poor(self):
        return bool(self.targets) and self.rms_relative > POOR_RMS

    def to_dict(self):
        def num(x):        # no lit target: null, never NaN (strict JSON)
            return round(float(x), 4) if np.isfinite(x) else None
        return {"rms_relative": num(self.rms_relative),
                "within_20pct": num(self.within_share),
                "targets": int(self.targets), "poor": self.poor}

    def words(self):
        return (f"fit {100 * self.rms_relative:.1f} % RMS, {100 * self.within_share:.0f} %"
                f" of {self.targets} targets within {100 * WITHIN:.0f} %")


def fit_quality(target, achieved):
    """:class:`FitQuality` of ``achieved`` against ``target`` (lux per point; NaN and 0 lx
    targets are not judged: no target, must stay dark)."""
    t = np.asarray(target, dtype=np.float64).reshape(-1)
    a = np.asarray(achieved, dtype=np.float64).reshape(-1)
    lit = np.isfinite(t) & (t > 0) & np.isfinite(a)
    if not lit.any():
        return FitQuality(float("nan"), float("nan"), 0)
    rel = (a[lit] - t[lit]) / t[lit]
    return FitQuality(float(np.sqrt(np.mean(rel ** 2))),
                      float(np.mean(np.abs(rel) <= WITHIN + 1e-12)), int(lit.sum()))


def poor_fit_warning(room, fq):
    """One line for a poor fit (None when the fit is not poor)."""
    if not fq.poor:
        return None
    return (f"warning: {room}: the luminaires found reproduce the targets poorly"
            f" ({fq.words()}); likely causes: another intensity distribution, aimed"
            " luminaires, the wrong flux, or targets that no real light gives (a"
            " requirement rather than a picture: use Design)")


@dataclass
class RequirementVerdict:
    """A work-plane level judged: Em within -10/+30 % of ``level``, U0 >= ``u0_required``."""
    level_lux: float
    em_lux: float
    emin_lux: float
    u0_required: float
    u0_source: str
    points: int = 0

    @property
    def u0(self):
        return self.emin_lux / self.em_lux if self.em_lux > 0 else 0.0

    @property
    def em_ok(self):
        return EM_LOW * self.level_lux - 1e-9 <= self.em_lux <= EM_HIGH * self.level_lux + 1e-9

    @property
    def u0_ok(self):
        return self.u0 >= self.u0_required - 1e-9

    @property
    def met(self):
        return self.em_ok and self.u0_ok

    def words(self):
        dev = self.em_lux / self.level_lux - 1.0
        em = (f"Em {self.em_lux:.0f} lx for {self.level_lux:.0f} lx ({100 * dev:+.0f} %,"
              f" tolerance -{100 * (1 - EM_LOW):.0f}/+{100 * (EM_HIGH - 1):.0f} %)"
              f" {'met' if self.em_ok else 'NOT met'}")
        u0 = (f"U0 {self.u0:.2f} {'>=' if self.u0_ok else '<'} {self.u0_required:.2f}"
              f" ({self.u0_source}) {'met' if self.u0_ok else 'NOT met'}")
        return f"{em}; {u0}"

    def why_not(self):
        """The reasons it is not met, in words (empty when met)."""
        out = []
        if self.em_lux < EM_LOW * self.level_lux:
            out.append("too dark: the room needs more or stronger luminaires")
        elif self.em_lux > EM_HIGH * self.level_lux:
            out.append("too bright: even the fewest luminaires that spread the light evenly"
                       " give more than the level; a weaker or dimmable luminaire would")
        if not self.u0_ok:
            out.append("not uniform enough at the mounting allowed")
        return out

    def to_dict(self):
        return {"level_lux": self.level_lux, "em_lux": round(float(self.em_lux), 2),
                "emin_lux": round(float(self.emin_lux), 2), "u0": round(float(self.u0), 3),
                "u0_required": self.u0_required, "u0_source": self.u0_source,
                "em_ok": self.em_ok, "u0_ok": self.u0_ok, "met": self.met,
                "points": int(self.points)}


def requirement_verdict(level_lux, achieved, u0_required, u0_source):
    """:class:`RequirementVerdict` of the achieved lux on a work plane's points."""
    a = np.asarray(achieved, dtype=np.float64).reshape(-1)
    a = a[np.isfinite(a)]
    if not len(a):
        return RequirementVerdict(float(level_lux), 0.0, 0.0, u0_required, u0_source, 0)
    return RequirementVerdict(float(level_lux), float(a.mean()), float(a.min()),
                              float(u0_required), u0_source, len(a))
