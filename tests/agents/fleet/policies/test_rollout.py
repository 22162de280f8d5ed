"""The rollout planner's parts: the batched rule (agents.fleet.policies.batch_rule) equal to
FleetRule.act, the planning model (planning) against the env shift by shift, and the
multiagent rollout (rollout): masks, determinism, and a decision the base rule gets wrong."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from agents.fleet.policies import batch_rule
from agents.fleet.policies.planning import Futures, PlanningModel
from agents.fleet.policies.rollout import RolloutPolicy
from agents.fleet.policies.rules import FleetRule, FleetRuleParams
from agents.fleet.policies.view import FleetLayout, FleetView, respects
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.routes import HOT as HOT_ROUTE
from brake_env.env.fleet.routes import route_wear_model
from brake_env.env.fleet.shop import HOT, MILD, PARK, SERVICE
from brake_env.env.fleet.wrappers import ExpectedRULObservation

TEACHER = FleetRuleParams(must=3, window_limit=20, shop_limit=15, greedy=True, duty="rul")


@pytest.fixture(scope="module")
def views():
    """Views of a default fleet driven mostly by a rule, sometimes at random (so that the
    shop, deferred requests and low stock occur), grouped by shifts to the window."""
    cfg = FleetConfig(episode_shifts=150)
    env = ExpectedRULObservation(BrakeWearFleetEnv(cfg))
    lay, rng = FleetLayout.of(cfg), np.random.default_rng(0)
    teacher, groups = FleetRule(lay, TEACHER), {}
    for seed in range(2):
        obs, _ = env.reset(seed=seed)
        for _ in range(150):
            view = FleetView.read(obs, lay)
            groups.setdefault(view.to_window, []).append(view)
            a = teacher.act(view) if rng.random() < 0.8 else env.action_space.sample()
            obs, *_ = env.step(a)
    return cfg, lay, groups


PARAMS = [
    FleetRuleParams(must=m, window_limit=w, shop_limit=s, greedy=g, duty=d, spare_duty=sp, S=5)
    for (m, w, s), g, d, sp in itertools.product(
        [(3, 20, 15), (10, None, None), (25, 40, 40)], [False, True],
        ["roster", "rul", "due-first"], ["mild", "park"],
    )
]  # fmt: skip


@pytest.mark.parametrize("params", PARAMS, ids=range(len(PARAMS)))
def test_the_batched_rule_decides_as_the_rule(views, params):
    cfg, lay, groups = views
    rule = FleetRule(lay, params)
    for to_window, vs in groups.items():
        bv = batch_rule.BatchView(
            np.stack([v.rul for v in vs]), np.stack([v.down for v in vs]),
            np.array([v.stock for v in vs]), np.array([v.transit for v in vs]),
            np.array([v.free_bays for v in vs]), to_window,
        )  # fmt: skip
        duty, order = batch_rule.act(params, cfg, bv)
        expected = np.stack([rule.act(v) for v in vs])
        np.testing.assert_array_equal(np.column_stack([duty, order]), expected)


def _model_state(model, env):
    """The planning model's state of the env now, from its truth (one future)."""
    base = env.unwrapped
    tr, shop = base.truth(), base.shop
    wear = route_wear_model(base.atlas, HOT_ROUTE)
    h = wear.rul(np.clip(tr["volume_frac"], wear.lower_edges[-1], 1.0), tr["wear_coeff"])
    s = model.start(h[None] / base.config.events_per_shift, tr["pad_age"], shop.down,
                    shop.stock, shop.transit, base.shift)  # fmt: skip
    s.failed[0], s.waiting[0] = shop.failed_down, shop.waiting
    return s


def test_the_model_steps_as_the_env_where_no_pad_fails():
    """Shift by shift from the env's own state, the model's cost (pads priced when fitted)
    and its next shop state equal the env's, wherever no pad fails in the env (wear is
    the model's one approximation) and breakdowns are off (their draws differ)."""
    cfg = FleetConfig(episode_shifts=200, breakdown_rate=0.0, initial_stock=2, max_order=3)
    env = ExpectedRULObservation(BrakeWearFleetEnv(cfg))
    model = PlanningModel.build(cfg, env.unwrapped.atlas)
    lay, rng = FleetLayout.of(cfg), np.random.default_rng(1)
    rule = FleetRule(lay, FleetRuleParams(must=4, window_limit=25, shop_limit=10, s=1, S=3))
    futures = Futures(np.ones((1, 1, cfg.n_vehicles)), np.full((1, cfg.n_vehicles, 3), 150.0))
    compared = {"shifts": 0, "fits": 0, "deferred": 0, "shortfall": 0}
    obs, _ = env.reset(seed=3)
    for _ in range(200):
        a = rule.act(FleetView.read(obs, lay)) if rng.random() < 0.7 else env.action_space.sample()
        s = _model_state(model, env)
        cost = model.step(s, a[None, :-1], a[-1:], futures, 0, np.zeros(1, dtype=np.int64))
        obs, reward, _, _, info = env.step(a)
        n, shop = info["counts"], env.unwrapped.shop
        if n["failures"] or n["corrective_fits"]:
            continue
        headline = -reward + cfg.costs.pad * (n["window_fits"] + n["shop_fits"] + n["visits"]
                                              - n["ordered"])  # fmt: skip
        assert cost[0] == pytest.approx(headline), info["costs"]
        assert (s.stock[0], s.shift) == (shop.stock, env.unwrapped.shift)
        np.testing.assert_array_equal(s.transit[0], shop.transit)
        np.testing.assert_array_equal(s.down[0], shop.down)
        compared["shifts"] += 1
        compared["fits"] += n["window_fits"] + n["shop_fits"] + n["visits"]
        compared["deferred"] += n["deferred"]
        compared["shortfall"] += n["shortfall"] + n["mild_shortfall"]
    # the comparison covered fits, deferred requests and shortfalls, not idle shifts only
    assert compared["shifts"] > 150 and min(compared.values()) > 0, compared


def test_the_model_wears_fails_and_replaces():
    cfg = FleetConfig(n_vehicles=3, hot_need=1, mild_need=1, breakdown_rate=0.0)
    model = PlanningModel.build(cfg, BrakeWearFleetEnv(cfg).atlas)
    futures = Futures(np.ones((1, 2, 3)), np.full((2, 3, 2), 99.0))
    s = model.start(np.array([[5.0, 5.0, 0.5], [5.0, 5.0, 0.5]]), np.zeros(3),
                    np.zeros(3, dtype=np.int64), 1, 0, 0)  # fmt: skip
    duty = np.array([[HOT, MILD, HOT], [PARK, SERVICE, MILD]])
    cost = model.step(s, duty, np.zeros(2, dtype=np.int64), futures, 0, np.arange(2))
    r = model.mild_use(np.array([5.0, 0.5]))
    assert 0.1 < r[0] < 0.3
    # future 0: hot uses one shift, mild r(h); the third pad (0.5 < 1) fails on the ramp
    # and gets the one spare at once (down failure_repair_shifts from the next shift on)
    np.testing.assert_allclose(s.h[0], [4.0, 5.0 - r[0], 99.0])
    w = cfg.costs
    fail = w.damage + w.pad + w.labour
    assert s.down[0, 2] == cfg.failure_repair_shifts and s.stock[0] == 0
    # future 1: a visit (bay free, spare in stock); the third on a drift (0.5 > r): wears
    assert s.h[1, 1] == 99.0 and s.h[1, 2] == pytest.approx(0.5 - r[1])
    visit = w.shop_visit + w.pad + w.labour
    short = w.shortfall  # nobody on the ramp
    np.testing.assert_allclose(cost, [fail, visit + short])


@pytest.fixture(scope="module")
def small_rollout():
    cfg = FleetConfig(n_vehicles=4, hot_need=2, mild_need=1, window_slots=1, bays=1,
                      episode_shifts=60)  # fmt: skip
    env = ExpectedRULObservation(BrakeWearFleetEnv(cfg))
    model = PlanningModel.build(cfg, env.unwrapped.atlas)
    return cfg, env, model


def test_rollout_respects_masks_and_is_deterministic(small_rollout):
    cfg, env, model = small_rollout
    base = FleetRule(FleetLayout.of(cfg), TEACHER, "teacher")
    obs, _ = env.reset(seed=0)
    for _ in range(25):
        a = RolloutPolicy(base, model, horizon=6, samples=4, seed=7).act(obs)
        again = RolloutPolicy(base, model, horizon=6, samples=4, seed=7).act(obs)
        np.testing.assert_array_equal(a, again)
        assert respects(a, env.unwrapped.action_masks(), cfg.n_vehicles)
        obs, *_ = env.step(a)


def test_rollout_keeps_a_pad_off_the_ramp_that_the_base_would_fail(small_rollout):
    """A base rule that never replaces (must = 0) sends a pad with half a hot shift of
    life up the ramp; the rollout sees the failure coming and decides otherwise."""
    cfg, env, model = small_rollout
    base = FleetRule(FleetLayout.of(cfg), FleetRuleParams(must=0.0, duty="roster"), "never")
    obs, _ = env.reset(seed=0)
    while cfg.is_window(env.unwrapped.shift):
        obs, *_ = env.step(env.action_space.sample() * 0 + PARK)
    obs = obs.copy()
    n = cfg.n_vehicles
    hot = base.layout.column("hot", "rul_mean")
    appended = obs[-n * base.layout.per_vehicle :].reshape(n, -1)  # (a view into obs)
    appended[:, hot] = [0.5, 200.0, 225.0, 250.0]  # hot shifts: vehicle 0 nearly worn
    assert base.act(FleetView.read(obs, base.layout))[0] == HOT
    a = RolloutPolicy(base, model, horizon=10, samples=8).act(obs)
    assert a[0] in (PARK, SERVICE, MILD) and a[0] != HOT


def test_the_program_value_reads_the_relaxed_program_at_the_window_phase():
    """ProgramValue: each vehicle's V[shift mod W, ceil(h units), d], summed per future."""
    from agents.fleet.policies.lagrangian import BoundModel, Prices, solve
    from agents.fleet.policies.planning import ProgramValue

    cfg = FleetConfig(n_vehicles=2, hot_need=1, mild_need=1, episode_shifts=8, window_period=3)
    m = BoundModel(cfg, units=2, mild_units=1, new_prob=np.array([0, 0, 0, 0.3, 0, 0.7]))
    program = solve(m, Prices.zeros(cfg))
    value = ProgramValue.of(m, program)
    h = np.array([[0.2, 2.0], [1.0, 0.0]])  # hot shifts: units ceil(0.4)=1, 4; 2, 0
    down = np.array([[0, 1], [0, 0]])
    got = value(h, down, shift=7)  # 7 mod 3 = 1
    v = program.values[1]
    np.testing.assert_allclose(got, [v[1, 0] + v[4, 1], v[2, 0] + v[0, 0]])


def _a_state(small_rollout, seed=0, shifts=5):
    cfg, env, model = small_rollout
    base = FleetRule(FleetLayout.of(cfg), TEACHER, "teacher")
    obs, _ = env.reset(seed=seed)
    for _ in range(shifts):
        obs, *_ = env.step(base.act(FleetView.read(obs, base.layout)))
    return cfg, base, model, obs


def test_every_candidate_and_the_base_see_the_same_futures(small_rollout):
    """Common random numbers: in one shift simulated, a candidate that changes vehicle 0's
    duty leaves the other vehicles' sampled wear, new pads and costs exactly the base's."""
    _, base, model, obs = _a_state(small_rollout)
    policy = RolloutPolicy(base, model, horizon=1, samples=8, seed=3)
    view = FleetView.read(obs, base.layout)
    rng = np.random.default_rng([3, view.shift])
    start = policy.start(obs, view, rng)
    futures = model.draw(rng, 8, 1)
    duty = base.act(view)[:-1]
    joints = np.stack([duty, duty, duty])
    joints[2, 0] = PARK if duty[0] != PARK else MILD
    cost, state = policy.simulate(start, joints, futures)
    h = state.h.reshape(3, 8, -1)
    np.testing.assert_array_equal(cost[0], cost[1])  # the base twice: identical futures
    np.testing.assert_array_equal(h[0], h[1])
    np.testing.assert_array_equal(h[0][:, 1:], h[2][:, 1:])  # the others' wear unchanged
    assert not np.array_equal(h[0][:, 0], h[2][:, 0])  # vehicle 0's duty did change


def test_the_corrected_test_takes_no_candidate_equal_to_the_current_action(small_rollout):
    """A candidate that is the current action (difference 0 in every future) is never
    taken, under any level; among candidates with pure noise differences the Bonferroni
    test takes few, the old one-standard-error rule most."""
    cfg, _, model = small_rollout
    rng = np.random.default_rng(0)
    for alpha in (0.05, 0.5, 0.99):
        rule = FleetRule(FleetLayout.of(cfg), TEACHER)
        policy = RolloutPolicy(rule, model, horizon=1, samples=32, alpha=alpha)
        cost = np.repeat(rng.normal(size=(1, 32)), 5, axis=0)
        assert policy.better(cost, 2) is None
        assert not policy.wins(cost[1:] - cost[0], 4).any()
    rule = FleetRule(FleetLayout.of(cfg), TEACHER)
    corrected = RolloutPolicy(rule, model, horizon=1, samples=32, alpha=0.05)
    old = RolloutPolicy(rule, model, horizon=1, samples=32, confidence=1.0)
    noise = rng.normal(size=(200, 37, 32))  # 200 states, 36 candidates against row 0
    taken = [sum(p.better(c, 0) is not None for c in noise) for p in (corrected, old)]
    assert taken[0] <= 200 * 0.05 * 2 and taken[1] > 100, taken


def test_a_real_improvement_passes_the_corrected_test(small_rollout):
    cfg, _, model = small_rollout
    rule = FleetRule(FleetLayout.of(cfg), TEACHER)
    policy = RolloutPolicy(rule, model, horizon=1, samples=32, alpha=0.05)
    rng = np.random.default_rng(1)
    cost = np.repeat(rng.normal(size=(1, 32)), 37, axis=0) + 0.1 * rng.normal(size=(37, 32))
    cost[5] -= 1.0  # better by 10 noise sd in every future
    assert policy.better(cost, 0) == 5


def test_the_rollout_on_the_index_policy_is_deterministic_and_respects_masks(small_rollout):
    from agents.fleet.policies.index import IndexPolicy, searched

    cfg, env, model = small_rollout
    index = IndexPolicy(FleetLayout.of(cfg), *searched(cfg, env.unwrapped.atlas, 3, starts=2),
                        cover=2.0, floor=0.03)  # fmt: skip
    obs, _ = env.reset(seed=1)
    for _ in range(8):
        a = RolloutPolicy(index, model, horizon=1, samples=8, seed=5).act(obs)
        np.testing.assert_array_equal(a, RolloutPolicy(index, model, 1, 8, 5).act(obs))
        assert respects(a, env.unwrapped.action_masks(), cfg.n_vehicles)
        obs, *_ = env.step(a)
    with pytest.raises(ValueError, match="horizon must be 1"):
        RolloutPolicy(index, model, horizon=2)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [({"alpha": 0.0}, "0 < alpha < 1"), ({"alpha": 1.5}, "alpha must be"),
     ({"samples": 1}, "samples >= 2"), ({"alpha": float("nan")}, "alpha must be")],
)  # fmt: skip
def test_the_acceptance_test_refuses_bad_settings(small_rollout, kwargs, match):
    cfg, _, model = small_rollout
    rule = FleetRule(FleetLayout.of(cfg), TEACHER)
    with pytest.raises(ValueError, match=match):
        RolloutPolicy(rule, model, **{"horizon": 1, "samples": 8, **kwargs})
    with pytest.raises(ValueError, match="FleetRule or an IndexPolicy"):
        RolloutPolicy(object(), model)  # type: ignore[arg-type]
