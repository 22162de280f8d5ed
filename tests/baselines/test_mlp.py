"""Data-driven baseline: learns a known linear RUL, deterministic, saved without pickle."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from baselines.mlp import MLPConfig, MLPPredictor, features
from brake_env.model.atlas import Atlas
from brake_env.prognostics.persist import load_predictor, save_predictor
from brake_env.prognostics.protocol import predict_log
from tests.baselines.fleet_check import assert_fleet_matches_loop
from tests.baselines.synthetic import cut_runs, synthetic_log

FAST = MLPConfig(epochs=40, batch_size=64, learning_rate=1e-2)


@pytest.fixture(scope="module")
def train() -> pd.DataFrame:
    return synthetic_log([300, 400, 500, 600])


@pytest.fixture(scope="module")
def fitted(train: pd.DataFrame) -> MLPPredictor:
    return MLPPredictor(FAST).fit(train)


def test_learns_a_linear_rul(fitted: MLPPredictor) -> None:
    """RUL = temp_c - 1 - event on these logs; a run of an unseen life is predicted."""
    test = synthetic_log([450], seed=1, prefix="test")
    pred = predict_log(fitted, test)
    err = pred["rul_mean"].to_numpy() - test["rul_events"].to_numpy()
    assert np.sqrt(np.mean(err**2)) < 0.03 * 450
    assert fitted.loss_history[-1] < 0.1 * fitted.loss_history[0]


def test_deterministic_for_a_seed(train: pd.DataFrame, fitted: MLPPredictor) -> None:
    x = features(train)
    again = MLPPredictor(FAST).fit(train)
    np.testing.assert_array_equal(again.predict(x), fitted.predict(x))
    other = MLPPredictor(MLPConfig(epochs=40, batch_size=64, learning_rate=1e-2, seed=1))
    assert not np.array_equal(other.fit(train).predict(x), fitted.predict(x))


def test_state_round_trip_without_pickle(
    train: pd.DataFrame, fitted: MLPPredictor, small_atlas: Atlas, tmp_path: Path
) -> None:
    meta, arrays = fitted.get_state()
    assert json.loads(json.dumps(meta)) == meta  # plain JSON settings
    assert all(isinstance(a, np.ndarray) and a.dtype == np.float32 for a in arrays.values())
    again = MLPPredictor()
    again.set_state(meta, arrays)
    x = features(train)
    np.testing.assert_array_equal(again.predict(x), fitted.predict(x))
    assert again.config == fitted.config and again.y_scale == fitted.y_scale
    save_predictor(fitted, tmp_path / "m", small_atlas, seed=FAST.seed)
    loaded = load_predictor(tmp_path / "m", small_atlas)
    test = synthetic_log([450], seed=1, prefix="test")
    pd.testing.assert_frame_equal(predict_log(loaded, test), predict_log(fitted, test))
    with pytest.raises(ValueError, match="do not fit layers"):
        MLPPredictor().set_state(meta, {k: v for k, v in arrays.items() if "0." not in k})
    with pytest.raises(ValueError, match="version"):
        MLPPredictor().set_state({**meta, "state_version": 1}, arrays)


def test_same_estimates_whatever_the_batches_and_the_start(fitted: MLPPredictor) -> None:
    """Per-event estimates: batch sizes change nothing, and a log that starts mid-life
    gets the estimates of the whole log at its events (the event index is an input)."""
    test = synthetic_log([450], seed=1, prefix="test")
    whole = predict_log(fitted, test)
    pd.testing.assert_frame_equal(predict_log(fitted, test, batch_events=7), whole)
    tail = predict_log(fitted, test[test["event"] >= 200], batch_events=33)
    pd.testing.assert_frame_equal(tail, whole[whole["event"] >= 200].reset_index(drop=True))


def test_fleet_equals_one_predictor_per_pad(fitted: MLPPredictor) -> None:
    log = synthetic_log([350, 500, 420, 610, 280], seed=2, prefix="t")
    assert assert_fleet_matches_loop(fitted, log, seed=0) > 100


def test_censored_runs_are_lower_bounds_not_lives() -> None:
    """Two runs to failure, two removed at 60% of life: their RUL is only bounded below."""
    full = synthetic_log([300, 400, 500, 600], with_truth=False)
    keep = full["run_id"].isin(["run-00", "run-03"])
    train = pd.concat([full[keep], cut_runs(full[~keep], 0.6)])
    test = synthetic_log([450], seed=1, prefix="test")

    def rmse(log: pd.DataFrame) -> float:
        pred = MLPPredictor(FAST).fit(log)
        err = predict_log(pred, test)["rul_mean"].to_numpy() - test["rul_events"].to_numpy()
        return float(np.sqrt(np.mean(err**2)))

    honest, lengths_as_lives = rmse(train), rmse(train.drop(columns="failed"))
    assert honest < 0.05 * 450 and lengths_as_lives > 2 * honest
    with pytest.raises(ValueError, match=r"every training run \(\['run-00'"):
        MLPPredictor(FAST).fit(cut_runs(full, 0.6))


def test_missing_readings_and_bad_config(fitted: MLPPredictor, train: pd.DataFrame) -> None:
    x = features(train.head(5))
    x[:, 1] = np.nan  # stopping-distance dropout -> the training mean
    assert np.all(np.isfinite(fitted.predict(x)))
    assert np.all(fitted.predict(features(train)) >= 0)
    with pytest.raises(ValueError, match="hidden"):
        MLPConfig(hidden=(20, 0))
    with pytest.raises(ValueError, match="epochs"):
        MLPConfig(epochs=0)
    with pytest.raises(RuntimeError, match="fit"):
        MLPPredictor().predict(x)


def test_torch_is_imported_only_by_the_mlp() -> None:
    code = (
        "import sys, baselines, brake_env.prognostics.evaluation, brake_env.prognostics.plots,"
        " brake_env.prognostics.registry, brake_env.prognostics.commands.evaluate;"
        " from baselines import PhysicsPredictor;"
        " assert 'torch' not in sys.modules, 'torch imported'"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
