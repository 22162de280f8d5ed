"""Every RL edge of BrakeWearFleet-v0 validates what crosses it (issue 29): the Gymnasium
env's and the PettingZoo env's actions, the RUL wrapper's estimates, the configs' numbers
and the route names. Each bad value raises one error naming the agent or vehicle and the
value; valid numpy integers behave exactly as Python ints."""

from __future__ import annotations

import re

import numpy as np
import pytest

from brake_env.env.fleet.config import FleetConfig, FleetCosts
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.spaces import as_int
from brake_env.env.fleet.wrappers import FleetRULObservation
from brake_env.prognostics.events import EventBatch, RULEstimate
from brake_env.prognostics.protocol import Predictor
from tests.brake_env.env.fleet.small import SMALL

# None is an integer; each is shown in the message by its repr.
NOT_INTEGERS = [
    2.9,
    0.7,
    2.0,
    "1",
    "hot",
    float("nan"),
    None,
    True,
    np.bool_(False),
    np.float32(1.0),
    np.array([1, 2]),
    np.array(1.0),
]


@pytest.fixture(scope="module")
def make(atlas):
    def _make(**kw):
        return BrakeWearFleetEnv(atlas=atlas, **{**SMALL, **kw})

    return _make


def test_as_int_takes_integers_only() -> None:
    for x in (2, np.int8(2), np.uint16(2), np.int64(2), np.array(2), np.array(2, np.uint8)):
        assert as_int(x) == 2 and type(as_int(x)) is int
    for x in NOT_INTEGERS:
        assert as_int(x) is None, x


# ------------------------------------------------------------------ BrakeWearFleet-v0


def _rollout(env: BrakeWearFleetEnv, actions: list) -> list:
    obs, _ = env.reset(seed=3)
    out = [obs]
    for a in actions:
        obs, reward, *_ = env.step(a)
        out += [obs, reward]
    return out


JOINT = [[0, 1, 3, 2], [1, 0, 2, 0], [3, 3, 0, 1], [2, 1, 0, 8]]


@pytest.mark.parametrize(
    "convert",
    [
        lambda a: a,  # a list of Python ints
        tuple,
        lambda a: np.array(a, dtype=np.int8),
        lambda a: np.array(a, dtype=np.uint8),
        lambda a: np.array(a, dtype=np.int32),
        lambda a: [np.int64(x) for x in a],
        lambda a: [np.array(x) for x in a],  # 0-d integer arrays
    ],
    ids=["list", "tuple", "int8", "uint8", "int32", "np.int64 list", "0-d list"],
)
def test_fleet_env_numpy_integer_actions_give_the_python_int_trajectory(make, convert) -> None:
    want = _rollout(make(), [np.array(a, dtype=np.int64) for a in JOINT])
    got = _rollout(make(), [convert(a) for a in JOINT])
    for x, y in zip(got, want, strict=True):
        np.testing.assert_array_equal(x, y)


@pytest.mark.parametrize("value", NOT_INTEGERS, ids=repr)
@pytest.mark.parametrize("slot", [1, 3], ids=["vehicle", "order"])
def test_fleet_env_refuses_a_non_integer_in_a_list(make, value, slot) -> None:
    env = make()
    env.reset(seed=0)
    action: list = [0, 1, 2, 0]
    action[slot] = value
    who = "vehicle 1's duty" if slot == 1 else "the order (last entry)"
    with pytest.raises(ValueError, match=re.escape(f"{who} {value!r} is not an integer")) as e:
        env.step(action)
    assert "BrakeWearFleet-v0" in str(e.value)


@pytest.mark.parametrize(
    ("action", "who", "shown"),
    [
        (np.array([0.0, 1.0, 2.0, 0.0]), "vehicle 0's duty", "0.0"),
        (np.array([0, 1, 2, 0.5]), "vehicle 0's duty", "0.0"),
        (np.array([0, np.nan, 2, 0]), "vehicle 0's duty", "0.0"),
        (np.array([1, 0, 1, 0], dtype=np.float32), "vehicle 0's duty", "1.0"),
        (np.array([True, False, True, False]), "vehicle 0's duty", "True"),
        (np.array(["1", "0", "1", "0"]), "vehicle 0's duty", "'1'"),
        (np.array([1, None, 1, 0], dtype=object), "vehicle 1's duty", "None"),
        (np.array([1, 0, 1, 2.5], dtype=object), "the order", "2.5"),
    ],
    ids=["float64", "half", "nan", "float32", "bool", "str", "object None", "object float"],
)
def test_fleet_env_refuses_non_integer_arrays(make, action, who, shown) -> None:
    env = make()
    env.reset(seed=0)
    with pytest.raises(ValueError, match=re.escape(who) + ".*" + re.escape(shown)):
        env.step(action)


def test_fleet_env_names_the_vehicle_of_a_value_out_of_range(make) -> None:
    env = make()
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"vehicle 2's duty 4 is outside 0-3"):
        env.step([0, 0, 4, 0])
    with pytest.raises(ValueError, match=r"vehicle 0's duty -1 is outside"):
        env.step(np.array([-1, 0, 0, 0], dtype=np.int16))
    with pytest.raises(ValueError, match=r"the order \(last entry\) 9 is outside 0-8"):
        env.step(np.array([0, 0, 0, 9]))
    with pytest.raises(ValueError, match=r"18446744073709551615 is outside"):  # no wrap-around
        env.step(np.array([0, 0, 0, 2**64 - 1], dtype=np.uint64))


@pytest.mark.parametrize(
    "action",
    [np.zeros(3, dtype=np.int64), np.zeros((1, 4), dtype=np.int64), [0, 0, 0], 2, "0000", None],
)
def test_fleet_env_refuses_actions_of_the_wrong_shape(make, action) -> None:
    env = make()
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"BrakeWearFleet-v0: action must be 4 integers"):
        env.step(action)


def test_true_rul_names_the_valid_routes(make) -> None:
    env = make()
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"'uphill'.*\['hot', 'mild', 'uniform'\]"):
        env.true_rul("uphill")
    for bad in (3, -1, np.array([0, 1, 5]), 0.5, np.array([0, 1])):
        with pytest.raises(ValueError, match="route indices 0-2"):
            env.true_rul(bad)
    np.testing.assert_array_equal(env.true_rul("mild"), env.true_rul(np.int8(1)))


# ------------------------------------------------------------------ PettingZoo


@pytest.fixture(scope="module")
def parallel(atlas):
    pytest.importorskip("pettingzoo")
    from brake_env.env.fleet.parallel import BrakeWearFleetParallelEnv

    return lambda: BrakeWearFleetParallelEnv(atlas=atlas, **SMALL)


AGENTS = ["vehicle_0", "vehicle_1", "vehicle_2", "store"]


def test_parallel_step_before_reset_says_call_reset_first(parallel) -> None:
    env = parallel()
    with pytest.raises(RuntimeError, match=r"call reset\(\) first"):
        env.step({"vehicle_0": 0})
    env.reset(seed=0)
    for _ in range(SMALL["episode_shifts"]):
        env.step({})
    assert env.agents == []
    with pytest.raises(RuntimeError, match=r"call reset\(\) first \(the episode is over\)"):
        env.step({"vehicle_0": 0})


@pytest.mark.parametrize("value", NOT_INTEGERS, ids=repr)
@pytest.mark.parametrize("agent", ["vehicle_0", "store"])
def test_parallel_refuses_non_integers_naming_agent_and_value(parallel, agent, value) -> None:
    env = parallel()
    env.reset(seed=0)
    shape = getattr(value, "shape", None)
    what = f"an array of shape {shape}" if shape else "not an integer"
    with pytest.raises(ValueError, match=re.escape(f"{agent}'s action {value!r} is {what}")):
        env.step({agent: value})


def test_parallel_refuses_values_out_of_range(parallel) -> None:
    env = parallel()
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"vehicle_1's action 4 is outside 0-3"):
        env.step({"vehicle_1": 4})
    with pytest.raises(ValueError, match=r"store's action 9 is outside 0-8"):
        env.step({"store": np.int64(9)})
    with pytest.raises(ValueError, match=r"vehicle_2's action -1 is outside"):
        env.step({"vehicle_2": -1})
    with pytest.raises(ValueError, match=r"unknown or done agents \['vehicle_9'\]"):
        env.step({"vehicle_9": 0})
    with pytest.raises(ValueError, match="must be a dict"):
        env.step([0, 1, 2, 0])  # type: ignore[arg-type]


def test_parallel_numpy_integer_actions_give_the_python_int_trajectory(parallel) -> None:
    def run(convert) -> list:
        env = parallel()
        obs, _ = env.reset(seed=5)
        out = [obs[a]["observation"] for a in AGENTS]
        for joint in JOINT:
            obs, rew, *_ = env.step({a: convert(x) for a, x in zip(AGENTS, joint, strict=True)})
            out += [obs[a]["observation"] for a in AGENTS] + [rew["store"]]
            out += [obs[a]["action_mask"] for a in AGENTS]
        return out

    want = run(int)
    for convert in (np.int64, np.int8, np.uint32, np.array):
        for x, y in zip(run(convert), want, strict=True):
            np.testing.assert_array_equal(x, y)


# ------------------------------------------------------------------ FleetRULObservation


class Scripted(Predictor):
    """Gives the same (mean, lower, upper) after every event."""

    name = "scripted"

    def __init__(self, mean: float, lower: float | None, upper: float | None) -> None:
        super().__init__()
        self.mean, self.lower, self.upper = mean, lower, upper

    def _update(self, events: EventBatch) -> RULEstimate:
        n = len(events)

        def full(x: float | None) -> np.ndarray | None:
            return None if x is None else np.full(n, x)

        return RULEstimate(full(self.mean), full(self.lower), full(self.upper))  # type: ignore[arg-type]


class Unnamed(Scripted):
    name = ""


@pytest.mark.parametrize(
    ("estimate", "kind", "shown"),
    [
        ((np.nan, None, None), "a NaN RUL", "rul_mean=nan"),
        ((100.0, np.nan, 200.0), "a NaN RUL", "rul_lower=nan"),
        ((100.0, 150.0, 200.0), "an inverted interval", "rul_mean=100.0, rul_lower=150.0"),
        ((300.0, 150.0, 200.0), "an inverted interval", "rul_upper=200.0"),
    ],
    ids=["nan mean", "nan lower", "lower above mean", "mean above upper"],
)
def test_rul_wrapper_refuses_nan_and_inverted_intervals(make, estimate, kind, shown) -> None:
    env = FleetRULObservation(make(), Scripted(*estimate))
    env.reset(seed=0)
    with pytest.raises(ValueError, match=re.escape(kind)) as e:
        env.step(np.array([2, 0, 2, 0]))  # only vehicle 1 brakes
    msg = str(e.value)
    assert "'scripted' (Scripted)" in msg and "vehicle 1:" in msg and shown in msg


def test_rul_wrapper_names_an_unnamed_predictor_by_its_class(make) -> None:
    env = FleetRULObservation(make(), Unnamed(np.nan, None, None))
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"predictor Unnamed gave a NaN RUL for vehicle 0"):
        env.step(np.array([0, 0, 0, 0]))


def test_rul_wrapper_takes_a_sound_or_infinite_estimate(make) -> None:
    for estimate in ((100.0, 100.0, 100.0), (100.0, 50.0, 200.0), (np.inf, 10.0, np.inf)):
        env = FleetRULObservation(make(), Scripted(*estimate))
        env.reset(seed=0)
        obs, *_ = env.step(np.array([0, 0, 0, 0]))
        assert env.observation_space.contains(obs)


# ------------------------------------------------------------------ configs


def test_fleet_configs_take_numpy_scalars() -> None:
    costs = FleetCosts(pad=np.float32(600), order=np.int32(100), holding=np.float64(0.2))
    assert costs == FleetCosts(pad=600.0, order=100, holding=0.2)
    assert type(costs.pad) is float and type(costs.order) is int
    c = FleetConfig(
        n_vehicles=np.int64(4),
        hot_need=np.int32(2),
        mild_need=np.uint8(1),
        breakdown_rate=np.float32(0.25),
        initial_age_max=np.float64(0.5),
        k_mean=np.float32(2e-6),
        costs=costs,
        truth=np.bool_(True),
    )
    assert c.n_vehicles == 4 and type(c.n_vehicles) is int and c.truth is True
    assert c.breakdown_rate == 0.25 and type(c.k_mean) is float
    assert FleetConfig.from_kwargs(costs={"damage": np.float32(7000)}).costs.damage == 7000.0


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"n_vehicles": np.float32(4)}, "n_vehicles must be an int"),
        ({"breakdown_rate": np.bool_(True)}, "breakdown_rate must be a number"),
        ({"breakdown_rate": np.float32(np.nan)}, "breakdown_rate must be a number"),
        ({"costs": {"pad": np.bool_(True)}}, "FleetCosts.pad must be a number"),
        ({"costs": {"pad": np.float32(np.nan)}}, "FleetCosts.pad must be >= 0"),
        ({"costs": {"pad": "600"}}, "FleetCosts.pad must be a number"),
    ],
)
def test_fleet_configs_still_refuse_bools_nan_and_words(kwargs, match) -> None:
    with pytest.raises((TypeError, ValueError), match=match):
        FleetConfig.from_kwargs(**kwargs)
