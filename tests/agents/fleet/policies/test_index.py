"""The Lagrangian index policy (agents.fleet.policies.index): the assignment is the exact
optimum of brute force on tiny fleets, the policy never makes the env defer or refuse a
request, and it is deterministic for a seed."""

from __future__ import annotations

import functools
import itertools

import numpy as np
import pytest

from agents.fleet.policies.index import IndexPolicy, assign
from agents.fleet.policies.lagrangian import BoundModel, start_counts
from agents.fleet.policies.lagrangian_search import search
from agents.fleet.policies.view import FleetLayout
from brake_env.env.fleet.config import FleetConfig, FleetCosts
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.rules import fits_capacity, shortfall_cost
from brake_env.env.fleet.shop import HOT, MILD, SERVICE
from brake_env.env.fleet.wrappers import ExpectedRULObservation


def tiny(n: int) -> FleetConfig:
    return FleetConfig(n_vehicles=n, hot_need=1, mild_need=1, window_slots=1, bays=1,
                       episode_shifts=30, costs=FleetCosts())  # fmt: skip


def total(config, values, duty, window) -> float:
    picked = values[np.arange(len(duty)), duty]
    on_hot, on_mild = int((duty == HOT).sum()), int((duty == MILD).sum())
    return float(picked.sum()) + shortfall_cost(config, on_hot, on_mild, window)


def brute_force(config, values, down, window, stock, free_bays) -> float:
    """The least total over every duty vector the env would serve in full."""
    best = np.inf
    for duty in itertools.product(range(4), repeat=len(values)):
        d = np.array(duty)
        drives = (d == HOT) | (d == MILD)
        barred = not np.all(np.isfinite(values[np.arange(len(d)), d]))
        if barred or np.any(drives & (down | window)):
            continue
        if not fits_capacity(config, window, d == SERVICE, down, stock, free_bays):
            continue
        best = min(best, total(config, values, d, window))
    return best


@pytest.mark.parametrize("n", [2, 3])
def test_assignment_is_the_brute_force_optimum(n):
    config = tiny(n)
    rng = np.random.default_rng(n)
    for _ in range(40):
        values = rng.normal(0.0, 1500.0, (n, 4))
        values[rng.random((n, 4)) < 0.1] = np.inf
        values[:, 2] = rng.normal(0.0, 1500.0, n)  # parking is always allowed
        down = rng.random(n) < 0.3
        window = bool(rng.random() < 0.3)
        stock, bays = int(rng.integers(0, 3)), int(rng.integers(0, 2))
        duty = assign(config, values, down, window, stock, bays)
        assert fits_capacity(config, window, duty == SERVICE, down, stock, bays)
        assert not np.any(((duty == HOT) | (duty == MILD)) & (down | window))
        got = total(config, values, duty, window)
        assert got == pytest.approx(brute_force(config, values, down, window, stock, bays),
                                    rel=1e-9, abs=1e-6)  # fmt: skip


def test_assign_refuses_bad_shapes():
    with pytest.raises(ValueError, match="values must be"):
        assign(tiny(2), np.zeros((2, 3)), np.zeros(2, dtype=bool), False, 1, 1)
    with pytest.raises(ValueError, match="parking"):
        assign(tiny(2), np.full((2, 4), np.inf), np.zeros(2, dtype=bool), False, 1, 1)


@functools.cache
def small_policy(atlas):
    cfg = FleetConfig(n_vehicles=4, hot_need=2, mild_need=1, window_slots=1, bays=1,
                      initial_stock=1, initial_age_max=0.95, episode_shifts=30,
                      costs=FleetCosts())  # fmt: skip
    env = BrakeWearFleetEnv(cfg, atlas=atlas)
    model = BoundModel.build(cfg, atlas, units=10, credit=True)
    states = []
    for seed in (100, 101):
        env.reset(seed=seed)
        tr = env.truth()
        states.append(model.state(tr["volume_frac"], tr["wear_coeff"]))
    result = search(model, start_counts(model, np.array(states)), iterations=5)
    return cfg, model, result


def run(atlas, seed: int, cover: float = 1.0) -> tuple[list[np.ndarray], list[dict]]:
    """The policy's actions and the env's per-shift counts over one episode."""
    cfg, model, result = small_policy(atlas)
    env = ExpectedRULObservation(BrakeWearFleetEnv(cfg, atlas=atlas))
    policy = IndexPolicy(FleetLayout.of(cfg), model, result.prices, result.program, s=1, S=2,
                         cover=cover, floor=0.1)  # fmt: skip
    obs, _ = env.reset(seed=seed)
    actions, counts, done = [], [], False
    while not done:
        action, _ = policy.predict(obs)
        actions.append(action)
        obs, _, terminated, truncated, info = env.step(action)
        counts.append(info["counts"])
        done = terminated or truncated
    return actions, counts


@pytest.mark.parametrize("cover", [0.0, 1e3])
def test_the_env_never_defers_nor_refuses_a_request(atlas, cover):
    # cover 1e3: every pad looks worn out, so every vehicle wants a fit and the stock, the
    # crew and the bays bind on every shift
    cfg, _, _ = small_policy(atlas)
    fits = 0
    for seed in (0, 1):
        _, counts = run(atlas, seed, cover)
        for t, c in enumerate(counts):
            assert c["deferred"] == 0 and c["refused"] == 0, (t, c)
            assert c["window_fits"] <= cfg.window_slots and c["visits"] <= cfg.bays, (t, c)
            fits += c["window_fits"] + c["shop_fits"] + c["visits"]
    if cover > 0:
        assert fits > 0  # the limits were exercised


def test_policy_is_deterministic_for_a_seed(atlas):
    a, _ = run(atlas, 3)
    b, _ = run(atlas, 3)
    assert np.array_equal(np.array(a), np.array(b))


def test_policy_refuses_bad_settings(atlas):
    cfg, model, result = small_policy(atlas)
    layout = FleetLayout.of(cfg)
    with pytest.raises(ValueError, match="s must be"):
        IndexPolicy(layout, model, result.prices, result.program, s=3, S=2)
    with pytest.raises(ValueError, match="cover"):
        IndexPolicy(layout, model, result.prices, result.program, cover=-1.0)
    with pytest.raises(ValueError, match="another fleet config"):
        IndexPolicy(FleetLayout.of(tiny(4)), model, result.prices, result.program)
