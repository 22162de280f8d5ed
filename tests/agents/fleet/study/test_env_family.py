"""Env families (issue 45 item 3): a second fleet, defined in this module alone (its config
class, its env, one registration and a fleet file naming it), runs through the unchanged
fleet study; the brake fleet stays the default family; bad names are refused."""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any, ClassVar

import pytest

from agents.fleet.settings import FleetStudyConfig
from agents.fleet.study.run import run_fleet_study
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.family import (
    BRAKE,
    EnvFamily,
    family_of,
    make_env,
    register_family,
)
from brake_env.env.fleet.fleet_file import fleet_toml, read_fleet
from brake_env.runner import Runner


@dataclass(frozen=True)
class RailConfig(FleetConfig):
    """A rail fleet: the brake fleet's fields (its own would be added here)."""


class RailEnv(BrakeWearFleetEnv):
    """The rail fleet's env: here the brake fleet's dynamics, counting what was built."""

    built: ClassVar[int] = 0

    def __init__(self, config: RailConfig, atlas: Any = None) -> None:
        RailEnv.built += 1
        super().__init__(config, atlas=atlas)


RAIL = EnvFamily("rail", RailConfig, RailEnv, "a test's rail fleet")
register_family(RAIL)

FLEET = """name = "{name}"
{family}
n_vehicles = 3
hot_need = 1
mild_need = 1
window_slots = 1
bays = 1
[costs]
currency = "EUR"
damage = 8000.0
"""
STUDY = dict(
    shifts=30, predictors=("oracle",), heuristics=("threshold",), trials=2, trials_best=2,
    tune_episodes=1, eval_episodes=2, n_train_runs=2, agent_predictors=(),
    rollout_predictors=(), bound_iterations=2,
)  # fmt: skip


def _file(tmp_path, family: str | None) -> str:
    name = family or "plain"
    path = tmp_path / f"{name}.toml"
    line = f'family = "{family}"' if family else ""
    path.write_text(FLEET.format(name=name, family=line), encoding="utf-8")
    return str(path)


def test_a_fleet_file_names_its_family_and_the_config_finds_it_back(tmp_path):
    rail, plain = read_fleet(_file(tmp_path, "rail")), read_fleet(_file(tmp_path, None))
    assert type(rail.config) is RailConfig and type(plain.config) is FleetConfig
    assert (rail.family, plain.family) == ("rail", BRAKE)
    assert family_of(rail.config) is RAIL
    assert isinstance(make_env(rail.config), RailEnv)
    assert type(make_env(plain.config)) is BrakeWearFleetEnv
    # written back and read again: the same fleet, family included; overrides keep it
    again = tmp_path / "again.toml"
    again.write_text(fleet_toml(rail), encoding="utf-8")
    assert read_fleet(str(again)).config == rail.config
    assert read_fleet(str(again)).digest == rail.digest != plain.digest
    assert type(read_fleet(rail, episode_shifts=40).config) is RailConfig
    # the brake fleet's files keep the digest they had before families (no family key)
    assert read_fleet("default").family == BRAKE


def test_unknown_families_and_clashes_are_refused_by_name(tmp_path):
    with pytest.raises(ValueError, match=r"family must be one of brake, rail, got 'tram'"):
        read_fleet(_file(tmp_path, "tram"))
    with pytest.raises(ValueError, match=r"'rail' .RailConfig. clashes with family 'rail'"):
        register_family(EnvFamily("rail", RailConfig, BrakeWearFleetEnv))
    with pytest.raises(ValueError, match=r"'metro' .FleetConfig. clashes with family 'brake'"):
        register_family(EnvFamily("metro", FleetConfig, RailEnv))

    @dataclass(frozen=True)
    class Unregistered(FleetConfig):
        pass

    with pytest.raises(TypeError, match="no env family has config class Unregistered"):
        make_env(Unregistered())
    with pytest.raises(TypeError, match="makes envs of RailConfig, got a FleetConfig"):
        RAIL.make(FleetConfig())


def test_the_study_runs_a_second_family_through_its_own_env(tmp_path, atlas):
    """The study builds the rail fleet's envs (counted) and, the rail env being the brake
    env's dynamics here, gives exactly the brake fleet's figures on the same file."""
    before = RailEnv.built
    costs = {}
    for family in ("rail", None):
        config = FleetStudyConfig(size=_file(tmp_path, family), **STUDY)
        out = tmp_path / (family or "brake")
        run_fleet_study(config, atlas, out, Runner(0), n_resamples=200)
        s = json.loads((out / "costs.json").read_text())
        costs[family] = {(r["predictor"], r["policy"]): r["episodes"]["net"] for r in s["rows"]}
        costs[family]["bound"] = s["bound"]["episodes"]
    assert RailEnv.built > before  # the study made the family's env, not the brake one
    assert costs["rail"] == costs[None] and len(costs["rail"]) >= 3
