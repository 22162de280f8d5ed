"""The fleet env's state: read from an episode, the env reset from it continues that episode
exactly; built by hand (as from logs), it is validated and the env starts there."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.state import FleetState
from tests.brake_env.env.fleet.small import SMALL

LONG = {**SMALL, "episode_shifts": 120, "breakdown_rate": 0.1, "initial_stock": 2, "max_order": 3}


def _actions(rng: np.random.Generator, n: int, shifts: int) -> np.ndarray:
    """Random duties (services included, so pads are replaced and spares run short) and
    orders: every rule of the env gets exercised."""
    duty = rng.choice(4, size=(shifts, n), p=[0.45, 0.3, 0.1, 0.15])
    order = rng.integers(0, 4, size=(shifts, 1))
    return np.concatenate([duty, order], axis=1).astype(np.int64)


def _run(env: BrakeWearFleetEnv, actions: np.ndarray) -> list[tuple]:
    out = []
    for a in actions:
        obs, r, _, trunc, info = env.step(a)
        v = info["vehicles"]
        out.append((obs, r, trunc, info["counts"], v["route"], v["events"], v["failed"],
                    v["broke_down"], v["serial"], info["truth"]["volume_frac"],
                    env.shift_events().measured))  # fmt: skip
    return out


def _same(a: list[tuple], b: list[tuple]) -> None:
    assert len(a) == len(b)
    for t, (x, y) in enumerate(zip(a, b, strict=True)):
        for i, (p, q) in enumerate(zip(x, y, strict=True)):
            if isinstance(p, dict):
                assert p == q, (t, i)
            else:
                np.testing.assert_array_equal(p, q, err_msg=f"shift {t}, item {i}")


def test_the_env_reset_from_its_own_state_continues_the_episode_array_equal(atlas) -> None:
    actions = _actions(np.random.default_rng(5), SMALL["n_vehicles"], 110)
    a = BrakeWearFleetEnv(atlas=atlas, **LONG)
    a.reset(seed=11)
    _run(a, actions[:40])
    state = a.state()
    obs_a = a._observation()
    ahead = _run(a, actions[40:90])  # the episode's next 50 shifts
    b = BrakeWearFleetEnv(atlas=atlas, **LONG)
    obs_b, _ = b.reset(seed=999, options={"state": state})  # another seed: the state rules
    np.testing.assert_array_equal(obs_b, obs_a)
    again = _run(b, actions[40:90])
    _same(ahead, again)
    # the 50 shifts saw failures or services and breakdowns: the test exercises the rules
    assert sum(x[3]["breakdowns"] for x in ahead) > 0
    assert sum(x[3]["visits"] + x[3]["window_fits"] + x[3]["corrective_fits"] for x in ahead) > 0


def test_reading_the_state_does_not_change_the_episode(atlas) -> None:
    actions = _actions(np.random.default_rng(6), SMALL["n_vehicles"], 60)
    a, b = (BrakeWearFleetEnv(atlas=atlas, **LONG) for _ in range(2))
    a.reset(seed=3)
    b.reset(seed=3)
    _run(a, actions[:20])
    _run(b, actions[:20])
    a.state()
    _same(_run(a, actions[20:]), _run(b, actions[20:]))


def _by_hand(n: int) -> FleetState:
    return FleetState(
        shift=9, wear_coeff=np.full(n, 1e-5), regime=("id",) * n,
        pad_age=np.array([100, 5000, 20000][:n]), volume_frac=np.array([0.99, 0.8, 0.45][:n]),
        stock=1, transit=np.array([0, 2]), down=np.array([0, 2, 0][:n]),
        failed_down=np.zeros(n, bool), waiting=np.zeros(n, bool),
    )  # fmt: skip


def test_a_state_built_by_hand_is_where_the_env_starts(atlas) -> None:
    env = BrakeWearFleetEnv(atlas=atlas, **LONG)
    s = _by_hand(3)
    obs, _ = env.reset(seed=1, options={"state": s})
    t = env.truth()
    np.testing.assert_array_equal(t["volume_frac"], s.volume_frac)
    np.testing.assert_array_equal(t["pad_age"], s.pad_age)
    np.testing.assert_array_equal(t["wear_coeff"], s.wear_coeff)
    assert env.shift == 9 and env.shop.stock == 1 and env.shop.in_transit == 2
    assert env.config.shifts_to_window(9) == obs[-4]  # the window cycle follows the shift
    assert obs[-2] == 2  # 2 pads on order
    np.testing.assert_array_equal(env.shop.down, [0, 2, 0])
    # the transit list arrives in order: nothing at the next shift's start, 2 the one after
    env.step(np.array([2, 2, 2, 0]))
    assert env.shop.stock == 1
    env.step(np.array([2, 2, 2, 0]))
    assert env.shop.stock == 3
    # same seed, same state: the same future (fresh streams drawn from the seed)
    e1, e2 = (BrakeWearFleetEnv(atlas=atlas, **LONG) for _ in range(2))
    e1.reset(seed=4, options={"state": s})
    e2.reset(seed=4, options={"state": s})
    act = np.array([0, 1, 0, 0])
    _same(_run(e1, np.tile(act, (8, 1))), _run(e2, np.tile(act, (8, 1))))


@pytest.mark.parametrize(
    ("change", "named"),
    [
        ({"wear_coeff": np.array([1e-5, np.nan, 1e-5])}, "wear_coeff: vehicle 1"),
        ({"wear_coeff": np.array([1e-5, 0.0, 1e-5])}, "wear_coeff: vehicle 1"),
        ({"volume_frac": np.array([0.9, 1.2, 0.5])}, "volume_frac: vehicle 1"),
        ({"volume_frac": np.array([0.9, 0.5, 0.01])}, "volume_frac: vehicle 2"),
        ({"pad_age": np.array([1, -1, 3])}, "pad_age: vehicle 1"),
        ({"down": np.array([1, 1])}, "down: 3 values"),
        ({"shift": 500}, "shift: 500"),
        ({"stock": -1}, "stock: -1"),
        ({"transit": np.zeros(40, dtype=np.int64)}, "transit"),
        ({"wear_coeff": np.full(3, 1.0)}, "wear coefficient"),
    ],
)
def test_a_bad_state_is_refused_naming_the_field(atlas, change, named) -> None:
    env = BrakeWearFleetEnv(atlas=atlas, **LONG)
    with pytest.raises(ValueError, match=named.replace("(", r"\(")):
        env.reset(seed=0, options={"state": dataclasses.replace(_by_hand(3), **change)})


def test_something_other_than_a_state_is_refused(atlas) -> None:
    env = BrakeWearFleetEnv(atlas=atlas, **LONG)
    with pytest.raises(ValueError, match="FleetState"):
        env.reset(seed=0, options={"state": {"shift": 3}})
