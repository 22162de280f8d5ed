"""Physics-based baseline: calibration of K and the straight-line RUL, in closed form."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from baselines._runs import run_lives, true_rul
from baselines.physics import PhysicsPredictor
from brake_env.model.atlas import Atlas
from brake_env.model.materials import hardness_mpa
from brake_env.model.physics import simulate_events
from brake_env.prognostics.persist import load_predictor, save_predictor
from brake_env.prognostics.protocol import EventBatch, predict_log
from tests.baselines.fleet_check import assert_fleet_matches_loop
from tests.baselines.synthetic import cut_runs, synthetic_log


def test_life_is_the_harmonic_mean_of_training_lives(small_atlas: Atlas) -> None:
    p = PhysicsPredictor(small_atlas).fit(synthetic_log([100, 200, 400]))
    life = 3 / (1 / 100 + 1 / 200 + 1 / 400)  # K_i ~ 1/N_i, K_avg their mean
    assert p.life_events == pytest.approx(life)
    assert p.k_runs is not None
    np.testing.assert_allclose(p.k_runs.to_numpy(), p.k_for_life(np.array([100, 200, 400])))
    assert p.k_avg == pytest.approx(p.k_runs.mean())
    test = synthetic_log([300], prefix="test")
    pred = predict_log(p, test)
    k = test["event"].to_numpy()
    np.testing.assert_allclose(pred["rul_mean"], np.maximum(life - 1 - k, 0.0))
    v_fail = small_atlas.failure_volume
    vol = np.maximum(1 - (k + 1) / life * (1 - v_fail), v_fail)
    np.testing.assert_allclose(pred["volume_frac"], vol)


def test_exact_on_runs_like_its_training_runs(small_atlas: Atlas) -> None:
    """Constant-wear pads of one life: the straight line is the truth."""
    p = PhysicsPredictor(small_atlas).fit(synthetic_log([250, 250]))
    test = synthetic_log([250], prefix="test")
    pred = predict_log(p, test, batch_events=17)  # online in batches, same line
    np.testing.assert_allclose(pred["rul_mean"], test["rul_events"], atol=1e-9)


def test_wear_model_against_the_physics(atlas: Atlas) -> None:
    """F_N E[s_slide] / H(20 C) of the fresh layer, against a Monte Carlo of the physics."""
    model = atlas.spec.model
    rng = np.random.default_rng(0)
    env = model.envelope
    n = 20_000
    r = simulate_events(
        rng.uniform(*env.speed_kmh, n) / 3.6,
        rng.uniform(*env.mass_kg, n),
        np.radians(rng.uniform(*env.slope_deg, n)),
        1.0,
        model,
    )
    h20 = float(hardness_mpa(20.0, model.hardness))
    assert 140 < h20 < 160  # docs/model.md: 152 MPa at 20 C
    mc = model.brake.normal_force_n * 1e-6 * r.sliding_dist_m.mean() / h20
    assert PhysicsPredictor(atlas).wear_per_k_m3 == pytest.approx(mc, rel=0.02)


def test_training_runs_need_a_known_life(small_atlas: Atlas) -> None:
    log = synthetic_log([50, 60], with_truth=False)
    assert run_lives(log).tolist() == [50, 60]
    np.testing.assert_array_equal(true_rul(log)[:3], [49, 48, 47])
    cut = cut_runs(log, 0.7)  # removed before failure, no truth, no measurement
    with pytest.raises(ValueError, match=r"run-00', 'run-01'\] \(2 runs\) were removed"):
        PhysicsPredictor(small_atlas).fit(cut)
    with pytest.raises(ValueError, match="do not end at failure"):
        run_lives(cut)
    truncated = synthetic_log([50, 60])
    truncated = truncated[truncated["event"] < 40]  # with truth, the life is still known
    assert run_lives(truncated).tolist() == [50, 60]
    with pytest.raises(RuntimeError, match="fit"):
        PhysicsPredictor(small_atlas).update(EventBatch.from_frame(log[log["run_id"] == "run-00"]))


def _fleet_log(rng: np.random.Generator, n: int) -> tuple[list[int], pd.DataFrame]:
    """Pads of lives 1 / K, K ~ N(1, 0.1) / 1000, each removed at a planned time drawn
    independently of its wear (about half before failure)."""
    lives = np.round(1000.0 / rng.normal(1.0, 0.1, n)).astype(int)
    removal = rng.integers(500, 1200, n)
    log = synthetic_log(lives.tolist(), seed=3, with_truth=False)
    life = log["run_id"].map(dict(zip(log["run_id"].unique(), lives, strict=True)))
    stop = log["run_id"].map(dict(zip(log["run_id"].unique(), removal, strict=True)))
    log = log[log["event"] < np.minimum(life, stop)].copy()
    return lives.tolist(), log


def test_censored_runs_enter_through_a_survival_likelihood(small_atlas: Atlas) -> None:
    """200 pads, about 70% removed before failure: K as if every pad had run to failure."""
    lives, log = _fleet_log(np.random.default_rng(0), 200)
    full = PhysicsPredictor(small_atlas).fit(synthetic_log(lives, with_truth=False))
    p = PhysicsPredictor(small_atlas).fit(log)
    ends = log.groupby("run_id", sort=False)["failed"].last()
    assert 0.6 < 1 - ends.mean() < 0.8  # censored share
    assert p.k_avg == pytest.approx(full.k_avg, rel=0.01)
    assert p.k_runs is not None and p.k_runs[~ends.to_numpy()].isna().all()
    failures_only = PhysicsPredictor(small_atlas).fit(log[log["run_id"].isin(ends.index[ends])])
    lengths_as_lives = PhysicsPredictor(small_atlas).fit(log.drop(columns="failed"))
    assert p.k_avg and full.k_avg and failures_only.k_avg and lengths_as_lives.k_avg
    assert failures_only.k_avg > 1.03 * full.k_avg  # short lives are over-represented
    assert lengths_as_lives.k_avg > 1.2 * full.k_avg


def test_measured_volumes_are_evidence_of_k(small_atlas: Atlas) -> None:
    """Every pad removed at 50-90% of its life, its volume measured with 2% noise."""
    rng = np.random.default_rng(1)
    lives = np.round(1000.0 / rng.normal(1.0, 0.1, 40)).astype(int).tolist()
    full = synthetic_log(lives, with_truth=False)
    v_fail = small_atlas.failure_volume
    parts = []
    for (_, g), life in zip(full.groupby("run_id", sort=False), lives, strict=True):
        g = g[g["event"] < int(rng.uniform(0.5, 0.9) * life)].copy()
        done = g["event"].iloc[-1] + 1.0  # volume after the last event, this model's line
        v = (1 - (1 - v_fail) * done / life) * (1 + 0.02 * rng.standard_normal())
        g["measured_volume_frac"] = np.where(g["event"] == done - 1, v, np.nan)
        parts.append(g.assign(failed=False))
    p = PhysicsPredictor(small_atlas).fit(pd.concat(parts))
    truth = PhysicsPredictor(small_atlas).fit(full)
    assert p.k_avg == pytest.approx(truth.k_avg, rel=0.02)
    assert p.k_runs is not None and p.k_runs.notna().all()


def test_mid_life_log_gets_the_line_of_its_events(small_atlas: Atlas) -> None:
    p = PhysicsPredictor(small_atlas).fit(synthetic_log([300, 400]))
    whole = predict_log(p, synthetic_log([500], prefix="test"))
    tail = whole[whole["event"] >= 123]
    log = synthetic_log([500], prefix="test")
    got = predict_log(p, log[log["event"] >= 123], batch_events=29)
    pd.testing.assert_frame_equal(got, tail.reset_index(drop=True))


def test_saved_and_loaded_without_pickle(small_atlas: Atlas, tmp_path: Path) -> None:
    _, log = _fleet_log(np.random.default_rng(2), 10)
    p = PhysicsPredictor(small_atlas).fit(log)
    save_predictor(p, tmp_path / "m", small_atlas)
    q = load_predictor(tmp_path / "m", small_atlas)
    assert isinstance(q, PhysicsPredictor) and q.k_avg == p.k_avg and q.k_std == p.k_std
    assert p.k_runs is not None and q.k_runs is not None
    pd.testing.assert_series_equal(q.k_runs, p.k_runs)
    test = synthetic_log([700], prefix="test")
    pd.testing.assert_frame_equal(predict_log(q, test), predict_log(p, test))


def test_fleet_equals_one_predictor_per_pad(small_atlas: Atlas) -> None:
    p = PhysicsPredictor(small_atlas).fit(synthetic_log([300, 400]))
    n = assert_fleet_matches_loop(p, synthetic_log([350, 500, 420, 610, 280], prefix="t"), 0)
    assert n > 100
