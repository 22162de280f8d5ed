"""The digital twin: known answers, convergence, determinism, batching, intervals, errors."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pandas as pd
import pytest

from brake_env.data.datasets import Dataset
from brake_env.model.atlas import Atlas
from brake_env.model.wear import WearModel
from brake_env.prognostics.protocol import EventBatch, iter_runs
from tests.twin.conftest import TEST_CONFIG
from twin import DigitalTwin, TwinCalibration, TwinConfig


def _synthetic_run(atlas: Atlas, k: float, sigma: float, seed: int) -> EventBatch:
    """A pad of coefficient ``k`` wearing exactly along the expected path, with Gaussian
    temperature noise ``sigma``: the twin's own model, so the answer is known."""
    wm = WearModel.from_atlas(atlas)
    n = int(wm.life(k))
    rng = np.random.default_rng(seed)
    u = rng.random((n, 3))
    lo = np.array([atlas.speed_mps[0], atlas.mass_kg[0], atlas.slope_rad[0]])
    hi = np.array([atlas.speed_mps[-1], atlas.mass_kg[-1], atlas.slope_rad[-1]])
    s, m, th = (lo + (hi - lo) * u).T
    layer = wm.layer_at_work(k * np.arange(n))
    temp, _ = atlas.lookup.profile(s, m, th, layer=layer)
    return EventBatch.from_arrays(
        {
            "event": np.arange(n),
            "speed_kmh": s * 3.6,
            "mass_kg": m,
            "slope_rad": th,
            "energy_j": 0.5 * m * s**2,
            "temp_c": temp + rng.normal(0.0, sigma, n),
            "stop_dist_m": np.ones(n),
        }
    )


def test_synthetic_pad_gives_its_k_and_life(atlas: Atlas) -> None:
    k_true, sigma = 2.6e-6, 1.0
    cal = TwinCalibration(k_log_mean=math.log(2e-6), k_log_scale=0.1, temp_sigma_c=sigma)
    twin = DigitalTwin(atlas, TEST_CONFIG, calibration=cal)
    ev = _synthetic_run(atlas, k_true, sigma, seed=1)
    est = twin.update(ev)
    n = len(ev)
    half = slice(n // 2, None)
    np.testing.assert_allclose(est.wear_coeff[half], k_true, rtol=0.01)
    life = WearModel.from_atlas(atlas).life(k_true)
    rul_true = life - (np.arange(n) + 1)
    assert np.max(np.abs(est.rul_mean[half] - rul_true[half])) < 0.01 * life
    # The prior alone (before evidence) predicts the prior's life, not the pad's.
    assert est.wear_coeff[0] == pytest.approx(2e-6, rel=0.02)


def test_k_converges_within_5pct_before_60pct_of_life(
    dataset: Dataset, id_predictions: pd.DataFrame
) -> None:
    log = dataset.logs["id"]
    for run_id, g in id_predictions.groupby("run_id", observed=True):
        k_true = log.loc[log.run_id == run_id, "wear_coeff"].iloc[0]
        off = np.flatnonzero(np.abs(g.wear_coeff.to_numpy() / k_true - 1.0) > 0.05)
        converged_at = (off[-1] + 1) if off.size else 0
        assert converged_at < 0.6 * len(g), f"{run_id}: K within 5% only from {converged_at}"


def test_rul_is_accurate_late_and_intervals_cover(
    dataset: Dataset, id_predictions: pd.DataFrame
) -> None:
    truth = dataset.logs["id"].rul_events.to_numpy()
    p = id_predictions
    assert np.all(p.rul_lower <= p.rul_mean + 1e-9) and np.all(p.rul_mean <= p.rul_upper + 1e-9)
    assert np.all(p.rul_lower >= 0)
    covered = (truth >= p.rul_lower) & (truth <= p.rul_upper)
    assert covered.mean() > 0.75  # nominal 0.9
    frac = p.groupby("run_id", observed=True).cumcount() / p.groupby(
        "run_id", observed=True
    ).event.transform("size")
    late = (frac > 0.5).to_numpy()
    life = p.groupby("run_id", observed=True).event.transform("size").to_numpy()
    assert np.max(np.abs(p.rul_mean.to_numpy() - truth)[late] / life[late]) < 0.02


def test_ood_fast_pad_is_identified(fitted: DigitalTwin, dataset: Dataset) -> None:
    ((_, ev),) = iter_runs(dataset.logs["ood"])
    fitted.reset()
    est = fitted.update(ev)
    k_true = ev.wear_coeff[0]
    assert est.wear_coeff[0] < 0.8 * k_true  # the prior is far off
    n = len(ev)
    np.testing.assert_allclose(est.wear_coeff[int(0.3 * n) :], k_true, rtol=0.05)


def test_deterministic_and_batch_size_invariant(fitted: DigitalTwin, dataset: Dataset) -> None:
    _, ev = next(iter_runs(dataset.logs["id"]))
    ev = ev[:20_000]

    def run(step: int, stop: int) -> pd.DataFrame:
        fitted.reset()
        parts = [fitted.update(ev[i : min(i + step, stop)]) for i in range(0, stop, step)]
        return pd.concat([p.to_frame() for p in parts], ignore_index=True)

    whole = run(len(ev), len(ev))
    pd.testing.assert_frame_equal(whole, run(len(ev), len(ev)))  # same input, same output
    pd.testing.assert_frame_equal(run(500, len(ev)), whole, rtol=1e-9)
    pd.testing.assert_frame_equal(run(1, 1500), whole.iloc[:1500], rtol=1e-9)


def test_dropped_out_channels_carry_no_evidence(fitted: DigitalTwin, dataset: Dataset) -> None:
    _, ev = next(iter_runs(dataset.logs["id"]))
    ev = ev[:3000]
    blind = dataclasses.replace(ev, temp_c=np.full(len(ev), np.nan))
    fitted.reset()
    est = fitted.update(blind)
    assert np.all(np.isfinite(est.rul_mean))
    np.testing.assert_allclose(est.wear_coeff, est.wear_coeff[0])  # the prior throughout
    fitted.reset()
    assert fitted.update(ev).wear_coeff[-1] != est.wear_coeff[-1]


def test_fit_learns_prior_and_noise(fitted: DigitalTwin, dataset: Dataset) -> None:
    cal = fitted.calibration
    assert cal is not None and cal.n_runs == 6
    train = dataset.logs["train"]
    ks = train.groupby("run_id", observed=True).wear_coeff.first().to_numpy()
    assert cal.k_median == pytest.approx(np.exp(np.log(ks).mean()), rel=0.01)
    assert cal.temp_sigma_c == pytest.approx(5.0, rel=0.15)  # the simulated sensor: 5 K
    assert abs(cal.temp_bias_c) < 0.5


def test_fit_ignores_ground_truth_columns(atlas: Atlas, dataset: Dataset) -> None:
    train = dataset.logs["train"]
    bare = train[["run_id", "event", "speed_kmh", "mass_kg", "slope_rad", "temp_c"]]
    a = DigitalTwin(atlas, TEST_CONFIG).fit(train).calibration
    b = DigitalTwin(atlas, TEST_CONFIG).fit(bare).calibration
    assert a == b


def test_bad_input_errors(atlas: Atlas, dataset: Dataset, fitted: DigitalTwin) -> None:
    twin = DigitalTwin(atlas, TEST_CONFIG)
    _, ev = next(iter_runs(dataset.logs["id"]))
    with pytest.raises(RuntimeError, match="call fit"):
        twin.update(ev[:10])
    train = dataset.logs["train"]
    with pytest.raises(ValueError, match="at least 2"):
        twin.fit(train[train.run_id == train.run_id.iloc[0]])
    with pytest.raises(ValueError, match=r"lacks column\(s\) \['temp_c'\]"):
        twin.fit(train.drop(columns="temp_c"))
    with pytest.raises(ValueError, match="empty"):
        twin.fit(train.iloc[:0])
    fitted.reset()
    fitted.update(ev[5:10])  # a log may start mid-life; later batches follow on (gaps allowed)
    with pytest.raises(ValueError, match="event 8, but the previous batch ended at event 9"):
        fitted.update(ev[8:20])
    with pytest.raises(ValueError, match="n_grid"):
        TwinConfig(n_grid=3)
    with pytest.raises(ValueError, match="grid_factor"):
        TwinConfig(grid_factor=1.0)
    with pytest.raises(ValueError, match="outlier_weight"):
        TwinConfig(outlier_weight=0.9)
    with pytest.raises(ValueError, match="point_estimate"):
        TwinConfig(point_estimate="mode")
    with pytest.raises(ValueError, match="temp_sigma_c"):
        TwinCalibration(k_log_mean=-13.0, k_log_scale=0.1, temp_sigma_c=0.0)


def test_protocol_attributes(fitted: DigitalTwin) -> None:
    assert DigitalTwin.name == "twin"
    assert DigitalTwin.interval_level == 0.9
    grid, w = fitted.k_posterior
    assert grid.shape == w.shape and w.sum() == pytest.approx(1.0)
