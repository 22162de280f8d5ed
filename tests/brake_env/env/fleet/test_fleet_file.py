"""Fleet files (issue 41): the shipped fleets, a file read back equal, one error naming the
file and the key, ``gym.make("BrakeWearFleet-v2", fleet=...)`` and the PettingZoo version
on a file, and the episode's cost in the last step's info, equal to the runner's."""

from __future__ import annotations

import dataclasses
import re

import gymnasium as gym
import numpy as np
import pytest

import brake_env  # noqa: F401  (registers the fleet envs)
from agents.fleet.evaluation.costs import run_episode
from brake_env.env.fleet.config import SMALL_FLEET, FleetConfig
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.fleet_file import FleetFile, fleet_toml, read_fleet, shipped_fleets
from tests.brake_env.env.fleet.small import SMALL


def test_the_shipped_fleets_are_the_env_s_sizes_and_the_benchmark_s() -> None:
    assert set(shipped_fleets()) == {"small", "default", "default-mixed", "large"}
    assert read_fleet("default").config == FleetConfig(episode_shifts=365)
    assert read_fleet("small").config == FleetConfig(**SMALL_FLEET, episode_shifts=365)
    assert read_fleet("default-mixed").config == FleetConfig(episode_shifts=365, regime="mixed")
    large = read_fleet("large").config
    assert (large.n_vehicles, large.hot_need, large.mild_need) == (24, 12, 8)
    assert {read_fleet(n).currency for n in shipped_fleets()} == {"USD"}


def test_a_fleet_written_is_read_back_equal_and_its_digest_is_its_content(tmp_path) -> None:
    costs = dataclasses.replace(FleetConfig().costs, shortfall=3500.0)
    f = FleetFile("mine", "-", FleetConfig(**SMALL, costs=costs), "AUD", "our pit")
    path = tmp_path / "mine.toml"
    path.write_text(fleet_toml(f))
    back = read_fleet(path)
    assert back.config == f.config and back.currency == "AUD" and back.name == "mine"
    assert back.digest == f.digest
    other = dataclasses.replace(f, config=dataclasses.replace(f.config, bays=3))
    assert other.digest != f.digest
    assert read_fleet(path, n_vehicles=4).config.n_vehicles == 4  # keywords on top


@pytest.mark.parametrize(
    ("text", "named"),
    [
        ("n_vehicle = 3\n", "n_vehicle"),
        ("n_vehicles = 0\n", "n_vehicles"),
        ("n_vehicles = 'x'\n", "n_vehicles"),
        ("hot_need = 9\nmild_need = 9\n", "hot_need + mild_need"),
        ("[costs]\npadd = 1.0\n", "padd"),
        ("[costs]\ncurrency = 3\n", "currency"),
        ("[costs]\npad = -1.0\n", "pad"),
        ("costs = 3\n", "costs must be a table"),
        ("regime = 'weird'\n", "regime"),
        ("n_vehicles = [\n", "not TOML"),
        ("shifts_per_year = 0\n", "shifts_per_year"),
        ("shifts_per_year = 730.5\n", "shifts_per_year"),
        ("shifts_per_year = true\n", "shifts_per_year"),
    ],
)
def test_a_bad_fleet_file_is_refused_naming_the_file_and_the_key(tmp_path, text, named) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ValueError, match=re.escape(named)) as e:
        read_fleet(path)
    assert str(path) in str(e.value)


def test_shifts_a_year_are_read_written_and_no_part_of_the_fleet_s_digest(tmp_path) -> None:
    """730 by default (2 x 12 h shifts a day) and in every shipped file; a file's own value
    read and written back; the digest (the suites' and the units' key) ignores it: it only
    prices a study's figures, no episode changes."""
    assert {read_fleet(n).shifts_per_year for n in shipped_fleets()} == {730}
    path = tmp_path / "mine.toml"
    path.write_text("n_vehicles = 3\nhot_need = 1\nmild_need = 1\nshifts_per_year = 600\n")
    mine = read_fleet(path)
    assert mine.shifts_per_year == 600
    assert dataclasses.replace(mine, shifts_per_year=730).digest == mine.digest
    again = tmp_path / "again.toml"
    again.write_text(fleet_toml(mine))
    assert read_fleet(again).shifts_per_year == 600
    (tmp_path / "plain.toml").write_text("n_vehicles = 3\nhot_need = 1\nmild_need = 1\n")
    assert read_fleet(tmp_path / "plain.toml").shifts_per_year == 730


def test_an_unknown_fleet_names_the_shipped_ones() -> None:
    with pytest.raises(ValueError, match=r"not a shipped fleet \(default, default-mixed"):
        read_fleet("nowhere.toml")


def test_v2_runs_the_file_s_fleet_and_v0_keeps_working(tmp_path, atlas) -> None:
    path = tmp_path / "f.toml"
    path.write_text(fleet_toml(FleetFile("f", "-", FleetConfig(**SMALL))))
    env = gym.make("BrakeWearFleet-v2", fleet=str(path), atlas=atlas)
    assert env.unwrapped.config == FleetConfig(**SMALL)
    assert gym.spec("BrakeWearFleet-v2").max_episode_steps == 365
    assert gym.make("BrakeWearFleet-v2").unwrapped.config == FleetConfig(episode_shifts=365)
    assert gym.make("BrakeWearFleet-v0").unwrapped.config == FleetConfig()
    with pytest.raises(ValueError, match="config or fleet"):
        BrakeWearFleetEnv(FleetConfig(), fleet="small")


def test_the_parallel_env_takes_a_fleet_file() -> None:
    pytest.importorskip("pettingzoo")
    from brake_env.env.fleet.parallel import parallel_env

    env = parallel_env(fleet="large")
    assert len(env.possible_agents) == 24 + 1  # the vehicles and the store


def test_the_last_step_s_episode_cost_equals_the_runner_s(atlas) -> None:
    """The wrapper's headline and net equal :func:`run_episode`'s on the same episode; no
    step before the last carries them."""

    class Hot:  # every vehicle on the hot route, nothing ordered
        def predict(self, obs, deterministic=True):
            return np.zeros(env.action_space.shape, dtype=np.int64), None

    env = gym.make("BrakeWearFleet-v2", fleet="small", atlas=atlas, episode_shifts=40)
    want = run_episode(env, Hot(), seed=3)
    env.reset(seed=3)
    seen = []
    for _ in range(40):
        *_, _, truncated, info = env.step(Hot().predict(None)[0])
        seen.append("episode_cost" in info)
    assert truncated and seen == [False] * 39 + [True]
    got = info["episode_cost"]
    assert got["shifts"] == 40
    assert got["cost"] == pytest.approx(want.per_vehicle_shift, rel=1e-12)
    assert got["net"] == pytest.approx(want.net, rel=1e-12)
    assert got["billed"] == pytest.approx(want.billed, rel=1e-12)
    assert got["net"] < got["cost"]  # pad life is left at the end
