"""Fit quality and requirement verdicts on numbers computed by hand."""
import math

import pytest

from invrad_wb.core.output.fitquality import (fit_quality, poor_fit_warning,
                                              requirement_verdict)


def test_fit_quality_by_hand():
    # lit targets 100, 200, 400 lx (NaN: no target, 0: must stay dark, not judged)
    fq = fit_quality([100, 200, float("nan"), 0, 400], [110, 150, 5, 3, 400])
    # relative deviations +0.10, -0.25, 0 -> RMS sqrt((0.01 + 0.0625) / 3)
    assert fq.rms_relative == pytest.approx(math.sqrt(0.0725 / 3))
    assert fq.within_share == pytest.approx(2 / 3)          # -25 % is outside 20 %
    assert fq.targets == 3 and fq.poor
    line = poor_fit_warning("Galerie", fq)
    assert line.startswith("warning: Galerie:") and "15.5 % RMS" in line
    assert "Design" in line and "\n" not in line


def test_no_lit_target_is_no_fit_and_no_warning():
    fq = fit_quality([float("nan"), 0.0], [3.0, 1.0])
    assert fq.targets == 0 and not fq.poor and poor_fit_warning("Store", fq) is None
    assert fq.to_dict() == {"rms_relative": None, "within_20pct": None, "targets": 0,
                            "poor": False}


def test_a_good_fit_gives_no_warning():
    fq = fit_quality([100, 100], [105, 96])
    assert fq.rms_relative == pytest.approx(math.sqrt((0.05 ** 2 + 0.04 ** 2) / 2))
    assert fq.within_share == 1.0 and not fq.poor
    assert poor_fit_warning("Bad", fq) is None


def test_requirement_verdict_by_hand():
    v = requirement_verdict(500, [600, 400, 500], 0.6, "EN 12464-1 for 500 lx")
    assert v.em_lux == 500 and v.emin_lux == 400 and v.u0 == pytest.approx(0.8)
    assert v.met and v.why_not() == []
    assert "U0 0.80 >= 0.60 (EN 12464-1 for 500 lx) met" in v.words()
    # +40 %: above the +30 % tolerance; U0 1.0
    hot = requirement_verdict(500, [700, 700], 0.6, "EN 12464-1 for 500 lx")
    assert not hot.em_ok and hot.u0_ok and not hot.met
    assert "too bright" in hot.why_not()[0]
    # -10 % is still within, U0 0.5 < 0.6 is not
    flat = requirement_verdict(100, [60, 120], 0.4, "EN 12464-1 for 100 lx")
    assert flat.em_lux == 90 and flat.em_ok
    assert flat.u0 == pytest.approx(60 / 90) and flat.u0_ok
    low = requirement_verdict(500, [225, 675], 0.6, "EN 12464-1 for 500 lx")
    assert low.u0 == pytest.approx(0.5) and not low.u0_ok
    assert "U0 0.50 < 0.60" in low.words()


def test_locate_states_its_fit_quality_and_a_wrong_flux_is_poor():
    from invrad_wb.core.inverse.locate import locate
    from invrad_wb.core.synthetic.scenarios import known_scene
    scene, true = known_scene("one_ceiling", reflectance=0.0, cell=0.2, backend="auto")
    good = locate(scene, true[0].flux_lm, backend="auto")
    fq = good.rooms[0].fit
    assert fq.targets > 100 and fq.rms_relative < 0.05 and not fq.poor
    assert good.to_dict()["rooms"][0]["fit"]["within_20pct"] >= 0.95
    # twice the flux: one luminaire cannot be dimmed, so every lit point is ~2x too bright
    bad = locate(scene, 2.0 * true[0].flux_lm, backend="auto", overlap_levels=1)
    assert bad.rooms[0].fit.poor
