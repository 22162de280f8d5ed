"""MaskablePPO on BrakeWearFleet-v0 (agents.fleet.learning.agent): tiny budgets, a smoke
test of the plumbing (masks, normalisation, determinism, the behaviour-cloning warm start),
not of learning."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from agents.fleet.evaluation.costs import run_episode
from agents.fleet.learning.agent import (
    ReorderBy,
    oracle_fleet_env,
    train_fleet_agent,
)
from agents.fleet.learning.imitation import record
from agents.fleet.policies.rules import FleetRule, FleetRuleParams
from agents.fleet.policies.view import FleetLayout
from agents.fleet.settings import IMITATION_SEED0, FleetTraining
from brake_env.env.fleet.shop import HOT, SERVICE
from tests.agents.fleet.learning.small_fleet import CFG, agreement

pytest.importorskip("sb3_contrib")

TINY = FleetTraining(timesteps=64, n_envs=2, n_steps=32, batch_size=32, n_epochs=1, seed=3)


@pytest.fixture(scope="module")
def agent(atlas):
    return train_fleet_agent(lambda: oracle_fleet_env(CFG, atlas), FleetLayout.of(CFG), TINY)


def test_agent_respects_the_mask_along_an_episode(agent, atlas) -> None:
    env = oracle_fleet_env(CFG, atlas)
    ep = run_episode(env, agent, seed=5, check_masks=True)  # raises on a masked action
    assert ep.shifts == 20 and np.isfinite(ep.per_vehicle_shift)


def test_same_seed_same_agent(agent, atlas) -> None:
    again = train_fleet_agent(lambda: oracle_fleet_env(CFG, atlas), FleetLayout.of(CFG), TINY)
    env = oracle_fleet_env(CFG, atlas)
    obs, _ = env.reset(seed=1)
    for _ in range(10):
        a1, _ = agent.predict(obs)
        a2, _ = again.predict(obs)
        np.testing.assert_array_equal(a1, a2)
        obs, *_ = env.step(a1)
    np.testing.assert_array_equal(agent.mean, again.mean)


def test_observations_are_normalised_with_frozen_statistics(agent, atlas) -> None:
    env = oracle_fleet_env(CFG, atlas)
    obs, _ = env.reset(seed=2)
    z = agent.normalize(obs)
    assert z.dtype == np.float32 and np.all(np.abs(z) <= agent.clip)
    assert agent.mean.shape == obs.shape and np.all(agent.std > 0)


def test_bad_training_settings_raise() -> None:
    with pytest.raises(ValueError, match="gamma"):
        FleetTraining(gamma=1.5)
    with pytest.raises(ValueError, match="n_envs"):
        FleetTraining(n_envs=0)
    with pytest.raises(ValueError, match="reorder"):
        FleetTraining(reorder=(3, 1))


def test_reorder_by_rule_leaves_the_agent_the_duties(atlas) -> None:
    env = ReorderBy(oracle_fleet_env(CFG, atlas), s=2, S=4)
    assert tuple(env.action_space.nvec) == (4, 4)
    env.reset(seed=0)
    base = env.unwrapped
    stock, transit = base.shop.stock, base.shop.in_transit
    _, _, _, _, info = env.step(np.array([SERVICE, HOT]))
    # the order is (s, S) on the position after the fit: stock + transit - 1 < 2 orders
    position = stock + transit - 1
    assert info["counts"]["ordered"] == (0 if position >= 2 else 4 - position)
    assert env.action_masks().shape == (8,)
    agent = train_fleet_agent(
        lambda: oracle_fleet_env(CFG, atlas), FleetLayout.of(CFG),
        dataclasses.replace(TINY, reorder=(2, 4)),
    )  # fmt: skip
    ep = run_episode(oracle_fleet_env(CFG, atlas), agent, seed=5, check_masks=True)
    assert ep.shifts == 20 and ep.counts["ordered"] <= 4 * 20


# ------------------------------------------------------- the warm start (behaviour cloning)
TEACHER = FleetRuleParams(
    must=3.0, window_limit=12.0, shop_limit=8.0, greedy=True, duty="rul", spare_duty="park",
    s=1, S=2,
)  # fmt: skip
CLONE = dataclasses.replace(
    TINY, timesteps=0, imitation_episodes=8, imitation_epochs=30, batch_size=16
)


def _teacher() -> FleetRule:
    return FleetRule(FleetLayout.of(CFG), TEACHER, "teacher")


@pytest.fixture(scope="module")
def clone(atlas):
    return train_fleet_agent(
        lambda: oracle_fleet_env(CFG, atlas), FleetLayout.of(CFG), CLONE, teacher=_teacher()
    )


def test_clone_acts_like_its_teacher_on_held_out_episodes(clone, atlas) -> None:
    assert clone.imitation is not None
    assert clone.imitation.samples == 8 * 20 and clone.imitation.agreement >= 0.95
    assert np.isnan(clone.imitation.on_policy)  # no DAgger round
    assert agreement(clone, _teacher(), atlas) >= 0.95  # measured 1.0
    ep = run_episode(oracle_fleet_env(CFG, atlas), clone, seed=9, check_masks=True)
    assert ep.shifts == 20


def test_clone_statistics_are_the_teachers_observations(clone, atlas) -> None:
    # without PPO the frozen statistics are those of the recorded episodes (their seeds
    # are apart from the evaluation's: IMITATION_SEED0 * (seed + 1) + k)
    seeds = [IMITATION_SEED0 * (CLONE.seed + 1) + k for k in range(8)]
    demo = record(oracle_fleet_env(CFG, atlas), _teacher(), seeds, drop_order=False)
    assert min(seeds) > 20_000 + 10_000
    np.testing.assert_allclose(clone.mean, demo.obs.mean(axis=0), rtol=1e-4, atol=1e-4)


def test_same_seed_same_clone(clone, atlas) -> None:
    again = train_fleet_agent(
        lambda: oracle_fleet_env(CFG, atlas), FleetLayout.of(CFG), CLONE, teacher=_teacher()
    )
    assert again.imitation is not None and clone.imitation is not None
    assert again.imitation.nll == clone.imitation.nll
    np.testing.assert_array_equal(again.mean, clone.mean)
    env = oracle_fleet_env(CFG, atlas)
    obs, _ = env.reset(seed=1)
    for _ in range(20):
        a1, _ = clone.predict(obs)
        np.testing.assert_array_equal(a1, again.predict(obs)[0])
        obs, *_ = env.step(a1)


def test_clone_then_ppo_with_dagger_and_reorder(atlas) -> None:
    settings = dataclasses.replace(CLONE, timesteps=64, imitation_rounds=1, reorder=(1, 2))
    agent = train_fleet_agent(
        lambda: oracle_fleet_env(CFG, atlas), FleetLayout.of(CFG), settings, teacher=_teacher()
    )
    assert agent.imitation is not None and agent.imitation.samples == 2 * 8 * 20
    assert 0.0 <= agent.imitation.on_policy <= 1.0
    # the order is the (s, S) rule's, the teacher's own here: the clone decides duties only
    ep = run_episode(oracle_fleet_env(CFG, atlas), agent, seed=5, check_masks=True)
    assert ep.shifts == 20


def test_teacher_breaking_the_mask_raises(atlas) -> None:
    class AlwaysHot:  # hot duty is masked at a window (shift 13 of 20)
        def predict(self, obs, deterministic=True):
            return np.array([HOT, HOT, 0]), None

    with pytest.raises(ValueError, match="broke"):
        train_fleet_agent(
            lambda: oracle_fleet_env(CFG, atlas), FleetLayout.of(CFG), CLONE, teacher=AlwaysHot()
        )


def test_bad_imitation_settings_raise(atlas) -> None:
    make, layout = (lambda: oracle_fleet_env(CFG, atlas)), FleetLayout.of(CFG)
    with pytest.raises(ValueError, match="teacher"):
        train_fleet_agent(make, layout, CLONE)  # episodes without a teacher
    with pytest.raises(ValueError, match="teacher"):
        train_fleet_agent(make, layout, TINY, teacher=_teacher())  # a teacher, no episodes
    with pytest.raises(ValueError, match="timesteps"):
        FleetTraining(timesteps=0)  # nothing to learn from
    with pytest.raises(ValueError, match="imitation_epochs"):
        FleetTraining(imitation_episodes=2, imitation_epochs=0)
    with pytest.raises(ValueError, match="imitation_rounds"):
        FleetTraining(imitation_episodes=2, imitation_rounds=-1)
    with pytest.raises(ValueError, match="clip_range"):
        FleetTraining(clip_range=0.0)
