"""BrakeWearFleet-v0 and BrakeWearFleetSmall-v0 as registered (issue 29): the episode length
in the spec, the small variant's settings, TimeLimit against ``episode_shifts``, and the
error of an unknown route."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import brake_env  # noqa: F401  (registers the fleet envs)
from brake_env.env.fleet.config import SMALL_FLEET, FleetConfig


def _episode_length(env: gym.Env) -> int:
    """Steps until truncation, every vehicle sent to the hot route, nothing ordered."""
    env.reset(seed=0)
    action = np.zeros(env.action_space.shape, dtype=np.int64)
    for n in range(1, 10_000):
        _, _, terminated, truncated, _ = env.step(action)
        assert not terminated
        if truncated:
            return n
    raise AssertionError("never truncated")


def test_specs_carry_the_episode_length() -> None:
    shifts = FleetConfig().episode_shifts
    assert shifts == 730
    assert gym.spec("BrakeWearFleet-v0").max_episode_steps == shifts
    small = gym.spec("BrakeWearFleetSmall-v0")
    assert small.max_episode_steps == shifts
    assert small.kwargs == SMALL_FLEET
    env = gym.make("BrakeWearFleetSmall-v0")
    assert env.unwrapped.config.n_vehicles == 2
    assert env.spec is not None and env.spec.max_episode_steps == shifts


def test_small_variant_truncates_at_its_last_shift(atlas) -> None:
    env = gym.make("BrakeWearFleetSmall-v0", atlas=atlas)
    assert _episode_length(env) == 730
    assert env.unwrapped.shift == 730


def test_episode_shifts_against_the_time_limit(atlas) -> None:
    kw = {"atlas": atlas, "events_per_shift": 100}
    # Fewer shifts: the env truncates first.
    assert _episode_length(gym.make("BrakeWearFleetSmall-v0", episode_shifts=25, **kw)) == 25
    # More shifts need max_episode_steps too (documented), which gym.make still overrides...
    longer = gym.make("BrakeWearFleetSmall-v0", episode_shifts=740, max_episode_steps=740, **kw)
    assert _episode_length(longer) == 740
    unlimited = gym.make("BrakeWearFleetSmall-v0", episode_shifts=740, max_episode_steps=-1, **kw)
    assert _episode_length(unlimited) == 740
    # ...else the registered TimeLimit cuts the episode at 730.
    cut = gym.make("BrakeWearFleetSmall-v0", episode_shifts=740, **kw)
    assert _episode_length(cut) == 730 and cut.unwrapped.shift == 730


def test_true_rul_of_an_unknown_route_lists_the_routes(atlas) -> None:
    env = gym.make("BrakeWearFleetSmall-v0", atlas=atlas)
    env.reset(seed=0)
    with pytest.raises(
        ValueError, match=r"BrakeWearFleet-v0: .*'uphill'.*\['hot', 'mild', 'uniform'\]"
    ):
        env.unwrapped.true_rul("uphill")
    assert env.unwrapped.true_rul("mild").shape == (2,)
