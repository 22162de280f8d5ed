"""The env's own clear errors for what RL clients get wrong (issue 22 item 5, 6): render
modes that do not exist, actions outside Discrete(2), step before reset, unknown keywords
as TypeError, and the module-qualified id in a fresh process."""

from __future__ import annotations

import subprocess
import sys

import gymnasium as gym
import numpy as np
import pytest

import brake_env  # noqa: F401  # registers BrakeWear-v0
from brake_env._validate import UnknownArgumentError
from brake_env.env.brake_wear import BrakeWearEnv

FAST = {"k_mean": 1e-5, "k_std": 1e-6, "decision_interval": 500, "episode_events": 100_000}


def test_human_render_mode_says_there_is_none(atlas):
    for make in (
        lambda: gym.make("BrakeWear-v0", atlas=atlas, render_mode="human"),
        lambda: BrakeWearEnv(atlas=atlas, render_mode="human"),
    ):
        with pytest.raises(ValueError, match="has no 'human' render mode"):
            make()
    env = gym.make("BrakeWear-v0", atlas=atlas, render_mode="rgb_array")
    assert env.metadata["render_modes"] == ["ansi", "rgb_array"]


def test_list_render_modes_collect_frames(atlas):
    env = gym.make("BrakeWear-v0", atlas=atlas, render_mode="ansi_list", **FAST)
    env.reset(seed=0)
    env.step(0)
    frames = env.render()
    assert isinstance(frames, list) and all(isinstance(f, str) for f in frames)


@pytest.mark.parametrize(
    ("action", "match"),
    [
        (np.array([0, 1]), r"one action.*not an array of shape \(2,\)"),
        (np.array([1]), r"not an array of shape \(1,\)"),
        (1.0, r"int 0 \(keep\) or 1 \(replace\) of Discrete\(2\), got 1.0 \(float\)"),
        (np.float32(0.0), "of Discrete"),
        (np.array(1.0), "of Discrete"),
        ("1", "of Discrete"),
        (None, "of Discrete"),
        (2, "must be 0 .keep. or 1 .replace., got 2"),
        (-1, "got -1"),
    ],
)
def test_actions_outside_discrete_2_are_refused(atlas, action, match):
    env = BrakeWearEnv(atlas=atlas, **FAST)
    env.reset(seed=0)
    with pytest.raises(ValueError, match=match):
        env.step(action)
    assert env.pad_age == 1  # nothing happened


@pytest.mark.parametrize("action", [0, 1, np.int64(1), np.array(1), np.uint8(0), True])
def test_actions_of_discrete_2_are_taken(atlas, action):
    env = BrakeWearEnv(atlas=atlas, **FAST)
    env.reset(seed=0)
    assert env.action_space.contains(action)
    env.step(action)


def test_step_before_reset_is_a_clear_error(atlas):
    env = gym.make("BrakeWear-v0", atlas=atlas, **FAST)
    with pytest.raises(RuntimeError, match=r"call reset\(\) before step\(\)"):
        env.unwrapped.step(0)


def test_unknown_keyword_is_a_type_error_naming_it(atlas):
    """TorchRL's GymEnv passes ``frameskip`` and retries without it on a TypeError whose
    message says "unexpected keyword argument 'frameskip'"."""
    with pytest.raises(TypeError, match="unexpected keyword argument 'frameskip'") as e:
        gym.make("BrakeWear-v0", atlas=atlas, frameskip=4)
    assert isinstance(e.value, ValueError) and isinstance(e.value, UnknownArgumentError)
    assert "valid are" in str(e.value)


def test_module_qualified_id_in_a_fresh_process():
    """RLlib's env runners make the env in processes where the driver's ``import
    brake_env`` never ran: ``"brake_env:BrakeWear-v0"`` imports the module first."""
    code = (
        "import sys, gymnasium as gym\n"
        "assert 'brake_env' not in sys.modules\n"
        "env = gym.make('brake_env:BrakeWear-v0', decision_interval=500, k_mean=1e-5)\n"
        "obs, _ = env.reset(seed=0)\n"
        "env.step(0)\n"
        "print(type(env.unwrapped).__name__, obs.shape)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "BrakeWearEnv (7,)"
    plain = subprocess.run(
        [sys.executable, "-c", "import gymnasium as gym; gym.make('BrakeWear-v0')"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert plain.returncode != 0 and "BrakeWear" in plain.stderr  # why the id is needed
