"""MaskablePPO on BrakeWearFleet-v0 (agents.learning.fleet_agent): tiny budgets, a smoke
test of the plumbing (masks, normalisation, determinism), not of learning."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from agents.learning.fleet_agent import (
    FleetTraining,
    ReorderBy,
    oracle_fleet_env,
    train_fleet_agent,
)
from agents.policies.fleet_view import FleetLayout
from agents.study.fleet_costs import run_episode
from brake_env.env.fleet.config import SMALL_FLEET, FleetConfig
from brake_env.env.fleet.shop import HOT, SERVICE

pytest.importorskip("sb3_contrib")

CFG = FleetConfig(**SMALL_FLEET, episode_shifts=20, events_per_shift=100)
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
