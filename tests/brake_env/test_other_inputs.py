"""The issue's "other exceptions" outside the fleet's policies (issue 44, item 4), each now one
clear error naming what is wrong: a store's settings.json that is no mapping, a lock that is
a folder, ``config="small"`` given to the fleet env, an ``--out`` that is a dangling or
looping symbolic link, a read-only folder, and a predictor giving more or fewer estimates
than events."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest

import brake_env  # noqa: F401  # registers the envs
from brake_env.cli import simulate
from brake_env.cli.main import main
from brake_env.env.fleet.config import SMALL_FLEET, FleetConfig
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.shop import HOT
from brake_env.env.fleet.wrappers import FleetRULObservation
from brake_env.prognostics.events import RULEstimate
from brake_env.units import LOCK, SETTINGS, open_store


@pytest.mark.parametrize("settings", [[], None, "x", 5])
def test_a_settings_file_that_is_no_mapping_is_named(tmp_path, settings):
    (tmp_path / SETTINGS).write_text(json.dumps(settings))
    with pytest.raises(ValueError, match=rf"{SETTINGS} is damaged \(a \w+, not the run's settings"):
        open_store(tmp_path, {"a": 1}, ["k"], "test")
    assert json.loads((tmp_path / SETTINGS).read_text()) == settings  # left as it was


def test_a_lock_that_is_a_folder_is_named(tmp_path):
    (tmp_path / LOCK).mkdir()
    with pytest.raises(ValueError, match=r"\.lock is a folder"):
        open_store(tmp_path, {"a": 1}, ["k"], "test")


@pytest.mark.filterwarnings("ignore:.*out of date")
def test_a_fleet_name_given_as_config_is_named(atlas):
    with pytest.raises(ValueError, match=r"config must be a FleetConfig, got 'small'.*fleet="):
        gym.make("BrakeWearFleet-v0", config="small", atlas=atlas)
    with pytest.raises(ValueError, match=r"config must be a FleetConfig, got \{'n_vehicles'"):
        BrakeWearFleetEnv({"n_vehicles": 2}, atlas=atlas)


@pytest.mark.parametrize("how", ["dangling", "loop"])
def test_an_out_that_is_a_broken_symbolic_link_is_one_line(tmp_path, capsys, how):
    link = tmp_path / "out"
    if how == "dangling":
        link.symlink_to(tmp_path / "nowhere")
    else:
        link.symlink_to(tmp_path / "other")
        (tmp_path / "other").symlink_to(link)
    assert main(["atlas", "--out", str(link), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"--out {link}: cannot write there" in err[0]


def test_a_read_only_folder_is_one_line_naming_it(tmp_path, capsys, monkeypatch):
    """(The tests run as root, whom no permission stops: the write's error is raised.)"""

    def read_only(args):
        raise PermissionError(13, "Permission denied", str(tmp_path / "ro" / "atlas.npz"))

    monkeypatch.setattr(simulate, "cmd_atlas", read_only)
    assert main(["atlas", "--out", str(tmp_path / "ro")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "Permission denied" in err[0] and "ro/atlas.npz" in err[0]


class Miscounting:
    """A predictor of the RULPredictor protocol (no Predictor subclass, so nothing checks
    it on its side) giving ``extra`` estimates more than events."""

    name = "miscounting"

    def __init__(self, extra: int) -> None:
        self.extra = extra

    def fit(self, log):
        return self

    def reset(self) -> None:
        pass

    def update(self, events) -> RULEstimate:
        return RULEstimate(np.full(max(len(events) + self.extra, 0), 1e4))


@pytest.mark.parametrize("extra", [3, -1])
def test_a_predictor_giving_more_or_fewer_estimates_than_events_is_named(atlas, extra):
    cfg = FleetConfig(**{**SMALL_FLEET, "events_per_shift": 50, "episode_shifts": 4})
    env = FleetRULObservation(BrakeWearFleetEnv(cfg, atlas=atlas), Miscounting(extra))
    with pytest.raises(ValueError, match=r"miscounting: update gave \d+ estimates for \d+ events"):
        env.reset(seed=0)
        env.step(np.array([HOT] * cfg.n_vehicles + [0]))  # both vehicles drive: events
