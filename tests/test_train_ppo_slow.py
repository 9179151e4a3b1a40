"""The training example end to end (slow; needs the rl extra): a minute of PPO, the learning curve, the
policy exported and compared with passive, skyhook and Toscano–Dumas in one report."""
import json
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow


def test_train_ppo_example(tmp_path):
    pytest.importorskip("stable_baselines3")
    repo = Path(__file__).resolve().parents[1]
    out = tmp_path / "ppo"
    res = subprocess.run([sys.executable, str(repo / "examples" / "train_ppo.py"), "--out", str(out),
                          "--minutes", "1"], capture_output=True, text=True, timeout=900)
    assert res.returncode == 0, res.stderr[-2000:]
    s = json.loads((out / "summary.json").read_text())
    assert s["train_env_steps"] > 10_000 and 55 <= s["train_wall_s"] <= 180  # the wall-clock limit holds
    curve = (out / "learning_curve.csv").read_text().splitlines()
    assert len(curve) > 16  # episodes from rest were recorded (a minute is too short to assert learning)
    assert set(s["metrics"]) == {"passive", "skyhook", "toscano_dumas", "ppo"}
    assert (out / "learning_curve.png").stat().st_size > 10_000
    assert (out / "compare" / "report.html").exists() and (out / "policy.npz").exists()
