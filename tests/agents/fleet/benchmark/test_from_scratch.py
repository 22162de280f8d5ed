"""Plain RL from scratch on a suite (issue 41): a training configuration is checked (a bad
key refused, named), each algorithm trains for a few hundred shifts, is saved, loaded back
as fleet-score loads it and driven by fleet-score's episode runner with every action inside
the env's mask, acting as it did before it was saved."""

from __future__ import annotations

import numpy as np
import pytest

from agents.fleet.benchmark.score import Adapted
from agents.fleet.benchmark.training import maskable
from agents.fleet.benchmark.training.config import (
    REFUSED,
    TRAIN_SEED0,
    from_dict,
    read_config,
    shipped_configs,
    suite_env,
)
from agents.fleet.benchmark.training.run import dev_net, load, save, train
from agents.fleet.evaluation.costs import run_episode
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.wrappers import ExpectedRULObservation

# The small fleet, 30-shift episodes, the twin fitted on 2 pads: a short real suite.
SUITE = """name = "short"
fleet = "small"
[protocol]
shifts = 30
dev_episodes = 2
n_train_runs = 2
"""
TINY = {
    "maskable_ppo": {"timesteps": 256, "n_envs": 2, "n_steps": 64, "batch_size": 64,
                     "n_epochs": 2},
    "mappo": {"frames": 200, "frames_per_batch": 100, "minibatch": 50, "n_epochs": 2},
}  # fmt: skip


@pytest.fixture(scope="module")
def short(tmp_path_factory):
    path = tmp_path_factory.mktemp("suite") / "short.toml"
    path.write_text(SUITE)
    return path


def test_the_shipped_configs_read_and_train_from_scratch() -> None:
    assert set(shipped_configs()) == {"maskable_ppo", "mappo"}
    for name in shipped_configs():
        c = read_config(name)
        assert c.suite.name == "default" and c.algorithm == name
        assert getattr(c.settings, "imitation_episodes", 0) == 0


@pytest.mark.parametrize(
    ("data", "named"),
    [
        ({"algorithm": "maskable_ppo", "trian": {}}, "trian"),
        ({"algorithm": "maskable_ppo", "train": {"learnig_rate": 1e-3}}, "learnig_rate"),
        ({"algorithm": "maskable_ppo", "train": {"imitation_episodes": 4}}, "imitation"),
        ({"algorithm": "maskable_ppo", "train": {"learning_rate": -1.0}}, "learning_rate"),
        ({"algorithm": "ppo"}, "algorithm"),
        ({"algorithm": "mappo"}, "spares"),
        ({"algorithm": "mappo", "spares": [4, 2]}, "spares"),
        ({"algorithm": "maskable_ppo", "suite": "nowhere"}, "nowhere"),
    ],
)
def test_a_bad_config_is_refused_naming_what_is_wrong(data, named) -> None:
    with pytest.raises(ValueError, match=named):
        from_dict(data, "cfg.toml")
    assert "vehicle_net" in REFUSED


def test_a_config_file_that_is_not_toml_is_refused(tmp_path) -> None:
    p = tmp_path / "bad.toml"
    p.write_text("algorithm = \n")
    with pytest.raises(ValueError, match="not TOML"):
        read_config(p)


@pytest.mark.parametrize("algorithm", ["maskable_ppo", "mappo"])
def test_trained_saved_loaded_and_scored_inside_the_mask(algorithm, short, atlas, tmp_path) -> None:
    config = read_config(algorithm, suite=str(short)).with_settings(**TINY[algorithm])
    policy, cost = train(config, atlas)
    assert cost["training_steps"] == next(iter(TINY[algorithm].values()))
    path = save(config, policy, tmp_path / "model", cost)
    make, _ = suite_env(config.suite, atlas, "test")
    env = make()
    loaded = Adapted(load(algorithm, path, env), env)  # as fleet-score drives a factory's
    seed = config.suite.test_from
    a = run_episode(env, loaded, seed, check_masks=True)
    b = run_episode(env, policy, seed, check_masks=True)
    assert a.shifts == 30 and np.isfinite(a.net)
    assert a.net == b.net  # the same policy after the round trip
    assert dev_net(config, loaded, atlas, 1) == dev_net(config, policy, atlas, 1)


def test_a_saved_agent_is_refused_on_another_fleet(short, atlas, tmp_path) -> None:
    config = read_config("maskable_ppo", suite=str(short)).with_settings(**TINY["maskable_ppo"])
    agent, cost = train(config, atlas)
    path = save(config, agent, tmp_path / "m.zip", cost)
    other = ExpectedRULObservation(
        BrakeWearFleetEnv(FleetConfig(n_vehicles=5, hot_need=2, mild_need=1))
    )
    with pytest.raises(ValueError, match="trained for 2 vehicles"):
        maskable.load(path, other)
    assert config.suite.test_from + config.suite.test_episodes < TRAIN_SEED0
