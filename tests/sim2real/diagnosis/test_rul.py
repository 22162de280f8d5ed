"""The twin's RUL error with and without an effect (the diagnosis's "quantify" callback)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

import sim2real.diagnosis.rul as rul_mod
from brake_env.model.atlas import Atlas
from sim2real.diagnosis.quantify import LogPart
from sim2real.diagnosis.rul import rmse_by_run, rul_scorer
from sim2real.effects.library import HeatPartition, SpeedFriction
from sim2real.effects.truth import TruthSpec, simulate_truth
from tests.sim2real.conftest import SMALL, short_runs


def test_rmse_by_run_is_per_run_with_an_interval_around_the_mean() -> None:
    err = np.array([3.0, -4.0, 1.0, 1.0, 1.0])
    run_id = pd.Series(["a", "a", "b", "b", "b"])
    r = rmse_by_run(err, run_id, level=0.9, n_boot=200, seed=0)
    np.testing.assert_allclose(r["rmse_runs"], [np.sqrt(12.5), 1.0])
    assert r["rmse"] == pytest.approx((np.sqrt(12.5) + 1.0) / 2)
    lo, hi = r["ci"]
    assert 1.0 <= lo <= r["rmse"] <= hi <= np.sqrt(12.5)


def test_twin_with_the_right_effect_has_a_lower_rul_error(s2r_atlas: Atlas) -> None:
    truth = HeatPartition(phi=0.25)  # a hotter-running nominal twin over-predicts wear
    cal = simulate_truth(SMALL, [truth], TruthSpec(short_runs(3)), seed=3)["train"]
    held = simulate_truth(SMALL, [truth], TruthSpec(short_runs(2)), seed=103)["train"]
    score = rul_scorer(s2r_atlas)
    out = {
        name: score(effect, LogPart(held), LogPart(cal))
        for name, effect in (("nominal", None), ("right", truth), ("wrong", SpeedFriction(a=0.3)))
    }
    for r in out.values():
        assert r is not None and len(r["rmse_runs"]) == 2
        assert np.all(np.isfinite(r["rmse_runs"]))
        assert r["ci"][0] <= r["rmse"] <= r["ci"][1]
    assert out["right"]["rmse"] < 0.2 * out["nominal"]["rmse"]
    assert out["right"]["rmse"] < 0.2 * out["wrong"]["rmse"]


def test_sensor_offset_is_removed_from_the_temperature(s2r_atlas: Atlas) -> None:
    log = simulate_truth(SMALL, [], TruthSpec(short_runs(2)), seed=4)["train"]
    offset = np.full(len(log), 7.0)
    corrected = rul_mod._corrected(LogPart(log, offset))
    np.testing.assert_array_equal(corrected["temp_c"], log["temp_c"] - 7.0)
    assert rul_mod._corrected(LogPart(log)) is log


def test_without_truth_or_without_twin(s2r_atlas: Atlas, monkeypatch) -> None:
    log = simulate_truth(SMALL, [], TruthSpec(short_runs(2)), seed=5)["train"]
    part = LogPart(log.drop(columns="rul_events"))
    r = rul_scorer(s2r_atlas)(None, part, part)
    assert r is not None and "rul_events" in r["note"]
    monkeypatch.setattr(rul_mod, "predictor_names", lambda: ("none", "oracle"))
    assert rul_scorer(s2r_atlas)(None, LogPart(log), LogPart(log)) is None
