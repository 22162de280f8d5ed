"""SB3 training (tiny budgets), save/load, and the cost comparison."""

from __future__ import annotations

import argparse
import json

import numpy as np
import pytest
import torch

from agents.cli import compare_and_report
from agents.compare import CompareConfig
from agents.hyperparameters import load_hyperparams
from agents.train import TrainedAgent, agent_env, train_agent
from brake_env.model.regime import WearRegime
from brake_env.prognostics.protocol import NoPrognostics, Oracle

FAST = {"k_mean": 1e-5, "k_std": 1e-6, "decision_interval": 500, "episode_events": 30_000}
TINY = {
    "n_envs": 2,
    "n_steps": 32,
    "batch_size": 32,
    "n_epochs": 1,
    "net_arch": [16],
    "pad_pool": 4,
    "initial_replace_prob": 0.05,
    "torch_threads": 1,
}


def test_hyperparameter_files_exist_for_every_predictor():
    for name in ("none", "physics", "data", "twin", "oracle"):
        for algo in ("ppo", "dqn"):
            assert "net_arch" in load_hyperparams(name, algo)
    with pytest.raises(ValueError, match="unknown algorithm"):
        load_hyperparams("twin", "a2c")


def test_training_twice_with_a_seed_gives_the_same_agent(atlas, tmp_path):
    params = []
    for run in ("a", "b"):
        train_agent(
            Oracle(),
            atlas,
            tmp_path / run,
            timesteps=128,
            seed=3,
            env_kwargs=FAST,
            hyperparams=TINY,
        )
        params.append(TrainedAgent(tmp_path / run).model.policy.state_dict())
    for k, v in params[0].items():
        assert torch.equal(v, params[1][k]), k
    out = tmp_path / "a"
    for f in ("model.zip", "vecnormalize.pkl", "obs_normalization.npz", "train.json"):
        assert (out / f).exists()
    assert any((out / "tb").iterdir()) and any((out / "checkpoints").iterdir())


def test_saved_agent_acts_like_the_trained_model(atlas, tmp_path):
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    train_agent(Oracle(), atlas, tmp_path, timesteps=64, seed=0, env_kwargs=FAST, hyperparams=TINY)
    agent, again = TrainedAgent(tmp_path), TrainedAgent(tmp_path)
    venv = VecNormalize.load(
        str(tmp_path / "vecnormalize.pkl"), DummyVecEnv([lambda: agent_env(Oracle(), atlas, FAST)])
    )
    env = agent_env(Oracle(), atlas, FAST)
    obs, _ = env.reset(seed=1)
    for _ in range(40):
        a1, _ = agent.predict(obs)
        assert np.array_equal(a1, again.predict(obs)[0])
        # The npz statistics normalise exactly as SB3's own VecNormalize does.
        z = venv.normalize_obs(obs[None])[0]
        assert np.allclose(agent.normalize(obs), z, atol=1e-6)
        assert int(a1) == int(agent.model.predict(z, deterministic=True)[0])
        obs, *_ = env.step(a1)


def test_tiny_comparison_writes_well_formed_costs_and_oracle_is_cheapest(atlas, tmp_path):
    config = CompareConfig(
        predictors=("none", "oracle"),
        agent_predictors=("oracle",),
        timesteps=64,
        n_train_runs=2,
        tune_seeds=1,
        eval_seeds=2,
        thresholds=(0, 1, 4),
        fixed_intervals=(10_000, 20_000),
        episode_events=FAST["episode_events"],
        wear=WearRegime(FAST["k_mean"], FAST["k_std"]),
    )
    args = argparse.Namespace(seed=0, quiet=True, preset="hot-duty", cache_dir=None, atlas=None)
    returned = compare_and_report(config, args, tmp_path, {"oracle": TINY})
    costs = json.loads((tmp_path / "costs.json").read_text())
    assert set(costs) == set(returned) and costs["eval_seeds"] == returned["eval_seeds"]
    assert (costs["config"]["k_mean"], costs["config"]["k_std"]) == (1e-5, 1e-6)
    policies = costs["policies"]
    expected = {"none/threshold", "oracle/threshold", "oracle/ppo", "fixed-interval"}
    assert expected | {"replace-on-failure", "oracle"} == set(policies)
    assert all(p["name"] == name for name, p in policies.items())
    # Every candidate was tuned, labelled with its parameter; the winners' parameters are
    # reported with their family.
    thresholds = {f"{n}/threshold/{h}" for n in ("none", "oracle") for h in (0, 500, 2000)}
    assert set(costs["tuning"]) == thresholds | {"fixed-interval/10000", "fixed-interval/20000"}
    for family, value in costs["tuned_parameters"].items():
        assert f"{family}/{value:g}" in costs["tuning"]
        assert policies[family]["parameter"] == value
    oracle = policies["oracle"]["cost_per_1000_events"]
    for name, p in policies.items():
        assert p["cost_per_1000_events"] >= oracle - 1e-9, name
        assert p["ratio_to_oracle"] == pytest.approx(p["cost_per_1000_events"] / oracle)
        assert set(p["failures_per_100_pads_by_regime"]) == {"id", "ood-slow", "ood-fast", "ood"}
    assert set(costs["sensitivity"]) == {"5", "10", "50"}
    for s in costs["sensitivity"].values():
        assert sorted(s["predictor_ranking"]) == ["none", "oracle"]
    for fig in ("cost_ratio", "replacement_timing", "cost_sensitivity"):
        assert (tmp_path / "figures" / f"{fig}.png").stat().st_size > 0


def test_compare_config_is_validated():
    with pytest.raises(ValueError, match="unknown predictor"):
        CompareConfig(predictors=("crystal-ball",))
    with pytest.raises(ValueError, match="not among the predictors"):
        CompareConfig(predictors=("none",), agent_predictors=("twin",))
    with pytest.raises(TypeError, match="WearRegime"):
        CompareConfig(wear=(1e-5, 1e-6))


def test_compare_config_passes_its_wear_regime_to_the_env():
    config = CompareConfig(wear=WearRegime(1e-5, 1e-6, 4.0))
    kwargs = config.env_kwargs
    assert (kwargs["k_mean"], kwargs["k_std"], kwargs["ood_shift_sigma"]) == (1e-5, 1e-6, 4.0)
    flat = config.to_dict()
    assert "wear" not in flat and (flat["k_mean"], flat["ood_shift_sigma"]) == (1e-5, 4.0)


def test_none_predictor_threshold_env_runs(atlas):
    env = agent_env(NoPrognostics(2e4), atlas, FAST)
    obs, _ = env.reset(seed=0)
    assert env.observation_space.contains(obs)
