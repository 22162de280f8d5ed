"""``brakewear diagnose --backtest``: what the fix is worth on the diagnosed log itself."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pandas as pd
import pytest

import sim2real.commands.cli as cli_mod
import sim2real.diagnosis.fix as fix_mod
import sim2real.validation.report as report_mod
from brake_env.cli.main import main
from brake_env.data.schema import write_event_log
from brake_env.model.atlas import Atlas
from sim2real.diagnosis.config import DiagnosisConfig
from sim2real.diagnosis.fix import NOT_FED_BACK, fed_back_effect, fix_lines, worth_of_fix
from sim2real.effects.library import HeatPartition, NewtonCooling, ThermocoupleBias
from sim2real.effects.truth import TruthSpec, simulate_truth
from tests.sim2real.conftest import SMALL, short_runs

FAST = DiagnosisConfig(
    fit_events_per_run=800,
    calibration_events_per_run=800,
    score_events_per_run=4000,
    grid_points=4,
    refine_evals=4,
    resamples=500,
)


@pytest.fixture(scope="module")
def hot_log() -> pd.DataFrame:
    """Four short pads whose friction heat enters the brake 25% more (a strong in-event
    effect): the nominal twin over-predicts their wear rate."""
    spec = TruthSpec(short_runs(4, k=8e-5))
    return simulate_truth(SMALL, [HeatPartition(phi=0.25)], spec, seed=21)["train"]


def _no_backtest(monkeypatch: pytest.MonkeyPatch) -> None:
    def refuse(*_a: Any, **_k: Any) -> Any:
        raise AssertionError("no back-test (nor fed-back atlas) should run")

    monkeypatch.setattr(fix_mod, "backtest", refuse)
    monkeypatch.setattr(fix_mod, "cached_atlas", refuse)


def test_diagnose_backtest_shows_the_fed_back_twin_beating_the_nominal_one(
    s2r_atlas: Atlas, hot_log: pd.DataFrame, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """End to end from the command: the diagnosis names the effect, refines its parameter,
    and ``fix`` in diagnosis.json and report.md holds the back-test before and after."""
    monkeypatch.setattr(cli_mod, "_config", lambda args: FAST)  # fewer events and models
    monkeypatch.setattr(report_mod, "figures", lambda r, out: [])  # seconds of drawing
    log_path = write_event_log(hot_log, tmp_path / "log.parquet")
    atlas_path = tmp_path / "small.npz"
    s2r_atlas.save(atlas_path)
    out = tmp_path / "diag"
    argv = ["diagnose", "--real", str(log_path), "--model", str(atlas_path), "--out", str(out)]
    argv += ["--candidates", "heat_partition", "tc_bias", "--no-rul", "--quiet", "--backtest"]
    assert main(argv) == 0
    doc = json.loads((out / "diagnosis.json").read_text())
    a, fix = doc["attribution"], doc["fix"]
    assert a["verdict"] == "heat_partition", a["reason"]
    assert fix["status"] == "done", fix["note"]
    # Fed back at the refined value, not the grid's.
    p = a["parameter"]
    assert fix["effect"] == f"heat_partition:phi={p['value']:.6g}"
    assert set(fix["predictors"]) == {"twin", "twin+effect", "window"}
    assert fix["pairs"] == [{"nominal": "twin", "fed_back": "twin+effect"}]
    twin, fed = fix["predictors"]["twin"], fix["predictors"]["twin+effect"]
    assert fed["failed_pads"] == twin["failed_pads"] == 4
    assert fed["rmse"]["hi"] < twin["rmse"]["lo"]
    assert fed["rmse"]["mean"] < 0.2 * twin["rmse"]["mean"]
    assert fed["coverage"]["mean"] > twin["coverage"]["mean"]
    assert fix["ranking"]["order"][-1] == "twin"
    report = (out / "report.md").read_text()
    assert "## What the fix is worth on your log" in report
    assert f"| twin + {fix['effect']} |" in report


def test_an_abstaining_diagnosis_runs_no_backtest(
    s2r_atlas: Atlas, hot_log: pd.DataFrame, monkeypatch: pytest.MonkeyPatch
) -> None:
    _no_backtest(monkeypatch)
    fix = worth_of_fix(hot_log, s2r_atlas, None, None)
    assert fix["status"] == "abstained" and fix["effect"] is None
    assert "named no effect" in fix["note"]
    assert "no back-test" in fix_lines(fix)[0]


def test_a_between_events_winner_is_reported_as_not_fed_back(
    s2r_atlas: Atlas, hot_log: pd.DataFrame, monkeypatch: pytest.MonkeyPatch
) -> None:
    _no_backtest(monkeypatch)
    fix = worth_of_fix(hot_log, s2r_atlas, NewtonCooling(tau_s=60.0), None)
    assert fix["status"] == "not fed back"
    assert NOT_FED_BACK in fix["note"] and "newton_cooling" in fix["note"]
    assert NOT_FED_BACK in fix_lines(fix)[0]


def test_too_few_pads_run_to_failure_give_one_clear_note(
    s2r_atlas: Atlas, hot_log: pd.DataFrame, monkeypatch: pytest.MonkeyPatch
) -> None:
    _no_backtest(monkeypatch)
    first = hot_log["run_id"] == hot_log["run_id"].iloc[0]
    one_failed = hot_log.assign(failed=hot_log["failed"] & first)
    fix = worth_of_fix(one_failed, s2r_atlas, HeatPartition(phi=0.2), None)
    assert fix["status"] == "not run"
    assert "1 of the log's 4 pads ran to failure" in fix["note"]
    none_failed = hot_log.assign(failed=False)
    fix = worth_of_fix(none_failed, s2r_atlas, HeatPartition(phi=0.2), None)
    assert fix["status"] == "not run" and "nothing to score" in fix["note"]
    with pytest.raises(ValueError, match="oracle"):
        worth_of_fix(hot_log, s2r_atlas, None, None, predictors=("oracle",))


def test_the_effect_is_fed_back_at_the_refined_value() -> None:
    winner = ThermocoupleBias(bias_k=10.0)
    assert fed_back_effect(winner, None) == "tc_bias:bias_k=10"
    refined = {"name": "bias_k", "value": 11.234567891}
    assert fed_back_effect(winner, refined) == "tc_bias:bias_k=11.2346"
