"""The discrepancy workflow on real measured data (../shared/data/real; skipped when absent).  Each diagnosis
takes minutes on this 2-core machine, so these are ``slow`` tests (run with ``-m slow``); their numbers are
in docs/diagnose.md (produced by benchmarks/diagnose_real.py, the same functions).  The thresholds are the
targets and published anchors (each data set's SOURCE.md), not what the code happened to reach."""
from __future__ import annotations

import sys
import warnings
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
warnings.filterwarnings("ignore", category=RuntimeWarning)

pytestmark = [pytest.mark.slow, pytest.mark.realdata]


def test_silverbox_names_cubic_stiffness_and_reaches_the_published_models(real_data, tmp_path):
    import diagnose_real

    r = diagnose_real.silverbox(tmp_path, real_data, log=lambda m: None)
    assert r["named"][0] == "cubic_stiffness"
    # quadratic damping next: an independent continuous-time fit (benchmarks/silverbox_study.py reference)
    # improves with it too (0.350 → 0.296 mV); nothing else belongs there.  (It was lost once to the 8 000-sample
    # screening, judged against a model fitted on all 65 062 samples: docs/diagnose.md, Silverbox.)
    assert r["named"] == ["cubic_stiffness", "quadratic_damping"]
    mv = r["rmse_mV"]
    # issue 13's target: the physical model as good as a five-parameter discrete linear model plus one cubic
    # term (0.37 mV, SOURCE.md), near the best published (about 0.26–0.36 mV)
    assert mv["multisine_after"] <= 0.4
    # the calibrated linear model is the published linear one (about 7 mV; SOURCE.md's check 7.01 mV)
    assert 5.0 < mv["multisine_before"] < 9.0
    # the arrow within the training amplitudes: the discrete linear + cubic check reaches 0.37 mV there
    assert mv["arrow_no_extrapolation_after"] <= 0.4
    assert mv["arrow_no_extrapolation_after"] < mv["arrow_no_extrapolation_before"] / 10
    # the fitted linear resonance is the third party's √b ≈ 68.5 Hz (SOURCE.md)
    import math

    f0 = math.sqrt(r["fitted"]["spring_stiffness"] / r["fitted"]["sprung_mass"]) / (2 * math.pi)
    assert f0 == pytest.approx(68.5, abs=1.0)


def test_emps_names_coulomb_friction(real_data, tmp_path):
    import diagnose_real

    r = diagnose_real.emps(tmp_path, real_data, log=lambda m: None)
    assert "coulomb_friction" in r["named"]
    # SOURCE.md's own open-loop check (linear → + Coulomb, Euler at 1 kHz): test 17.2 → 9.0 mm
    assert r["rmse_mm"]["test_after"] <= 9.0
    # and better than our own calibrated linear model.  (The ratio asked before, ≤ 0.6×, was SOURCE's linear
    # 17.2 → 9.0 mm, from the IDIM-LS linear model; our output-error linear fit, with the mass free since the
    # zero-spring sag fix, is already 7.2 mm, so the anchor is the absolute 9.0 mm above.)
    assert r["rmse_mm"]["test_after"] < r["rmse_mm"]["test_before"]
    fit = r["fitted"]
    # the fitted physics is close to the organisers' IDIM-LS reference (M 95.1 kg, Fv 203.4 N s/m, Fc 20.4 N)
    assert fit["sprung_mass"] == pytest.approx(95.1, rel=0.25)
    assert fit["damping"] == pytest.approx(203.4, rel=0.3)
    assert fit["coulomb_friction.force"] == pytest.approx(20.4, rel=0.4)
    # the force offset too (SOURCE.md: −3.17 N on the left-hand side, +3.17 N added to the input here)
    assert fit["input.offset"] == pytest.approx(3.17, rel=0.25)


def test_quanser_claims_only_what_beats_the_repeatability_floor(real_data, tmp_path):
    import diagnose_real

    r = diagnose_real.quanser(tmp_path, real_data, log=lambda m: None)
    floor = r["floor_mm"]["body_pos"]
    kept = [c for c in r["candidates"] if c["kept"]]
    assert set(r["named"]) <= {c["name"] for c in kept}  # (a stand-in may pass the gate beside the one added)
    for c in kept:  # every claimed effect removes error above the floor on the repeat run
        assert c["excess_after"] < c["excess_before"] and c["test_after"] < c["test_before"]
    # SOURCE.md's rough check: linear 0.67 mm, + Coulomb friction 0.56 mm on the repeat run (floor 0.33 mm)
    assert r["rmse_mm"]["test_after_body_pos"] <= 0.67
    # whatever is named, the held-out body error is not claimed below the repeat floor
    assert r["rmse_mm"]["test_after_body_pos"] >= 0.5 * floor
