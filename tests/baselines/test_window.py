"""The rolling-window baseline: reads wear from recent events, exact across batches, pads
and mid-life starts, saved without pickle, censored lives through a survival likelihood,
and better than the paper's MLP on simulated ID and OOD pads."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from baselines.window import WindowConfig, WindowPredictor
from brake_env.data.datasets import DatasetSpec, make_dataset
from brake_env.model.atlas import Atlas
from brake_env.model.regime import WearRegime
from brake_env.prognostics.evaluation import EvaluationConfig, evaluate
from brake_env.prognostics.persist import load_predictor, save_predictor
from brake_env.prognostics.protocol import predict_log
from brake_env.prognostics.registry import make_predictor
from tests.baselines.fleet_check import assert_fleet_matches_loop
from tests.baselines.synthetic import wear_log

LIVES = [3000, 3600, 4200, 3300, 3900, 4500]


@pytest.fixture(scope="module")
def fitted() -> WindowPredictor:
    return WindowPredictor().fit(wear_log(LIVES))


def test_reads_the_wear_of_pads_slower_and_faster_than_training(fitted: WindowPredictor) -> None:
    assert fitted.block_events == round(0.035 * np.mean(LIVES) / 8)
    for life in (2000, 3800, 7000):  # the index knows no event count: OOD lives too
        test = wear_log([life], seed=5, prefix="test")
        pred = predict_log(fitted, test)
        err = pred["rul_mean"].to_numpy() - test["rul_events"].to_numpy()
        late = test["event"].to_numpy() > 0.3 * life
        assert np.sqrt(np.mean(err[late] ** 2)) < 0.05 * life
        inside = (pred["rul_lower"] <= test["rul_events"]) & (
            test["rul_events"] <= pred["rul_upper"]
        )
        assert inside[late].mean() > 0.6 and (pred["rul_lower"] <= pred["rul_upper"]).all()


def test_same_estimates_whatever_the_batches(fitted: WindowPredictor) -> None:
    test = wear_log([1500, 900], seed=6, prefix="test")
    whole = predict_log(fitted, test)
    for batch in (1, 13, 500):
        pd.testing.assert_frame_equal(predict_log(fitted, test, batch_events=batch), whole)


def test_mid_life_start_reads_its_events_by_index(fitted: WindowPredictor) -> None:
    """Once a window's events have been logged, a log that starts at event 1,234 gets the
    estimates of the whole log (windows follow the event index, sums are exact); before,
    it reads its shorter window, a noisier but unbiased reading."""
    test = wear_log([4000], seed=7, prefix="test")
    whole = predict_log(fitted, test)
    start, b = 1234, fitted.block_events
    tail = predict_log(fitted, test[test["event"] >= start], batch_events=77)
    same = tail["event"] >= (start // b + fitted.config.n_blocks) * b
    ref = whole[whole["event"] >= start].reset_index(drop=True)
    pd.testing.assert_frame_equal(tail[same], ref[same])
    early = ~same.to_numpy()
    truth = test["rul_events"].to_numpy()[start:][early]
    renumbered = test[test["event"] >= start].assign(event=lambda d: d["event"] - start)
    wrong = predict_log(fitted, renumbered)["rul_mean"].to_numpy()[early]
    rmse_tail = np.sqrt(np.mean((tail["rul_mean"].to_numpy()[early] - truth) ** 2))
    assert early.sum() > 50 and rmse_tail < 0.5 * np.sqrt(np.mean((wrong - truth) ** 2))


def test_fleet_equals_one_predictor_per_pad(fitted: WindowPredictor) -> None:
    log = wear_log([900, 1500, 1200, 2000, 800, 1700], seed=8, prefix="t")
    assert assert_fleet_matches_loop(fitted, log, seed=1, max_batch=400) > 300


def test_missing_channel_falls_back_to_the_prior(fitted: WindowPredictor) -> None:
    test = wear_log([3000], seed=9, prefix="test")
    test["temp_c"] = np.nan
    pred = predict_log(fitted, test)
    assert fitted.prior is not None
    np.testing.assert_allclose(
        pred["rul_mean"], np.maximum(1.0 / fitted.prior.mean - test["event"] - 1.0, 0.0)
    )


def test_saved_and_loaded_without_pickle(
    fitted: WindowPredictor, small_atlas: Atlas, tmp_path: Path
) -> None:
    save_predictor(fitted, tmp_path / "m", small_atlas)
    loaded = load_predictor(tmp_path / "m", small_atlas)
    assert isinstance(loaded, WindowPredictor) and loaded is not fitted
    test = wear_log([3500], seed=10, prefix="test")
    pd.testing.assert_frame_equal(predict_log(loaded, test), predict_log(fitted, test))
    meta, arrays = fitted.get_state()
    with pytest.raises(ValueError, match="coef has shape"):
        WindowPredictor().set_state(meta, {**arrays, "coef": arrays["coef"][:-1]})


def test_censored_lives_enter_the_prior_never_as_lives() -> None:
    """60 pads, each removed at a planned time drawn independently of its wear."""
    rng = np.random.default_rng(0)
    lives = np.round(1000.0 / rng.normal(1.0, 0.1, 60)).astype(int)
    removal = rng.integers(600, 1200, 60)
    full = wear_log(lives.tolist(), with_truth=False)
    stop = full["run_id"].map(dict(zip(full["run_id"].unique(), removal, strict=True)))
    log = full[full["event"] < stop]
    assert 0.4 < 1 - log.groupby("run_id")["failed"].any().mean() < 0.8
    truth = WindowPredictor().fit(full)
    fit = WindowPredictor().fit(log)
    assert fit.prior is not None and truth.prior is not None
    assert fit.prior.mean == pytest.approx(truth.prior.mean, rel=0.02)
    assert WindowPredictor().fit(log.drop(columns="failed")).prior.mean > 1.15 * truth.prior.mean
    with pytest.raises(ValueError, match=r"0 training run\(s\) end at failure.*\(60 runs\)"):
        WindowPredictor().fit(log.assign(failed=False))


def test_bad_config() -> None:
    with pytest.raises(ValueError, match="n_blocks"):
        WindowConfig(n_blocks=0)
    with pytest.raises(ValueError, match="window_frac"):
        WindowConfig(window_frac=-0.1)
    with pytest.raises(RuntimeError, match="fit"):
        WindowPredictor().fleet(2)


def test_beats_the_papers_mlp_on_simulated_pads(small_atlas: Atlas) -> None:
    """Lives of ~1e4 events: 6 training, 3 ID, 4 OOD pads (K shifted by -6 and +6 sigma)."""
    spec = DatasetSpec(n_train=6, n_id=3, n_ood_slow=2, n_ood_fast=2, wear=WearRegime(2e-5, 2e-6))
    data = make_dataset(small_atlas, spec, seed=2)
    preds = {n: make_predictor(n, small_atlas) for n in ("data", "window")}
    ev = evaluate(preds, data.logs, EvaluationConfig())
    for split in ("id", "ood"):
        assert ev.mean("window", split, "rul_rmse") < ev.mean("data", split, "rul_rmse")
    assert ev.mean("window", "ood", "rul_rmse") < 0.5 * ev.mean("data", "ood", "rul_rmse")
