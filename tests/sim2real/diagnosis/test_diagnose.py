"""Diagnosis end to end on small truth logs: a clear case, the control, a user effect, bad logs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from numpy.typing import ArrayLike

from brake_env.cli.main import main
from brake_env.data.schema import EventLogError, read_event_log, write_event_log
from brake_env.model.atlas import Atlas
from sim2real.diagnosis.attribute import NONE
from sim2real.diagnosis.config import DiagnosisConfig
from sim2real.diagnosis.diagnose import diagnose
from sim2real.effects.interface import Effect, EventState, Param
from sim2real.effects.library import (
    HeatPartition,
    NewtonCooling,
    SpeedFriction,
    ThermocoupleBias,
    register,
)
from sim2real.effects.truth import TruthSpec, simulate_truth
from tests.sim2real.conftest import SMALL, short_runs

FAST = DiagnosisConfig(
    fit_events_per_run=800,
    calibration_events_per_run=800,
    score_events_per_run=4000,
    grid_points=4,
)


class Squeal(Effect):
    """A user effect written here: friction rises at low sliding speed (stick-slip)."""

    name = "test_squeal"
    kind = "in-event"
    summary = "friction rises as the pad slows down"
    params = (Param("c", "-", 0.0, 0.0, 0.3, 0.15, "friction gain at standstill"),)

    def friction_factor(self, s: EventState) -> ArrayLike:
        return 1.0 + self["c"] * np.exp(-s.slide_speed_mps / 0.2)


def _log(effects: list[Effect], seed: int, n: int = 4):
    return simulate_truth(SMALL, effects, TruthSpec(short_runs(n)), seed=seed)["train"]


def test_clear_case_is_named_and_closes_the_gap(s2r_atlas: Atlas) -> None:
    log = _log([ThermocoupleBias(bias_k=12.0)], seed=11)
    res = diagnose(log, s2r_atlas, [ThermocoupleBias, HeatPartition, SpeedFriction], FAST, seed=1)
    a = res.summary["attribution"]
    assert a["verdict"] == "tc_bias", a["reason"]
    assert a["candidates"][0]["params"]["bias_k"] == pytest.approx(12.0, abs=1.5)
    q = res.summary["quantify"]
    assert q["channel"] == "temp" and q["shrink"]["temp"] > 0.7
    # The localisation puts the gap in the temperature channel.
    assert res.summary["localise"]["ranked"][0]["channel"] == "temp"


def test_control_gets_none(s2r_atlas: Atlas) -> None:
    log = _log([], seed=12)
    res = diagnose(log, s2r_atlas, [ThermocoupleBias, HeatPartition, SpeedFriction], FAST, seed=2)
    assert res.verdict == NONE


def test_user_effect_end_to_end(s2r_atlas: Atlas, tmp_path: Path) -> None:
    register(Squeal)
    # Truth simulator from the CLI, by name.
    out = tmp_path / "truth"
    rc = main(
        [
            "simulate",
            "--effect",
            "test_squeal:c=0.25",
            "--out",
            str(out),
            "--seed",
            "5",
            "--n-train",
            "4",
            "--n-id",
            "0",
            "--n-ood-slow",
            "0",
            "--n-ood-fast",
            "0",
            "--k-mean",
            "4e-5",
            "--k-std",
            "4e-6",
            "--format",
            "parquet",
            "--quiet",
            "--cache-dir",
            str(tmp_path / "cache"),
        ]
    )
    assert rc == 0
    log = read_event_log(out / "train.parquet")
    assert "time_s" in log
    res = diagnose(log, s2r_atlas, [Squeal, ThermocoupleBias, HeatPartition], FAST, seed=3)
    assert res.verdict == "test_squeal", res.summary["attribution"]["reason"]


def test_bad_logs_get_clear_errors(s2r_atlas: Atlas, tmp_path: Path, capsys) -> None:
    log = _log([], seed=13, n=2)
    one = log[log["run_id"] == log["run_id"].iloc[0]]
    with pytest.raises(ValueError, match="at least 2"):
        diagnose(one, s2r_atlas, [ThermocoupleBias], FAST)
    bad = log.drop(columns="temp_c")
    path = write_event_log(bad, tmp_path / "bad.parquet")
    with pytest.raises(EventLogError, match="temp_c"):
        read_event_log(path)
    rc = main(["diagnose", "--real", str(path), "--out", str(tmp_path / "d"), "--quiet"])
    assert rc == 2
    assert "temp_c" in capsys.readouterr().err
    # A thermal-history candidate on a log without event times is skipped, with the reason.
    res = diagnose(log.drop(columns="time_s"), s2r_atlas, [NewtonCooling, ThermocoupleBias], FAST)
    assert "time_s" in res.summary["attribution"]["skipped"]["newton_cooling"]


def test_diagnosis_is_deterministic_for_a_seed(s2r_atlas: Atlas) -> None:
    log = _log([ThermocoupleBias(bias_k=6.0)], seed=14, n=3)
    a = diagnose(log, s2r_atlas, [ThermocoupleBias], FAST, seed=4).summary
    b = diagnose(log, s2r_atlas, [ThermocoupleBias], FAST, seed=4).summary
    assert a["attribution"]["parameter"] is not None  # the refinement and its bootstrap too
    assert a["attribution"] == b["attribution"]
