"""The perfect-information reference (agents.fleet.policies.reference): the program's value
against brute force on tiny cases, and its policy in the env against its prediction."""

from __future__ import annotations

import dataclasses
import functools
import itertools

import numpy as np
import pytest

from agents.fleet.evaluation.costs import run_episodes
from agents.fleet.policies.reference import (
    ReferenceModel,
    ReferencePolicy,
    joint_choices,
    solve,
)
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.shop import HOT, MILD, PARK, SERVICE
from brake_env.model.wear import WearModel

TOY_WEAR = WearModel.from_layer_wear(np.ones(1), np.full(1, 0.5), np.ones(1), 1.0)


def toy(h_new, w_new, r_mild=0.4, **kwargs) -> ReferenceModel:
    kwargs = {"mild_need": 1, "window_slots": 1, **kwargs}
    cfg = FleetConfig(n_vehicles=2, hot_need=1, **kwargs)
    h = np.array(h_new)
    r = np.full(int(h.max()) + 1, r_mild) + 0.05 * np.arange(h.max() + 1)  # h-dependent
    return ReferenceModel(cfg, TOY_WEAR, h, np.array(w_new, dtype=float), np.clip(r, 0, 1))


def shortfall(m: ReferenceModel, joint: tuple[int, ...]) -> float:
    c = m.config
    hot, mild = joint.count(HOT), joint.count(MILD)
    extra = max(hot - c.hot_need, 0)
    return c.costs.shortfall * max(c.hot_need - hot, 0) + c.costs.mild_shortfall * max(
        c.mild_need - mild - extra, 0
    )


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
        fail = [(w, (hn, 0), m.fail_cost) for w, hn in new]  # corrective fit
        step = fail if h == 0 else [(1 - p, (h - 1, 0), 0.0), (p, (h - 1, R), 0.0)]
        if choice == HOT:
            return step
        r = float(m.r_mild[h])  # mild: a hot shift's step with probability r
        stay = [(1 - p, (h, 0), 0.0), (p, (h, R), 0.0)]
        return [(r * q, x, cost) for q, x, cost in step] + [(q * (1 - r), x, c) for q, x, c in stay]

    @functools.cache
    def value(t: int, state: tuple) -> float:
        if t == c.episode_shifts:
            return 0.0
        window = c.is_window(t)
        best = np.inf
        for joint in itertools.product((HOT, MILD, PARK, SERVICE), repeat=2):
            pairs = zip(joint, state, strict=True)
            if any(j in (HOT, MILD) and (window or d > 0) for j, (_, d) in pairs):
                continue
            if window and joint.count(SERVICE) > c.window_slots:
                continue
            short = 0.0 if window else shortfall(m, joint)
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


@pytest.mark.parametrize(("rate", "mild_need", "slots"), [(0.0, 1, 1), (0.25, 1, 1), (0.25, 0, 2)])
def test_program_value_is_the_brute_force_optimum(rate, mild_need, slots):
    m = toy(
        [2, 4], [0.3, 0.7], episode_shifts=6, window_period=3, breakdown_rate=rate,
        mild_need=mild_need, window_slots=slots,
    )  # fmt: skip
    sol = solve(m)
    for h0 in itertools.product(range(m.H + 1), repeat=2):
        v = float(sol.values[0][h0[0], 0, h0[1], 0])
        assert v == pytest.approx(brute_force_value(m, h0), rel=1e-5), h0
    # with no tail the plan's cost over the episode is the optimum itself
    np.testing.assert_allclose(sol.plan_cost[0], sol.values[0], rtol=1e-6)


def test_open_loop_enumeration_agrees_when_everything_is_deterministic():
    """No breakdowns, one new-pad life, mild wear 0 or a whole hot shift: the optimum is the
    best of all action sequences."""
    m = toy([3], [1.0], episode_shifts=5, window_period=3, breakdown_rate=0.0, r_mild=0.0)
    m = dataclasses.replace(m, r_mild=np.array([0.0, 1.0, 0.0, 1.0]))
    c = m.config
    best = np.inf
    steps = [joint_choices(m, c.is_window(t)) for t in range(c.episode_shifts)]
    for plan in itertools.product(*steps):
        h, cost = [1, 2], 0.0
        for t, joint in enumerate(plan):
            window = c.is_window(t)
            cost += 0.0 if window else shortfall(m, joint)
            for v, j in enumerate(joint):
                wears = j == HOT or (j == MILD and m.r_mild[h[v]] == 1.0)
                if j == SERVICE:
                    cost, h[v] = cost + (m.fit_cost if window else m.visit_cost), 3
                elif wears and h[v] == 0:
                    cost, h[v] = cost + m.fail_cost, 3
                elif wears:
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
        ReferenceModel.build(FleetConfig(n_vehicles=3, hot_need=1, mild_need=1), None)  # type: ignore[arg-type]


@pytest.fixture(scope="module")
def small_fleet():
    # K 2.5x the default's: pads last ~70 hot shifts, so a short episode has fits to plan
    cfg = FleetConfig(
        n_vehicles=2, hot_need=1, mild_need=1, window_slots=1, episode_shifts=150,
        breakdown_rate=0.0, k_mean=5e-6, k_std=5e-7,
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
