"""SB3 training on tiny budgets: determinism for a seed, the learning curve and its best
agent, agents evaluated pad by pad as in the env, the agent's observation."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch

from agents.learning.curve import agent_outcomes
from agents.learning.hyperparameters import load_hyperparams
from agents.learning.train import TrainedAgent, agent_env, train_agent
from agents.study import outcomes as oc
from agents.study.pads import PadDraws, collect_pads
from brake_env.env.config import EnvConfig
from brake_env.model.regime import WearRegime
from brake_env.prognostics.protocol import NoPrognostics, Oracle
from brake_env.prognostics.registry import fit_predictors
from tests.agents.budgets import FAST, FAST_ENV, TINY


@pytest.fixture(scope="module")
def curve_pads(atlas):
    config = EnvConfig.from_kwargs(**FAST, regime="mixed")
    draws = PadDraws.stratified(config.pad_regime, 2, [0, 3])
    return collect_pads(draws, atlas, config, {"oracle": Oracle()})


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
            Oracle(), atlas, tmp_path / run, timesteps=128, seed=3, env=FAST_ENV,
            hyperparams=TINY,
        )  # fmt: skip
        params.append(TrainedAgent(tmp_path / run).model.policy.state_dict())
    for k, v in params[0].items():
        assert torch.equal(v, params[1][k]), k
    for f in ("agent.json", "agent.npz", "obs_normalization.npz", "train.json"):
        assert (tmp_path / "a" / f).exists()


def test_the_learning_curve_keeps_the_best_agent(atlas, tmp_path, curve_pads):
    res = train_agent(
        Oracle(), atlas, tmp_path, timesteps=512, seed=0, env=FAST_ENV, hyperparams=TINY,
        curve_pads=curve_pads, n_evals=4,
    )  # fmt: skip
    points = json.loads((tmp_path / "learning_curve.json").read_text())["points"]
    assert points == res.curve  # every 64 vector steps of 2 envs, the last at the end
    assert [p["timesteps"] for p in points] == [128, 256, 384, 512]
    best = min(points, key=lambda p: p["ratio_to_oracle"])
    assert res.best_step == best["timesteps"] and all(p["ratio_to_oracle"] >= 1 for p in points)
    # The saved agent is that one: pad by pad it costs what the curve said.
    agent = TrainedAgent(tmp_path)
    out = agent_outcomes(agent, "oracle", curve_pads, ("rul_mean",), FAST["episode_events"])
    costs = EnvConfig().costs
    ratio = oc.cost_per_1000(curve_pads, out, costs) / oc.cost_per_1000(
        curve_pads, oc.oracle(curve_pads), costs
    )
    assert ratio == pytest.approx(best["ratio_to_oracle"], rel=1e-12)


def test_an_agent_takes_pads_off_pad_by_pad_where_it_does_in_the_env(atlas, tmp_path):
    """A (hand-set) agent that replaces below its mean RUL feature: its first replacement
    on each pad, from the pad-level observations, is where it replaces in the env."""
    train_agent(Oracle(), atlas, tmp_path, timesteps=64, seed=0, env=FAST_ENV, hyperparams=TINY)
    agent = TrainedAgent(tmp_path)
    with torch.no_grad():  # replace where the normalised RUL feature is below 0
        hidden, action = (
            agent.model.policy.mlp_extractor.policy_net[0],
            agent.model.policy.action_net,
        )
        hidden.weight.zero_(), hidden.bias.zero_(), action.weight.zero_(), action.bias.zero_()
        hidden.weight[0, 1] = 1.0
        action.weight[1, 0] = -10.0
    env = agent_env(
        Oracle(), atlas, EnvConfig.from_kwargs(FAST_ENV, episode_events=200_000, regime="mixed")
    )
    obs, _ = env.reset(seed=2)
    config = EnvConfig.from_kwargs(**FAST, regime="mixed")
    rng = np.random.default_rng(2)
    taken, done = [], False
    while not done:
        obs, _, terminated, truncated, info = env.step(agent.predict(obs)[0])
        done = terminated or truncated
        taken += [(p.life_left, p.life) for p in info["retired"]]
    assert len(taken) >= 3 and all(t[0] > 0 for t in taken)  # planned: no phase shifts
    for i in range(len(taken)):
        k, label = config.pad_regime.draw(rng)
        draws = PadDraws(
            np.array([k]), np.array([label]), np.array([rng.integers(2**63)]), {label: 1}
        )
        first = [1 if i == 0 else FAST["decision_interval"]]  # reset observes one event
        pads = collect_pads(draws, atlas, config, {"oracle": Oracle()}, first=first)
        out = agent_outcomes(agent, "oracle", pads, ("rul_mean",), 200_000)
        assert (int(pads.life[0] - out.events[0]), int(pads.life[0])) == taken[i]


def test_an_agent_env_observes_age_and_rul_in_log_steps(atlas):
    env = agent_env(NoPrognostics(2e4), atlas, FAST_ENV)
    obs, _ = env.reset(seed=0)
    assert env.observation_space.contains(obs) and obs.shape == (2,)
    assert obs == pytest.approx(np.log1p(np.array([1, 2e4]) / 500))
    _, reward, *_ = env.step(1)
    assert reward == -1.0  # a planned replacement, in planned replacements
    predictors, _ = fit_predictors(("twin",), atlas, 0, 2, WearRegime(1e-5, 1e-6))
    assert agent_env(predictors["twin"], atlas, FAST_ENV).observation_space.shape == (3,)
