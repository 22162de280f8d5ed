"""The fleet's rules over a batch of states (brake_env.env.fleet.model): on many states at
once they give what the env's workshop gives on each state alone, and what the documented
rule gives written out as a plain loop; on states from real rollouts of the default fleet
and on the edges (no free bay, the crew full, no stock)."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from brake_env.env.fleet import model
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.shop import PARK, SERVICE, Workshop

SHIFTS = 60


def _rollout(cfg: FleetConfig, seed: int) -> list[dict]:
    """States before each shift of a random dispatcher that asks for many services (so that
    requests are deferred, bays fill and the stock runs out), with the env's own outcome."""
    env = BrakeWearFleetEnv(cfg)
    env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(SHIFTS):
        shop, n = env.shop, cfg.n_vehicles
        duty = rng.choice(4, n, p=[0.4, 0.3, 0.1, 0.2])
        action = np.append(duty, rng.integers(0, 3))
        state = {"down": shop.down.copy(), "age": env.pads.pos.copy(), "stock": shop.stock,
                 "free": shop.free_bays(), "window": cfg.is_window(env.shift), "duty": duty,
                 "mask": env.action_masks(), "waiting": shop.waiting.copy()}  # fmt: skip
        state["plan"] = copy.deepcopy(shop).plan(duty, state["window"], state["age"])
        _, _, _, _, info = env.step(action)
        state["counts"] = info["counts"]
        out.append(state)
    return out


CONFIGS = {
    "default": FleetConfig(episode_shifts=SHIFTS),
    "no bays": FleetConfig(episode_shifts=SHIFTS, bays=0, window_slots=1, initial_stock=1),
    "crew of one, no spares": FleetConfig(
        episode_shifts=SHIFTS, window_period=3, window_slots=1, initial_stock=0, max_order=2
    ),
}


@pytest.fixture(scope="module", params=list(CONFIGS))
def states(request):
    cfg = CONFIGS[request.param]
    return cfg, _rollout(cfg, seed=len(request.param))


def _stack(rows: list[dict], key: str) -> np.ndarray:
    return np.stack([np.asarray(r[key]) for r in rows])


def _documented(cfg: FleetConfig, s: dict) -> tuple[np.ndarray, list[tuple[int, str]]]:
    """The workshop's rule of shop.py's docstring, as a loop over one state's requests."""
    n = cfg.n_vehicles
    down, asks, window = s["down"] > 0, s["duty"] == SERVICE, s["window"]
    order = sorted(range(n), key=lambda v: (not (down[v] or window), -s["age"][v], v))
    fit, deferred = np.zeros(n, dtype=bool), []
    stock, slots, bays = s["stock"], cfg.window_slots, s["free"]
    for v in (v for v in order if asks[v]):
        if window and slots == 0:
            deferred.append((v, "crew"))
        elif not window and not down[v] and bays == 0:
            deferred.append((v, "bay"))
        elif stock == 0:
            deferred.append((v, "spare"))
        else:
            fit[v], stock = True, stock - 1
            slots -= int(window)
            bays -= int(not (window or down[v]))
    return fit, deferred


def test_admission_of_a_batch_is_the_workshop_s_on_each_state(states):
    """Batched over the states of each kind of shift: the fits and the deferred requests
    (vehicle and reason, in the workshop's order) of Workshop.plan and of the loop."""
    cfg, rows = states
    seen = {"fits": 0, "crew": 0, "bay": 0, "spare": 0}
    for window in (False, True):
        group = [s for s in rows if s["window"] == window]
        if not group:
            continue
        down, asks = _stack(group, "down") > 0, _stack(group, "duty") == SERVICE
        order = model.workshop_order(_stack(group, "age"), down, window)
        stock, free = _stack(group, "stock"), _stack(group, "free")
        fit, why = model.admit(cfg, asks, order, down=down, window=window, stock=stock, free=free)
        for i, s in enumerate(group):
            loop_fit, loop_deferred = _documented(cfg, s)
            np.testing.assert_array_equal(fit[i], s["plan"].replaced)
            np.testing.assert_array_equal(fit[i], loop_fit)
            got = [(int(v), model.REASONS[why[i, v]]) for v in order[i] if why[i, v]]
            assert got == s["plan"].deferred == loop_deferred
            seen["fits"] += int(loop_fit.sum())
            for _, reason in loop_deferred:
                seen[reason] += 1
    assert seen["fits"] > 0 and seen["crew"] + seen["bay"] + seen["spare"] > 0, seen


def test_the_edges_were_reached():
    """The edge configs do defer for a bay and for the crew (else they test nothing)."""
    reasons = {
        name: {r for s in _rollout(cfg, seed=len(name))[:40] for _, r in s["plan"].deferred}
        for name, cfg in CONFIGS.items() if name != "default"
    }  # fmt: skip
    assert "bay" in reasons["no bays"] and "crew" in reasons["crew of one, no spares"], reasons


def test_shortfall_mask_and_free_bays_of_a_batch_are_the_env_s(states):
    cfg, rows = states
    for window in (False, True):
        group = [s for s in rows if s["window"] == window]
        if not group:
            continue
        counts = [s["counts"] for s in group]
        hot, mild = model.shortfall(cfg, [c["on_hot"] for c in counts],
                                    [c["on_mild"] for c in counts], window)  # fmt: skip
        np.testing.assert_array_equal(hot, [c["shortfall"] for c in counts])
        np.testing.assert_array_equal(mild, [c["mild_shortfall"] for c in counts])
        down = _stack(group, "down")
        np.testing.assert_array_equal(model.free_bays(cfg.bays, down), _stack(group, "free"))
        allowed = model.service_allowed(down, window, _stack(group, "stock"), _stack(group, "free"))
        masks = _stack(group, "mask")[:, : 4 * cfg.n_vehicles].reshape(len(group), -1, 4)
        np.testing.assert_array_equal(allowed, masks[:, :, SERVICE])
        np.testing.assert_array_equal(model.can_drive(down, window), masks[:, :, 0])


def test_shortfall_counts_a_ramp_truck_towards_the_drifts():
    cfg = FleetConfig(hot_need=3, mild_need=2)
    hot, mild = model.shortfall(cfg, [0, 3, 5, 4, 6], [0, 0, 0, 1, 5], window=False)
    np.testing.assert_array_equal(hot, [3, 0, 0, 0, 0])
    np.testing.assert_array_equal(mild, [2, 2, 0, 0, 0])
    assert model.shortfall_cost(cfg, [0], [0], window=True)[0] == 0.0
    assert model.needs(cfg, window=True) == (0, 0) and model.needs(cfg, False) == (3, 5)


def test_admission_edges():
    """No free bay: visits deferred, a vehicle down still fitted; the crew full: the rest
    wait for the crew; no stock: every request deferred for a spare (or for the bay)."""
    cfg = FleetConfig(n_vehicles=4, hot_need=2, mild_need=1, bays=0, window_slots=1)
    asks = np.ones((3, 4), dtype=bool)
    down = np.array([[True, False, False, False]] * 3)
    order = np.tile(np.arange(4), (3, 1))
    fit, why = model.admit(cfg, asks, order, down=down, window=False, stock=[5, 0, 1], free=0)
    np.testing.assert_array_equal(fit[:, 0], [True, False, True])
    assert not fit[:, 1:].any()
    np.testing.assert_array_equal(why[1], [model.SPARE, model.BAY, model.BAY, model.BAY])
    fit, why = model.admit(cfg, asks, order, down=down, window=True, stock=[5, 0, 1], free=0)
    np.testing.assert_array_equal(fit.sum(axis=1), [1, 0, 1])
    np.testing.assert_array_equal(why[0], [0, model.CREW, model.CREW, model.CREW])
    np.testing.assert_array_equal(why[1], [model.SPARE] * 4)  # no fit took the crew's slot
    ok = model.within_capacity(cfg, np.eye(4, dtype=bool)[[0, 1]], down=down[:2],
                               window=False, stock=[1, 1], free=[0, 1])  # fmt: skip
    np.testing.assert_array_equal(ok, [True, True])
    assert not model.within_capacity(cfg, asks[:1], down=down[:1], window=True, stock=9, free=9)


def test_waiting_fits_shop_time_and_arrivals():
    waiting = np.array([[True, False, True, True], [False, True, True, False]])
    np.testing.assert_array_equal(
        model.fit_waiting(waiting, np.array([2, 0])),
        [[True, False, True, False], [False, False, False, False]],
    )
    down = np.array([[3, 1, 1, 0], [2, 0, 1, 5]])
    wait = np.array([[False, True, False, False], [False, False, False, True]])
    new = np.array([[False, False, False, False], [False, False, False, True]])
    # a waiting failed vehicle stays down; one sent down at the shift's end keeps its shifts
    np.testing.assert_array_equal(model.end_shift(down, wait, new), [[2, 1, 0, 0], [1, 0, 0, 5]])
    transit = np.array([[2, 0, 1], [0, 3, 0]])
    model.place_order(transit, np.array([4, 0]))
    got, rest = model.receive(transit)
    np.testing.assert_array_equal(got, [2, 0])
    np.testing.assert_array_equal(rest, [[0, 5, 0], [3, 0, 0]])
    ordered = model.reorder([1, 1, 0], [0, 1, 0], [0, 0, 0], 2, 5, 4)
    np.testing.assert_array_equal(ordered, [4, 0, 4])


def test_fill_needs_ranks_only_the_able():
    cfg = FleetConfig(n_vehicles=5, hot_need=1, mild_need=2)
    order = np.array([[3, 0, 4, 1, 2]])
    able = np.array([[True, False, True, True, True]])
    duty = np.full((1, 5), PARK)
    hot, drift = model.fill_needs(cfg, order, able, duty)
    np.testing.assert_array_equal(hot[0], [False, False, False, True, False])
    np.testing.assert_array_equal(drift[0], [True, False, False, False, True])  # 1 cannot
    np.testing.assert_array_equal(duty[0], [1, PARK, PARK, 0, 1])


def test_the_env_workshop_is_the_model_on_a_batch_of_one():
    """Workshop.plan of one state, by hand: the down vehicle first, then by pad age."""
    cfg = FleetConfig(n_vehicles=3, hot_need=1, mild_need=1, bays=2, initial_stock=2)
    shop = Workshop(cfg)
    shop.down[:] = [0, 2, 0]
    duty = np.full(3, SERVICE)
    plan = shop.plan(duty, window=False, pad_age=np.array([10, 5, 30]))
    # the vehicle down first (no bay), then the most worn visit; the bay is gone for the third
    np.testing.assert_array_equal(plan.shop_fit, [False, True, False])
    np.testing.assert_array_equal(plan.visit, [False, False, True])
    assert plan.deferred == [(0, "bay")] and shop.stock == 0
