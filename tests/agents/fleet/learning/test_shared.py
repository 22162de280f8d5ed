"""Parameter-shared MaskablePPO on BrakeWearFleet-v0 (agents.fleet.learning.shared): the
per-vehicle adapter against the full env and the PettingZoo view, and a tiny training's
plumbing (masks, determinism, the cloning warm start), not learning."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from agents.fleet.evaluation.costs import run_episodes
from agents.fleet.learning.agent import oracle_fleet_env
from agents.fleet.learning.imitation import record
from agents.fleet.learning.shared import (
    SharedFleetVecEnv,
    train_shared_agent,
    vehicle_observations,
    vehicle_samples,
)
from agents.fleet.policies.rules import FleetRule, FleetRuleParams, reorder
from agents.fleet.policies.view import FleetLayout
from agents.fleet.settings import IMITATION_SEED0, FleetTraining
from brake_env.env.fleet.shop import SERVICE
from brake_env.env.fleet.spaces import FLEET_FEATURES, N_VF
from tests.agents.fleet.learning.small_fleet import CFG, agreement

pytest.importorskip("sb3_contrib")

N = CFG.n_vehicles
TINY = FleetTraining(timesteps=160, n_envs=2, n_steps=16, batch_size=32, n_epochs=1, seed=3)
S_S = (1, 2)


@pytest.fixture(scope="module")
def agent(atlas):
    return train_shared_agent(lambda: oracle_fleet_env(CFG, atlas), FleetLayout.of(CFG), TINY,
                              s=S_S[0], S=S_S[1])  # fmt: skip


R = 2  # RUL values per vehicle: the hot and the mild route's


def _duties(rng: np.random.Generator, masks: np.ndarray) -> np.ndarray:
    return np.array([rng.choice(np.flatnonzero(m)) for m in masks])


def test_vehicle_view_is_the_slices_of_the_fleet_observation(atlas) -> None:
    venv = SharedFleetVecEnv(lambda: oracle_fleet_env(CFG, atlas), 2, *S_S)
    ref = oracle_fleet_env(CFG, atlas)  # copy 1, stepped alongside
    venv.seed(7)
    obs = venv.reset()
    full, _ = ref.reset(seed=8)
    assert venv.num_envs == 2 * N and obs.shape == (2 * N, N_VF + R + len(FLEET_FEATURES))
    rng = np.random.default_rng(0)
    for _ in range(CFG.episode_shifts + 3):  # across an episode end
        veh, fleet = full[: N * N_VF].reshape(N, N_VF), full[N * N_VF : -R * N]
        rul = full[-R * N :].reshape(N, R)
        for v in range(N):
            np.testing.assert_array_equal(obs[N + v], np.concatenate([veh[v], rul[v], fleet]))
            assert venv.observation_space.contains(obs[N + v])
        masks = venv.action_masks()
        np.testing.assert_array_equal(masks[N:].ravel(), ref.unwrapped.action_masks()[: 4 * N])
        np.testing.assert_array_equal(np.stack(venv.env_method("action_masks")), masks)
        duties = _duties(rng, masks)
        obs, _, dones, infos = venv.step(duties)
        base = ref.unwrapped
        q = reorder(base.shop.stock, base.shop.in_transit, int((duties[N:] == SERVICE).sum()),
                    *S_S, CFG.max_order)  # fmt: skip
        full, _, term, trunc, _ = ref.step(np.append(duties[N:], q))
        if term or trunc:
            assert dones.all()
            last = vehicle_observations(full, N)
            for v in range(N):
                np.testing.assert_array_equal(infos[N + v]["terminal_observation"], last[v])
            full, _ = ref.reset()
        else:
            assert not dones.any()


def test_the_pettingzoo_view_plus_the_rul(atlas) -> None:
    pytest.importorskip("pettingzoo")
    from brake_env.env.fleet.parallel import BrakeWearFleetParallelEnv

    pz = BrakeWearFleetParallelEnv(CFG, atlas=atlas)
    venv = SharedFleetVecEnv(lambda: oracle_fleet_env(CFG, atlas), 1, *S_S)
    venv.seed(4)
    obs = venv.reset()
    pz_obs, _ = pz.reset(seed=4)
    for v in range(N):
        own = pz_obs[f"vehicle_{v}"]["observation"]
        np.testing.assert_array_equal(np.delete(obs[v], np.arange(N_VF, N_VF + R)), own)
        np.testing.assert_array_equal(venv.action_masks()[v], pz_obs[f"vehicle_{v}"]["action_mask"])


def test_every_vehicle_gets_the_fleets_reward_scaled(atlas) -> None:
    scale = 1e-3
    venv = SharedFleetVecEnv(lambda: oracle_fleet_env(CFG, atlas), 1, *S_S, reward_scale=scale)
    ref = oracle_fleet_env(CFG, atlas)
    venv.seed(2)
    venv.reset()
    ref.reset(seed=2)
    rng = np.random.default_rng(1)
    for _ in range(10):
        duties = _duties(rng, venv.action_masks())
        base = ref.unwrapped
        q = reorder(base.shop.stock, base.shop.in_transit, int((duties == SERVICE).sum()),
                    *S_S, CFG.max_order)  # fmt: skip
        _, rewards, _, _ = venv.step(duties)
        _, r, *_ = ref.step(np.append(duties, q))
        np.testing.assert_allclose(rewards, np.full(N, float(r) * scale, dtype=np.float32))


def test_agent_respects_the_mask_along_an_episode(agent, atlas) -> None:
    env = oracle_fleet_env(CFG, atlas)
    (ep,) = run_episodes(env, agent, [5], check_masks=True)  # raises on a masked action
    assert ep.shifts == CFG.episode_shifts and np.isfinite(ep.per_vehicle_shift)
    assert agent.mean.shape == (N_VF + R + len(FLEET_FEATURES),)


def test_same_seed_same_actions(agent, atlas) -> None:
    again = train_shared_agent(lambda: oracle_fleet_env(CFG, atlas), FleetLayout.of(CFG), TINY,
                               s=S_S[0], S=S_S[1])  # fmt: skip
    env = oracle_fleet_env(CFG, atlas)
    obs, _ = env.reset(seed=1)
    for _ in range(10):
        a1, _ = agent.predict(obs)
        a2, _ = again.predict(obs)
        np.testing.assert_array_equal(a1, a2)
        assert a1.shape == (N + 1,)
        obs, *_ = env.step(a1)
    np.testing.assert_array_equal(agent.mean, again.mean)


def test_agent_indicator_appends_the_vehicle_index(atlas) -> None:
    venv = SharedFleetVecEnv(lambda: oracle_fleet_env(CFG, atlas), 1, *S_S, agent_indicator=True)
    venv.seed(0)
    obs = venv.reset()
    np.testing.assert_array_equal(obs[:, -N:], np.eye(N))
    assert all(venv.observation_space.contains(o) for o in obs)


# ------------------------------------------------------- the warm start (behaviour cloning)
# A teacher a vehicle can follow from its own view: its RUL says when to go for service
TEACHER = FleetRule(
    FleetLayout.of(CFG),
    FleetRuleParams(must=3.0, window_limit=12.0, shop_limit=8.0, greedy=True, s=1, S=2),
    "teacher",
)
CLONE = dataclasses.replace(
    TINY, timesteps=0, imitation_episodes=8, imitation_epochs=30, batch_size=16
)


def test_vehicle_samples_are_each_vehicles_rows(atlas) -> None:
    env = oracle_fleet_env(CFG, atlas)
    demo = record(env, TEACHER, [3, 4], drop_order=False)
    got = vehicle_samples(demo, N, agent_indicator=True)
    steps = len(demo.rewards)
    assert got.obs.shape[0] == got.actions.shape[0] == got.masks.shape[0] == steps * N
    for t in (0, steps // 2, steps - 1):
        rows = slice(t * N, (t + 1) * N)
        np.testing.assert_array_equal(got.obs[rows], vehicle_observations(demo.obs[t], N, True))
        np.testing.assert_array_equal(got.actions[rows, 0], demo.actions[t, :N])
        np.testing.assert_array_equal(got.masks[rows].ravel(), demo.masks[t, : 4 * N])
        assert (got.rewards[rows] == demo.rewards[t]).all()
    np.testing.assert_array_equal(got.starts, demo.starts * N)


@pytest.fixture(scope="module")
def clone(atlas):
    return train_shared_agent(lambda: oracle_fleet_env(CFG, atlas), FleetLayout.of(CFG), CLONE,
                              s=1, S=2, teacher=TEACHER)  # fmt: skip


def test_shared_clone_acts_like_its_teacher_on_held_out_episodes(clone, atlas) -> None:
    assert clone.imitation is not None
    assert clone.imitation.samples == 8 * 20 * N and clone.imitation.agreement >= 0.9
    assert agreement(clone, TEACHER, atlas) >= 0.9  # the teacher drives


def test_shared_clone_statistics_are_the_teachers_vehicle_views(clone, atlas) -> None:
    seeds = [IMITATION_SEED0 * (CLONE.seed + 1) + k for k in range(8)]
    demo = record(oracle_fleet_env(CFG, atlas), TEACHER, seeds, drop_order=False)
    own = vehicle_samples(demo, N, agent_indicator=False).obs
    np.testing.assert_allclose(clone.mean, own.mean(axis=0), rtol=1e-4, atol=1e-4)


def test_shared_clone_then_ppo_with_dagger(atlas) -> None:
    settings = dataclasses.replace(CLONE, timesteps=32, imitation_rounds=1, imitation_episodes=2)
    agent = train_shared_agent(lambda: oracle_fleet_env(CFG, atlas), FleetLayout.of(CFG),
                               settings, s=1, S=2, teacher=TEACHER)  # fmt: skip
    assert agent.imitation is not None and agent.imitation.samples == 2 * 2 * 20 * N
    assert 0.0 <= agent.imitation.on_policy <= 1.0
    (ep,) = run_episodes(oracle_fleet_env(CFG, atlas), agent, [5], check_masks=True)
    assert ep.shifts == CFG.episode_shifts
    with pytest.raises(ValueError, match="teacher"):
        train_shared_agent(lambda: oracle_fleet_env(CFG, atlas), FleetLayout.of(CFG), CLONE,
                           s=1, S=2)  # fmt: skip
