"""The policies and the planning model on the env's rules (brake_env.env.fleet.model): on the
same states from real rollouts they serve, defer and fit as the env's workshop does, and the
scalar FleetRule is the batched rule on a batch of one, action for action, on rollouts of
the default fleet and of the edges (no bay, a crew of one, no spares)."""

from __future__ import annotations

import copy
import itertools

import numpy as np
import pytest

from agents.fleet.policies import batch_rule
from agents.fleet.policies.planning import FleetState, _serve
from agents.fleet.policies.rules import FleetRule, FleetRuleParams
from agents.fleet.policies.view import FleetLayout, FleetView, respects
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.shop import SERVICE
from brake_env.env.fleet.wrappers import ExpectedRULObservation

SHIFTS = 60
CONFIGS = {
    "default": FleetConfig(episode_shifts=SHIFTS),
    "no bays": FleetConfig(episode_shifts=SHIFTS, bays=0, window_slots=1, initial_stock=1),
    "crew of one, no spares": FleetConfig(
        episode_shifts=SHIFTS, window_period=3, window_slots=1, initial_stock=0, max_order=2
    ),
}
RULE = FleetRuleParams(must=15, window_limit=60, shop_limit=40, greedy=True, duty="due-first",
                       s=2, S=4)  # fmt: skip


@pytest.fixture(scope="module", params=list(CONFIGS))
def rollout(request):
    """Each shift's view, the rule's action, and the workshop's plan of a random action
    that asks for many services (the env then takes the rule's action or that one)."""
    cfg = CONFIGS[request.param]
    env = ExpectedRULObservation(BrakeWearFleetEnv(cfg))
    lay, rng = FleetLayout.of(cfg), np.random.default_rng(11)
    rule = FleetRule(lay, RULE)
    obs, _ = env.reset(seed=5)
    rows = []
    for _ in range(SHIFTS):
        base = env.unwrapped
        view = FleetView.read(obs, lay)
        duty = rng.choice(4, cfg.n_vehicles, p=[0.4, 0.3, 0.1, 0.2])
        window = cfg.is_window(base.shift)
        row = {"view": view, "act": rule.act(view), "duty": duty, "age": base.pads.pos.copy(),
               "down": base.shop.down.copy(), "waiting": base.shop.waiting.copy(),
               "stock": base.shop.stock, "window": window,
               "plan": copy.deepcopy(base.shop).plan(duty, window, base.pads.pos)}  # fmt: skip
        rows.append(row)
        take = row["act"] if rng.random() < 0.6 else np.append(duty, rng.integers(0, 3))
        obs, *_ = env.step(take)
    return cfg, lay, rows


def test_the_planner_serves_as_the_workshop(rollout):
    """The planning model's workshop (_serve) on the states of each kind of shift at once:
    the env's fits, visits, stock left and waiting vehicles, state by state."""
    cfg, _, rows = rollout
    for window in (False, True):
        group = [r for r in rows if r["window"] == window]
        n, b = cfg.n_vehicles, len(group)
        state = FleetState(
            h=np.zeros((b, n)), age=np.stack([r["age"] for r in group]).astype(float),
            down=np.stack([r["down"] for r in group]), failed=np.zeros((b, n), dtype=bool),
            waiting=np.stack([r["waiting"] for r in group]),
            stock=np.array([r["stock"] for r in group]),
            transit=np.zeros((b, cfg.lead_time), dtype=np.int64),
            installs=np.zeros((b, n), dtype=np.int64), shift=0,
        )  # fmt: skip
        asks = np.stack([r["duty"] for r in group]) == SERVICE
        fit, visit = _serve(cfg, state, asks, window)
        for i, r in enumerate(group):
            plan = r["plan"]
            np.testing.assert_array_equal(fit[i], plan.replaced)
            np.testing.assert_array_equal(visit[i], plan.visit)
            assert state.stock[i] == r["stock"] - int(plan.replaced.sum())
            np.testing.assert_array_equal(state.waiting[i], r["waiting"] & ~plan.replaced)


def test_the_rule_is_the_batched_rule_on_a_batch_of_one(rollout):
    """Every state of a shift kind in one batch: the actions the scalar rule took, which
    the env's mask allows; the rollout sent pads to the shop and ordered spares."""
    cfg, lay, rows = rollout
    for to_window, group in itertools.groupby(
        sorted(rows, key=lambda r: r["view"].to_window), key=lambda r: r["view"].to_window
    ):
        vs = [r["view"] for r in group]
        acts = np.stack([r["act"] for r in rows if r["view"].to_window == to_window])
        bv = batch_rule.BatchView(
            np.stack([v.rul for v in vs]), np.stack([v.down for v in vs]),
            np.array([v.stock for v in vs]), np.array([v.transit for v in vs]),
            np.array([v.free_bays for v in vs]), to_window,
        )  # fmt: skip
        duty, order = batch_rule.act(RULE, cfg, bv)
        np.testing.assert_array_equal(np.column_stack([duty, order]), acts)
        for v, a in zip(vs, acts, strict=True):
            assert respects(a, v.mask(lay.max_order), cfg.n_vehicles)
    acts = np.stack([r["act"] for r in rows])
    assert (acts[:, :-1] == SERVICE).any() and (acts[:, -1] > 0).any()
