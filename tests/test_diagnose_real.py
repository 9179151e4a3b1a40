"""The discrepancy workflow on real measured data (../shared/data/real; skipped when absent).  Each diagnosis
takes longer than 30 s on this 2-core machine, so these are ``slow`` tests (run with ``-m slow``); their
numbers are in docs/diagnose.md (produced by benchmarks/diagnose_real.py, the same functions)."""
from __future__ import annotations

import sys
import warnings
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
warnings.filterwarnings("ignore", category=RuntimeWarning)

pytestmark = [pytest.mark.slow, pytest.mark.realdata]


def test_silverbox_names_cubic_stiffness(real_data, tmp_path):
    import diagnose_real

    r = diagnose_real.silverbox(tmp_path, real_data, log=lambda m: None)
    assert r["named"][0] == "cubic_stiffness"
    assert r["rmse_mV"]["multisine_after"] <= 1.0
    assert r["rmse_mV"]["multisine_before"] > 3 * r["rmse_mV"]["multisine_after"]
    # the arrow sets are reported, and the no-extrapolation arrow improves too
    assert r["rmse_mV"]["arrow_no_extrapolation_after"] < r["rmse_mV"]["arrow_no_extrapolation_before"]


def test_emps_names_coulomb_friction(real_data, tmp_path):
    import diagnose_real

    r = diagnose_real.emps(tmp_path, real_data, log=lambda m: None)
    assert "coulomb_friction" in r["named"]
    assert r["rmse_mm"]["test_after"] <= 0.6 * r["rmse_mm"]["test_before"]
    fit = r["fitted"]
    # the fitted physics is close to the organisers' IDIM-LS reference (M 95.1 kg, Fv 203.4 N s/m, Fc 20.4 N)
    assert fit["sprung_mass"] == pytest.approx(95.1, rel=0.25)
    assert fit["damping"] == pytest.approx(203.4, rel=0.3)
    assert fit["coulomb_friction.force"] == pytest.approx(20.4, rel=0.4)


def test_quanser_claims_only_what_beats_the_repeatability_floor(real_data, tmp_path):
    import diagnose_real

    r = diagnose_real.quanser(tmp_path, real_data, log=lambda m: None)
    floor = r["floor_mm"]["body_pos"]
    kept = [c for c in r["candidates"] if c["kept"]]
    assert len(kept) == len(r["named"])
    for c in kept:  # every claimed effect removes error above the floor on the repeat run
        assert c["excess_after"] < c["excess_before"] and c["test_after"] < c["test_before"]
    # whatever is named, the held-out body error is not claimed below the repeat floor
    assert r["rmse_mm"]["test_after_body_pos"] >= 0.5 * floor
