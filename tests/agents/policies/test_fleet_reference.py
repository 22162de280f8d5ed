"""The perfect-information reference (agents.policies.fleet_reference): the program's value
against brute force on tiny cases, and its policy in the env against its prediction."""

from __future__ import annotations

import functools
import itertools

import numpy as np
import pytest

from agents.policies.fleet_reference import (
    ReferenceModel,
    ReferencePolicy,
    joint_choices,
    solve,
)
from agents.study.fleet_costs import run_episodes
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.shop import HOT, PARK, SERVICE
from brake_env.model.wear import WearModel

TOY_WEAR = WearModel.from_layer_wear(np.ones(1), np.full(1, 0.5), np.ones(1), 1.0)


def toy(h_new, w_new, **kwargs) -> ReferenceModel:
    cfg = FleetConfig(n_vehicles=2, hot_need=1, **kwargs)
    return ReferenceModel(cfg, TOY_WEAR, np.array(h_new), np.array(w_new, dtype=float))


def brute_force_value(m: ReferenceModel, h0: tuple[int, ...]) -> float:
    """Expectimax by explicit recursion over (t, per-vehicle (h, d)), written apart from
    the program: per vehicle and choice the list of (probability, next (h, d), cost)."""
    c = m.config
    R, p = c.breakdown_repair_shifts, c.breakdown_rate

    def moves(h: int, d: int, choice: int, window: bool) -> list[tuple[float, tuple, float]]:
        nd = max(d - 1, 0)
        if choice == PARK:
            return [(1.0, (h, nd), 0.0)]
        new = list(zip(m.w_new, m.h_new.tolist(), strict=True))
        if choice == SERVICE:
            fit = m.fit_cost if (window or d > 0) else m.visit_cost
            return [(w, (hn, nd), fit) for w, hn in new]
        if h == 0:  # hot on an empty pad: failure, corrective fit
            return [(w, (hn, 0), m.fail_cost) for w, hn in new]
        return [(1 - p, (h - 1, 0), 0.0), (p, (h - 1, R), 0.0)]

    @functools.cache
    def value(t: int, state: tuple) -> float:
        if t == c.episode_shifts:
            return 0.0
        window = c.is_window(t)
        best = np.inf
        for joint in itertools.product((HOT, PARK, SERVICE), repeat=2):
            if any(j == HOT and (window or d > 0) for j, (_, d) in zip(joint, state, strict=True)):
                continue
            short = 0.0 if window else c.costs.shortfall * max(1 - joint.count(HOT), 0)
            total = short
            per = [moves(h, d, j, window) for j, (h, d) in zip(joint, state, strict=True)]
            for combo in itertools.product(*per):
                prob = np.prod([o[0] for o in combo])
                total += prob * (
                    sum(o[2] for o in combo) + value(t + 1, tuple(o[1] for o in combo))
                )
            best = min(best, total)
        return best

    return value(0, tuple((h, 0) for h in h0))


@pytest.mark.parametrize("rate", [0.0, 0.25])
def test_program_value_is_the_brute_force_optimum(rate):
    m = toy([2, 4], [0.3, 0.7], episode_shifts=6, window_period=3, breakdown_rate=rate)
    sol = solve(m)
    for h0 in itertools.product(range(m.H + 1), repeat=2):
        v = float(sol.values[0][h0[0], 0, h0[1], 0])
        assert v == pytest.approx(brute_force_value(m, h0), rel=1e-5), h0
    # with no tail the plan's cost over the episode is the optimum itself
    np.testing.assert_allclose(sol.plan_cost[0], sol.values[0], rtol=1e-6)


def test_open_loop_enumeration_agrees_when_everything_is_deterministic():
    """No breakdowns, one new-pad life: the optimum is the best of all action sequences."""
    m = toy([3], [1.0], episode_shifts=5, window_period=3, breakdown_rate=0.0)
    c = m.config
    best = np.inf
    steps = [joint_choices(m, c.is_window(t)) for t in range(c.episode_shifts)]
    for plan in itertools.product(*steps):
        h, cost = [1, 2], 0.0
        for t, joint in enumerate(plan):
            window = c.is_window(t)
            cost += 0.0 if window else c.costs.shortfall * max(1 - joint.count(HOT), 0)
            for v, j in enumerate(joint):
                if j == SERVICE:
                    cost, h[v] = cost + (m.fit_cost if window else m.visit_cost), 3
                elif j == HOT and h[v] == 0:
                    cost, h[v] = cost + m.fail_cost, 3
                elif j == HOT:
                    h[v] -= 1
        best = min(best, cost)
    assert float(solve(m).values[0][1, 0, 2, 0]) == pytest.approx(best)


def test_tail_makes_the_plan_keep_pads_going_at_the_end():
    m = toy([2, 4], [0.5, 0.5], episode_shifts=6, window_period=3, breakdown_rate=0.0)
    short, long = solve(m), solve(m, tail=12)
    # planning beyond the episode can only cost more within it than the episode's optimum
    assert np.all(long.plan_cost[0] >= short.values[0] - 1e-3)


def test_reference_model_rejects_big_fleets():
    with pytest.raises(ValueError, match="<= 2 vehicles"):  # checked before the atlas is read
        ReferenceModel.build(FleetConfig(n_vehicles=3, hot_need=1), None)  # type: ignore[arg-type]


@pytest.fixture(scope="module")
def small_fleet():
    # K 2.5x the default's: pads last ~70 hot shifts, so a short episode has fits to plan
    cfg = FleetConfig(
        n_vehicles=2, hot_need=1, episode_shifts=150, breakdown_rate=0.0, k_mean=5e-6,
        k_std=5e-7,
    )  # fmt: skip
    env = BrakeWearFleetEnv(cfg)
    model = ReferenceModel.build(cfg, env.atlas, n_k=8)
    return env, model, solve(model)


def test_reference_policy_realises_its_predicted_cost(small_fleet):
    """Without breakdowns the only randomness left is the law-of-large-numbers wear and the
    new pads' K: the realised cost on the model's terms is the prediction within 10% on
    average over 3 episodes (measured: 1333 predicted and realised; one window fit is
    1000), never a failure, never a shortfall, and there were fits to plan."""
    env, model, sol = small_fleet
    policy = ReferencePolicy(env, model, sol, s=1, S=2)
    eps = run_episodes(env, policy, [1, 2, 3], check_masks=True)
    predicted = []
    for seed in (1, 2, 3):
        env.reset(seed=seed)
        truth = env.truth()
        predicted.append(
            sol.predicted(model, model.state(truth["volume_frac"], truth["wear_coeff"]))
        )
    realised = [e.model_terms * e.vehicles * e.shifts for e in eps]
    assert np.mean(realised) == pytest.approx(np.mean(predicted), rel=0.10)
    assert sum(e.counts["failures"] + e.counts["shortfall"] for e in eps) == 0
    assert sum(e.fits for e in eps) >= 3
