"""Data-driven baseline: learns a known linear RUL, deterministic, saved without pickle."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from baselines.mlp import MLPConfig, MLPPredictor, features
from brake_env.prognostics.protocol import predict_log
from tests.baselines.synthetic import synthetic_log

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


def test_save_load_round_trip(train: pd.DataFrame, fitted: MLPPredictor, tmp_path: Path) -> None:
    npz, js = fitted.save(tmp_path / "mlp")
    assert npz.suffix == ".npz" and js.suffix == ".json"
    with np.load(npz, allow_pickle=False) as f:  # weights only
        assert all(f[k].dtype == np.float32 for k in f.files)
    loaded = MLPPredictor.load(tmp_path / "mlp")
    x = features(train)
    np.testing.assert_array_equal(loaded.predict(x), fitted.predict(x))
    assert loaded.config == fitted.config
    with pytest.raises(FileNotFoundError, match="no saved network"):
        MLPPredictor.load(tmp_path / "nothing")


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
        " brake_env.prognostics.registry, brake_env.prognostics.cli;"
        " from baselines import PhysicsPredictor;"
        " assert 'torch' not in sys.modules, 'torch imported'"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
