"""benchmarks/analysis/distilled_decision_speed.py on a tiny study: the planner and both distilled
policies decide every recorded state, and each printed ratio is the planner's time over
that policy's."""

from __future__ import annotations

import pytest

from agents.fleet.settings import FleetStudyConfig
from agents.fleet.study.run import run_fleet_study
from brake_env.runner import Runner
from tests.benchmarks import load_script

pytest.importorskip("sb3_contrib")


def test_every_policy_decides_every_recorded_state(atlas, tmp_path, capsys) -> None:
    study = FleetStudyConfig(
        shifts=16, predictors=("oracle",), heuristics=("threshold",), trials=2, tune_episodes=1,
        eval_episodes=2, n_train_runs=2,
    )  # fmt: skip
    run_fleet_study(study, atlas, tmp_path, Runner(0), n_resamples=50)
    got = load_script("distilled_decision_speed").main(
        [str(tmp_path), "--predictor", "oracle", "--episodes", "2", "--epochs", "1"]
    )
    assert got["states"] == 2 * 16
    out = capsys.readouterr().out
    assert "base rule's duties in the input: True" in out
    for key, name in (("agent", "distilled central policy"), ("shared", "distilled shared policy")):
        assert got[key] > 0 and got["planner"] > 0
        row = next(line for line in out.splitlines() if name in line)
        assert row.rstrip(" |").endswith(f"{got['planner'] / got[key]:.0f}")
