"""Physics-based baseline: calibration of K and the straight-line RUL, in closed form."""

from __future__ import annotations

import numpy as np
import pytest

from baselines._runs import run_lives, true_rul
from baselines.physics import PhysicsPredictor
from brake_env.model.atlas import Atlas
from brake_env.model.materials import hardness_mpa
from brake_env.model.physics import simulate_events
from brake_env.prognostics.protocol import EventBatch, predict_log
from tests.baselines.synthetic import synthetic_log


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
    assert 140 < h20 < 160  # README "The model": 152 MPa at 20 C
    mc = model.brake.normal_force_n * 1e-6 * r.sliding_dist_m.mean() / h20
    assert PhysicsPredictor(atlas).wear_per_k_m3 == pytest.approx(mc, rel=0.02)


def test_training_runs_need_a_known_life(small_atlas: Atlas) -> None:
    log = synthetic_log([50, 60], with_truth=False)
    assert run_lives(log).tolist() == [50, 60]
    np.testing.assert_array_equal(true_rul(log)[:3], [49, 48, 47])
    cut = log[log["event"] < 40]  # runs cut short, no truth: life unknown
    with pytest.raises(ValueError, match="do not end at failure"):
        PhysicsPredictor(small_atlas).fit(cut)
    truncated = synthetic_log([50, 60])
    truncated = truncated[truncated["event"] < 40]  # with truth, the life is still known
    assert run_lives(truncated).tolist() == [50, 60]
    with pytest.raises(RuntimeError, match="fit"):
        PhysicsPredictor(small_atlas).update(EventBatch.from_frame(log[log["run_id"] == "run-00"]))
