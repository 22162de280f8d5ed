"""The cost study's pads against BrakeWear-v0: evaluated pad by pad, a policy takes each pad
off where the env takes it off; every policy meets the same pads."""

from __future__ import annotations

import numpy as np
import pytest

from agents.learning.features import AgentFeatures, pad_observations
from agents.policies.rules import ReplaceOnFailure, RULThreshold
from agents.study import outcomes as oc
from agents.study.pads import PadDraws, collect_pads
from brake_env.env.brake_wear import BrakeWearEnv
from brake_env.env.config import EnvConfig
from brake_env.env.wrappers import RULObservation
from brake_env.model.regime import WearRegime
from brake_env.prognostics.registry import fit_predictors

FAST = {
    "k_mean": 1e-5,
    "k_std": 1e-6,
    "decision_interval": 500,
    "episode_events": 150_000,
    "regime": "mixed",
}


@pytest.fixture(scope="module")
def fitted(atlas):
    predictors, _ = fit_predictors(("physics", "oracle"), atlas, 0, 2, WearRegime(1e-5, 1e-6))
    return predictors


def env_pads(config: EnvConfig, seed: int, n: int) -> list[PadDraws]:
    """The first n pads an episode of BrakeWear-v0 with ``seed`` installs, in the order
    its pad service draws them (K and label, then the pad's seed)."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        k, label = config.pad_regime.draw(rng)
        entropy = int(rng.integers(2**63))
        out.append(PadDraws(np.array([k]), np.array([label]), np.array([entropy]), {label: 1.0}))
    return out


def replay(atlas, config, fitted, name, threshold, seed):
    """The env's episode rebuilt pad by pad: each pad's first decision comes where the env
    puts it (age 1 for the episode's first pad, the rest of the step after a failure)."""
    d, first, done, out = config.decision_interval, 1, 0, []
    for draws in env_pads(config, seed, 40):
        pads = collect_pads(draws, atlas, config, {name: fitted[name]}, first=[first])
        est = pads.estimates[name]["rul_mean"]
        o = oc.threshold_outcomes(pads, est, np.array([threshold]))[0]
        life, events = int(pads.life[0]), int(o.events[0])
        out.append((0 if o.failed[0] else life - events, life, str(draws.label[0])))
        last = int(pads.age[-1]) if o.failed[0] else 0
        first = last + d - life if o.failed[0] else d
        done += events
        if done >= config.episode_events:
            return out
    raise AssertionError("episode longer than 40 pads")


def run_env(atlas, fitted, name, threshold, seed):
    env = RULObservation(BrakeWearEnv(atlas=atlas, **FAST), fitted[name])
    obs, _ = env.reset(seed=seed)
    retired, done = [], False
    while not done:
        action, _ = RULThreshold(threshold).predict(obs)
        obs, _, terminated, truncated, info = env.step(action)
        done = terminated or truncated
        retired += [(p.life_left, p.life, p.regime) for p in info["retired"]]
    return retired


@pytest.mark.parametrize(("name", "threshold"), [("oracle", 500), ("physics", 3000)])
def test_pads_are_taken_off_where_the_env_takes_them_off(atlas, fitted, name, threshold):
    config = EnvConfig.from_kwargs(**FAST)
    failures = 0
    for seed in (3, 4):
        in_env = run_env(atlas, fitted, name, threshold, seed)
        by_pad = replay(atlas, config, fitted, name, threshold, seed)
        assert len(in_env) >= 3 and in_env == by_pad[: len(in_env)]
        failures += sum(p[0] == 0 for p in in_env)
    assert (failures == 0) == (name == "oracle")  # physics fails some: phases are tested


def test_an_agent_sees_the_same_observations_pad_by_pad(atlas, fitted):
    """``pad_observations`` at each decision point equals ``AgentFeatures`` in the env."""
    config = EnvConfig.from_kwargs(**FAST)
    env = AgentFeatures(RULObservation(BrakeWearEnv(atlas=atlas, **FAST), fitted["physics"]))
    obs, _ = env.reset(seed=5)
    seen, first, done = [[obs]], [1], False
    while not done:
        obs, _, terminated, truncated, info = env.step(ReplaceOnFailure().predict(obs)[0])
        done = terminated or truncated
        if info["retired"]:  # a failure: the next pad's first decision is this step's end
            seen.append([])
            first.append(env.unwrapped.pad_age)
        seen[-1].append(obs)
    draws = env_pads(config, 5, len(seen))
    for i, obs_env in enumerate(seen[:-1]):  # the last pad is cut by truncation
        pads = collect_pads(draws[i], atlas, config, fitted, first=[first[i]])
        by_pad = pad_observations(pads, "physics", ("rul_mean",), config.episode_events)
        assert np.array_equal(np.array(obs_env), by_pad)


def test_every_policy_meets_the_same_pads(atlas, fitted):
    """A pad set is a function of its draws: the predictors run over it change nothing
    else, and drawing again gives the same pads (common random numbers)."""
    config = EnvConfig.from_kwargs(**FAST)
    draws = PadDraws.stratified(config.pad_regime, 2, [7, 1])
    assert np.array_equal(draws.label, ["id"] * 2 + ["ood-slow"] * 2 + ["ood-fast"] * 2)
    again = PadDraws.stratified(config.pad_regime, 2, [7, 1])
    assert np.array_equal(draws.entropy, again.entropy)
    both = collect_pads(draws, atlas, config, fitted)
    one = collect_pads(again, atlas, config, {"oracle": fitted["oracle"]})
    assert np.array_equal(both.life, one.life) and np.array_equal(both.measured, one.measured)
    assert np.array_equal(both.estimates["oracle"]["rul_mean"], one.estimates["oracle"]["rul_mean"])
    # The oracle's estimate is the true RUL: life - age at every decision point.
    assert np.array_equal(
        both.estimates["oracle"]["rul_mean"], both.life[both.pad_of_row] - both.age
    )
    other = PadDraws.stratified(config.pad_regime, 2, [7, 2])
    assert not set(other.entropy) & set(draws.entropy)
