"""What tells two tied candidates apart: the power calculation, and a check on a simulated log
that lacks a range (benchmarks/analysis/separability.py runs more seeds and the runs check)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pandas as pd
import pytest

from brake_env.model.atlas import Atlas
from sim2real.diagnosis.attribute import NONE
from sim2real.diagnosis.config import DiagnosisConfig
from sim2real.diagnosis.diagnose import diagnose
from sim2real.diagnosis.logdata import prepare_log
from sim2real.diagnosis.replay import Prediction
from sim2real.diagnosis.separate import (
    advice,
    channel_s2,
    events_to_add,
    runs_needed,
    separation_lines,
    synthetic_log,
    target_z,
)
from sim2real.effects.library import HeatPartition, ThermocoupleBias
from sim2real.effects.truth import TruthSpec, simulate_truth
from tests.sim2real.conftest import SMALL, short_runs

FAST = DiagnosisConfig(
    fit_events_per_run=800,
    calibration_events_per_run=800,
    score_events_per_run=4000,
    grid_points=4,
    refine_evals=0,
    resamples=200,
)
CANDIDATES = [HeatPartition, ThermocoupleBias]


def test_events_to_add_reaches_the_target_z() -> None:
    s_sum, v_sum, s2, z = 20.0, 400.0, 0.5, 3.84  # z now 1.0
    m = events_to_add(s_sum, v_sum, s2, z)
    assert (s_sum + m * s2 / 2) / math.sqrt(v_sum + m * s2) == pytest.approx(z, rel=1e-9)
    assert events_to_add(s_sum, v_sum, 2 * s2, z) < m  # a cell that separates more needs fewer
    assert events_to_add(80.0, 400.0, s2, z) == 0.0  # already there
    assert events_to_add(s_sum, v_sum, 0.0, z) == math.inf
    m_neg = events_to_add(-20.0, v_sum, s2, z)  # the runner-up ahead: more to make up
    assert (-20.0 + m_neg * s2 / 2) / math.sqrt(v_sum + m_neg * s2) == pytest.approx(z)


def test_runs_needed_scales_with_the_square_of_z() -> None:
    # z 1.5 on 2 held-out runs of 4: (3 / 1.5)^2 = 4x the held-out runs, half of all runs.
    assert runs_needed(1.5, 2, 4, 3.0, 0.5) == 16
    assert runs_needed(3.5, 2, 4, 3.0, 0.5) == 4  # already there
    assert runs_needed(0.0, 2, 4, 3.0, 0.5) == math.inf
    assert target_z(3.0) == pytest.approx(3.0 + 0.8416, abs=1e-4)  # 80% power


def test_channel_separation_in_predictive_spread_units() -> None:
    one = np.ones(2)
    a = Prediction(np.array([10.0, 0.0]), 4 * one, np.array([1.0, 1.0]), one, one)
    b = Prediction(np.array([8.0, 0.0]), 4 * one, np.array([1.0, 3.0]), 3 * one, one)
    s2 = channel_s2(a, b)
    np.testing.assert_allclose(s2["temp"], [1.0, 0.0])
    np.testing.assert_allclose(s2["stop"], [0.0, 2.0])


def test_advice_cheapest_first_and_a_channel_not_logged() -> None:
    cell = {"range": "X", "events_logged": 0, "separation": 1.1, "events_to_log": 43.0}
    cell["separation_by_channel"] = {"temp": 1.1, "stop": 0.03}
    stop = {"channel": "stop", "logged_share": 0.0, "separation": 0.4, "z_if_all_logged": 5.0}
    temp = {"channel": "temp", "logged_share": 1.0, "separation": 0.01, "z_if_all_logged": 0.1}
    sep: dict[str, Any] = {
        "runs": {"runs_needed": 8.0, "more_runs": 4.0, "runs_needed_interval": [6.0, 11.0]},
        "events_per_run": 800.0,  # 4 runs: 3200 events, more than the cell's 43
        "paired_z": 2.9,
        "win_z": 3.0,
        "power": 0.8,
        "target_z": 3.84,
        "ranges": [cell],
        "channels": [{**stop, "noise_factor": 1.0}, {**temp, "noise_factor": 0.03}],
    }
    lines = advice(sep)
    assert lines[0].startswith("log about 43 braking events at X (the log has 0)")
    assert lines[1].startswith("log 4 more runs like these (8 in all, 6-11 from the runs'")
    assert lines[2].startswith("stopping distance separates them") and "holds 0%" in lines[2]
    assert len(lines) == 3  # temperature is not the channel that separates them
    sep["runs"]["runs_needed"] = float("inf")
    assert advice(sep)[1] == "more runs like these would not separate them (paired z <= 0)"


def test_synthetic_events_follow_two_alike(s2r_atlas: Atlas) -> None:
    log = simulate_truth(SMALL, [], TruthSpec(short_runs(2)), seed=3)["train"]
    d = prepare_log(log, s2r_atlas)
    pts = np.array([[5.0, 45e3, 0.05], [3.0, 50e3, 0.1]])
    syn, rows = synthetic_log(d, pts)
    np.testing.assert_array_equal(rows, [2, 5])
    np.testing.assert_array_equal(syn.prev(rows, 2), [0, 3])
    np.testing.assert_array_equal(syn.speed_mps[syn.prev(rows)], pts[:, 0])
    gaps = d.gap_s(np.flatnonzero(d.ok))
    assert syn.gap_s(rows) == pytest.approx(np.median(gaps[np.isfinite(gaps)]))


def _in_cell(log: pd.DataFrame, cell: dict[str, Any]) -> pd.DataFrame:
    s, m, th = log["speed_kmh"], log["mass_kg"] / 1000, np.degrees(log["slope_rad"])
    ok = s.between(*cell["speed_kmh"]) & m.between(*cell["mass_t"])
    return log[ok & th.between(*cell["slope_deg"])]


def _plus(base: pd.DataFrame, full: pd.DataFrame, cell: dict[str, Any], n: int) -> pd.DataFrame:
    pool = _in_cell(full, cell).drop(index=base.index, errors="ignore")
    pick = pool.iloc[np.linspace(0, len(pool) - 1, n).astype(int)]
    return pd.concat([base, pick]).sort_index()


def test_the_recommended_range_names_the_true_effect(s2r_atlas: Atlas) -> None:
    # Slow, flat braking only: a heat partition and a thermocouple offset both lower the
    # logged temperature by about the same amount, and the diagnosis abstains between them.
    full = simulate_truth(SMALL, [HeatPartition(phi=0.1)], TruthSpec(short_runs(4)), seed=21)
    full_log = full["train"]
    slow = (full_log["speed_kmh"] < 9) & (full_log["slope_rad"] < np.radians(3))
    base = full_log[slow]
    a = diagnose(base, s2r_atlas, CANDIDATES, FAST, seed=21).summary["attribution"]
    assert a["verdict"] == NONE and "equally well" in a["reason"], a["reason"]
    sep = a["separation"]
    assert {c.split(":")[0] for c in sep["candidates"]} == {"heat_partition", "tc_bias"}
    assert sep["paired_z"] == pytest.approx(a["candidates"][0]["held_z_vs_runner_up"])
    best, worst = sep["ranges"][0], sep["ranges"][-1]
    # Fast braking, absent from the log, separates them: temperature, not stopping distance.
    assert best["events_logged"] == 0 and best["speed_kmh"][0] >= 9
    assert best["separation_by_channel"]["temp"] > 10 * best["separation_by_channel"]["stop"]
    assert best["separation"] > 3 * worst["separation"]
    n = math.ceil(best["events_to_log"])
    assert 0 < n < 200
    lines = separation_lines(sep)
    assert f"log about {n} braking events at {best['range']}" in "\n".join(lines)
    # The simulator given those events names the true effect; as many from the cell ranked
    # last do not.
    named = diagnose(_plus(base, full_log, best, n), s2r_atlas, CANDIDATES, FAST, seed=21)
    assert named.verdict == "heat_partition", named.summary["attribution"]["reason"]
    ctrl = diagnose(_plus(base, full_log, worst, n), s2r_atlas, CANDIDATES, FAST, seed=21)
    assert ctrl.verdict == NONE
