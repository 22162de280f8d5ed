"""The net's credit for pad life left (BrakeWearFleet-v2): priced over a new pad's life
with each wear label at its mean K. In the ``id`` regime that is v1's mean-K pad exactly,
so v1 and v2 give the same episodes; in ``mixed`` a fresh pad is credited about its cost
(v1's price credited it 1.34 times), and v1 refuses the fleet, naming v2."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import brake_env  # noqa: F401  (registers the fleet envs)
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.episode_cost import credit_life
from brake_env.env.fleet.routes import HOT, route_wear_model


def _fresh_pad_credit_over_cost(config: FleetConfig, life: float, wear) -> float:
    """A new pad's mean credit over the fit's cost, on 100,000 of the env's own draws."""
    rng = np.random.default_rng(7)
    k = np.array([config.pad_regime.draw(rng)[0] for _ in range(100_000)])
    return float(np.mean(wear.life(k)) / life)


def test_the_credit_life_is_the_mean_k_pad_s_in_id_and_the_labels_mean_in_mixed(atlas) -> None:
    wear = route_wear_model(atlas, HOT)
    idc = FleetConfig()
    assert credit_life(idc, wear) == float(wear.life(idc.k_mean))  # bit for bit: v1's
    mixed = FleetConfig(regime="mixed")
    w = mixed.wear
    want = 0.5 * float(wear.life(w.k_mean)) + 0.25 * float(
        wear.life(w.mean("ood-slow")) + wear.life(w.mean("ood-fast"))
    )
    assert credit_life(mixed, wear) == pytest.approx(want, rel=1e-12)
    # slow pads outlive the mean-K pad by more than fast ones fall short of it (1/K convex)
    assert credit_life(mixed, wear) > 1.2 * credit_life(idc, wear)


def test_a_fresh_pad_is_credited_about_its_cost_in_every_regime(atlas) -> None:
    """The Jensen gap left is within each label's spread (id: 1%); v1's price, the mean-K
    pad's life, credits a fresh mixed pad a third above its cost."""
    wear = route_wear_model(atlas, HOT)
    for regime, most in (("id", 1.02), ("mixed", 1.06), ("ood", 1.08)):
        c = FleetConfig(regime=regime)
        ratio = _fresh_pad_credit_over_cost(c, credit_life(c, wear), wear)
        assert 1.0 < ratio < most, regime
    mixed = FleetConfig(regime="mixed")
    v1 = _fresh_pad_credit_over_cost(mixed, float(wear.life(mixed.k_mean)), wear)
    assert v1 > 1.3


def _episode_net(env_id: str, atlas, **kwargs) -> dict:
    env = gym.make(env_id, fleet="small", atlas=atlas, episode_shifts=30, **kwargs)
    env.reset(seed=5)
    rng = np.random.default_rng(0)
    info: dict = {}
    for _ in range(30):
        masks = np.split(env.unwrapped.action_masks(), np.cumsum(env.action_space.nvec)[:-1])
        action = np.array([rng.choice(np.flatnonzero(m)) for m in masks])
        *_, info = env.step(action)
    return info["episode_cost"]


def test_v1_is_v2_on_an_id_fleet_and_refuses_a_mixed_one(atlas) -> None:
    assert _episode_net("BrakeWearFleet-v1", atlas) == _episode_net("BrakeWearFleet-v2", atlas)
    mixed = _episode_net("BrakeWearFleet-v2", atlas, regime="mixed")
    assert mixed["net"] < mixed["cost"]
    with pytest.raises(ValueError, match=r"replaced by BrakeWearFleet-v2 .*'mixed'"):
        gym.make("BrakeWearFleet-v1", fleet="small", atlas=atlas, regime="mixed")
