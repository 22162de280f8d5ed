"""Fleet rules (agents.fleet.policies.rules): each does what it says on constructed situations,
and every action respects the env's mask along episodes."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from agents.fleet.evaluation.costs import run_episode
from agents.fleet.policies.rules import (
    FleetRule,
    FleetRuleParams,
    opportunistic_rule,
    reorder,
    threshold_rule,
    window_rule,
    with_parts,
)
from agents.fleet.policies.view import FleetLayout, FleetView, respects
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.shop import HOT, MILD, PARK, SERVICE
from brake_env.env.fleet.spaces import FLEET_FEATURES, N_VF, VEHICLE_FEATURES
from brake_env.env.fleet.wrappers import ExpectedRULObservation

N = 4
# 4 vehicles, 2 needed hot and none mild, a window crew that fits every vehicle.
LAYOUT = FleetLayout(FleetConfig(n_vehicles=N, hot_need=2, mild_need=0, window_slots=N))


def observation(
    rul_shifts: list[float], down: list[int] | None = None, to_window: int = 5,
    stock: int = 4, transit: int = 0, free_bays: int = 2,
) -> np.ndarray:  # fmt: skip
    """A fleet observation with the given hot-route RUL (in hot shifts; the mild route's five
    times it) and fleet state."""
    n = len(rul_shifts)
    veh = np.zeros((n, N_VF))
    veh[:, VEHICLE_FEATURES.index("down_shifts")] = down or [0] * n
    fleet = dict.fromkeys(FLEET_FEATURES, 0.0)
    fleet.update(shifts_to_window=to_window, stock=stock, in_transit=transit, free_bays=free_bays)
    rul = np.stack([rul_shifts, 5.0 * np.asarray(rul_shifts)], axis=1).ravel()
    return np.concatenate([veh.ravel(), list(fleet.values()), rul]).astype(np.float32)


def test_threshold_services_exactly_the_vehicles_below_it():
    rule = threshold_rule(LAYOUT, 10.0, s=0, S=0)
    a, _ = rule.predict(observation([3.0, 12.0, 9.99, 50.0], free_bays=4))
    assert (a[:N] == SERVICE).tolist() == [True, False, True, False]
    assert a[-1] == 0  # s = 0: never orders
    # the same whatever the window: at a window the same vehicles
    a, _ = rule.predict(observation([3.0, 12.0, 9.99, 50.0], to_window=0))
    assert (a[:N] == SERVICE).tolist() == [True, False, True, False]


def test_rules_take_a_batch_like_sb3():
    obs = np.stack([observation([3.0, 12.0, 20.0, 50.0]), observation([30.0, 1.0, 20.0, 50.0])])
    a, state = threshold_rule(LAYOUT, 5.0).predict(obs)
    assert a.shape == (2, N + 1) and state is None
    assert a[0, 0] == SERVICE and a[1, 1] == SERVICE and a[0, 1] != SERVICE


def test_window_rule_waits_for_the_window_unless_the_pad_would_fail():
    rule = window_rule(LAYOUT, window_period=14, margin=2.0, must=1.0)
    rul = [0.5, 10.0, 14.0, 16.0]
    between = rule.predict(observation(rul, to_window=4))[0]
    assert (between[:N] == SERVICE).tolist() == [True, False, False, False]
    at_window = rule.predict(observation(rul, to_window=0))[0]
    # 13 working shifts to the next window plus the margin 2: below 15
    assert (at_window[:N] == SERVICE).tolist() == [True, True, True, False]
    assert set(at_window[:N].tolist()) <= {PARK, SERVICE}  # nobody drives at a window


def test_opportunistic_rule_can_do_only_in_the_shop_or_at_a_window():
    rule = opportunistic_rule(LAYOUT, n=20.0, N=3.0)
    rul = [2.0, 10.0, 10.0, 30.0]
    a = rule.predict(observation(rul, down=[0, 0, 1, 0]))[0]
    assert (a[:N] == SERVICE).tolist() == [True, False, True, False]
    a = rule.predict(observation(rul, to_window=0))[0]
    assert (a[:N] == SERVICE).tolist() == [True, True, True, False]


def test_greedy_serves_lowest_rul_first_within_bays_and_stock():
    base = threshold_rule(LAYOUT, 10.0)
    greedy = with_parts(base, "greedy", greedy=True)
    obs = observation([8.0, 2.0, 5.0, 50.0], free_bays=1, stock=3)
    a = greedy.predict(obs)[0]
    assert (a[:N] == SERVICE).tolist() == [False, True, False, False]
    assert a[0] != HOT or a[2] != HOT  # the unserved are the last picked for the ramp
    assert a[3] == HOT  # the healthy one drives
    # without greedy every request goes to the workshop (it defers by its own rule)
    assert (base.predict(obs)[0][:N] == SERVICE).sum() == 3
    # at a window only the stock limits: 2 spares, the two lowest RUL
    a = greedy.predict(observation([8.0, 2.0, 5.0, 50.0], to_window=0, stock=2))[0]
    assert (a[:N] == SERVICE).tolist() == [False, True, True, False]
    # ... and the window's crew: one slot, the lowest RUL only
    one_slot = dataclasses.replace(LAYOUT.config, window_slots=1)
    crew = FleetRule(dataclasses.replace(LAYOUT, config=one_slot), greedy.params)
    a = crew.predict(observation([8.0, 2.0, 5.0, 50.0], to_window=0, stock=2))[0]
    assert (a[:N] == SERVICE).tolist() == [False, True, False, False]


def test_duty_rule_sends_the_lowest_rul_to_the_spare_duty():
    rule = FleetRule(LAYOUT, FleetRuleParams(must=0.0, duty="rul", spare_duty="mild"))
    a = rule.predict(observation([30.0, 80.0, 5.0, 60.0]))[0]
    assert a[:N].tolist() == [MILD, HOT, MILD, HOT]
    parked = FleetRule(LAYOUT, FleetRuleParams(must=0.0, duty="rul", spare_duty="park"))
    assert parked.predict(observation([30.0, 80.0, 5.0, 60.0]))[0][:N].tolist() == [
        PARK, HOT, PARK, HOT,
    ]  # fmt: skip
    roster = FleetRule(LAYOUT, FleetRuleParams(must=0.0))
    assert roster.predict(observation([30.0, 80.0, 5.0, 60.0]))[0][:N].tolist() == [
        HOT, HOT, MILD, MILD,
    ]  # fmt: skip
    # a vehicle in the shop cannot drive: the next healthiest takes the ramp
    a = rule.predict(observation([30.0, 80.0, 5.0, 60.0], down=[0, 2, 0, 0]))[0]
    assert a[:N].tolist() == [HOT, PARK, MILD, HOT]
    # due-first: a pad replaced at the next window anyway (RUL there < 12, > must = 1)
    # takes the ramp first, and a due pad on the mild need goes up the ramp too
    due = FleetRule(
        dataclasses.replace(LAYOUT, config=dataclasses.replace(LAYOUT.config, mild_need=2)),
        FleetRuleParams(must=1.0, window_limit=12.0, duty="due-first", spare_duty="park"),
    )
    a = due.predict(observation([30.0, 80.0, 9.0, 14.0], to_window=5))[0]
    assert a[:N].tolist() == [MILD, MILD, HOT, HOT]  # 9 and 14 due: the ramp is theirs
    a = due.predict(observation([9.0, 14.0, 10.0, 80.0], to_window=5))[0]
    assert a[:N].tolist() == [HOT, HOT, HOT, MILD]  # three due: the third covers a drift
    a = due.predict(observation([30.0, 80.0, 5.0, 60.0], to_window=5))[0]
    assert a[:N].tolist() == [MILD, HOT, MILD, HOT]  # 5 would be at 0 < must: not due
    # a mild need is filled after the hot need, healthiest first; the least RUL is spare
    need = FleetRule(
        dataclasses.replace(LAYOUT, config=dataclasses.replace(LAYOUT.config, mild_need=1)),
        parked.params,
    )
    assert need.predict(observation([30.0, 80.0, 5.0, 60.0]))[0][:N].tolist() == [
        MILD, HOT, PARK, HOT,
    ]  # fmt: skip


def test_s_S_orders_up_to_S_below_s():
    assert reorder(stock=1, transit=0, fits=0, s=2, S=5, max_order=8) == 4
    assert reorder(stock=1, transit=1, fits=0, s=2, S=5, max_order=8) == 0
    assert reorder(stock=2, transit=1, fits=2, s=2, S=5, max_order=8) == 4  # fits count
    assert reorder(stock=0, transit=0, fits=0, s=2, S=20, max_order=8) == 8  # capped
    rule = threshold_rule(LAYOUT, 1.0, s=3, S=6)
    assert rule.predict(observation([50.0] * N, stock=1, transit=1))[0][-1] == 4
    assert rule.predict(observation([50.0] * N, stock=2, transit=1))[0][-1] == 0


def test_bad_parameters_and_observations_raise_clearly():
    with pytest.raises(ValueError, match="s <= S"):
        FleetRuleParams(s=3, S=2)
    with pytest.raises(ValueError, match="duty"):
        FleetRuleParams(duty="random")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="fleet rule: fleet observation: expected"):
        threshold_rule(LAYOUT, 1.0).predict(np.zeros(7, dtype=np.float32))
    with pytest.raises(ValueError, match="rul_field"):
        FleetLayout(FleetConfig(), fields=("rul_mean",), rul_field="rul_lower")


@pytest.fixture(scope="module")
def tight_env():
    """3 vehicles, 2 needed hot and 1 mild, 1 bay, 1 window slot, 1 spare, fast wear: the
    limits bind often."""
    cfg = FleetConfig(
        n_vehicles=3, hot_need=2, mild_need=1, window_slots=1, bays=1, initial_stock=1,
        lead_time=3, episode_shifts=60, events_per_shift=200, k_mean=2e-5, k_std=2e-6,
        window_period=7, breakdown_rate=0.1,
    )  # fmt: skip
    return ExpectedRULObservation(BrakeWearFleetEnv(cfg)), FleetLayout.of(cfg)


RULES = {
    "threshold": lambda lay: threshold_rule(lay, 3.0, s=1, S=2),
    "window": lambda lay: window_rule(lay, 7, 1.0, 1.0),
    "nN": lambda lay: opportunistic_rule(lay, 8.0, 2.0),
    "greedy-duty": lambda lay: FleetRule(
        lay, FleetRuleParams(must=4.0, greedy=True, duty="rul", spare_duty="park", s=0, S=0)
    ),
}


@pytest.mark.parametrize("name", list(RULES))
def test_every_action_respects_the_mask_along_an_episode(tight_env, name):
    env, layout = tight_env
    rule = RULES[name](layout)
    ep = run_episode(env, rule, seed=3, check_masks=True)  # raises on a masked action
    assert ep.shifts == 60 and ep.counts["window_fits"] + ep.counts["visits"] > 0


def test_the_mask_rebuilt_from_the_observation_is_the_envs(tight_env):
    env, layout = tight_env
    rule = RULES["threshold"](layout)
    obs, _ = env.reset(seed=5)
    for _ in range(60):
        mask = FleetView.read(obs, layout).mask(layout.max_order)
        np.testing.assert_array_equal(mask, env.unwrapped.action_masks())
        a, _ = rule.predict(obs)
        assert respects(a, mask, layout.n_vehicles)
        obs, *_ = env.step(a)


def test_closed_form_oracle_rul_is_the_simulated_ahead_one_within_a_few_percent():
    env = ExpectedRULObservation(
        BrakeWearFleetEnv(n_vehicles=2, hot_need=1, mild_need=1, episode_shifts=5)
    )
    obs, _ = env.reset(seed=2)
    for _ in range(3):
        obs, *_ = env.step(np.array([HOT, HOT, 0]))
    expected = obs[-4:].astype(float).reshape(2, 2) * env.unwrapped.config.events_per_shift
    for j, route in enumerate(("hot", "mild")):
        simulated = env.unwrapped.true_rul(route).astype(float)
        np.testing.assert_allclose(expected[:, j], simulated, rtol=0.03)
    # the rules read both routes, in shifts, without converting
    view = FleetView.read(obs, FleetLayout.of(env.unwrapped.config))
    np.testing.assert_allclose(view.rul * 400, expected[:, 0], rtol=1e-6)
    np.testing.assert_allclose(view.rul_mild * 400, expected[:, 1], rtol=1e-6)
    assert (view.rul_mild > 3 * view.rul).all()  # the drifts wear a pad 4.7-6.6x slower
