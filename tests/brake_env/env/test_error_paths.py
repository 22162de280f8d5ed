"""The env's own clear errors for what RL clients get wrong (issue 22 item 5, 6): render
modes that do not exist, actions outside Discrete(2), step before reset, unknown keywords
as TypeError, and the module-qualified id in a fresh process."""

from __future__ import annotations

import re
import subprocess
import sys

import gymnasium as gym
import numpy as np
import pytest

import brake_env  # noqa: F401  # registers BrakeWear-v0
from brake_env._validate import UnknownArgumentError
from brake_env.env.brake_wear import BrakeWearEnv
from brake_env.env.vector import BrakeWearVectorEnv

FAST = {"k_mean": 1e-5, "k_std": 1e-6, "decision_interval": 500, "episode_events": 100_000}


def test_human_render_mode_says_there_is_none(atlas):
    for make in (
        lambda: gym.make("BrakeWear-v0", atlas=atlas, render_mode="human"),
        lambda: BrakeWearEnv(atlas=atlas, render_mode="human"),
        lambda: gym.make("BrakeWearFleet-v0", atlas=atlas, render_mode="human"),
        lambda: gym.make("BrakeWearFleetSmall-v0", atlas=atlas, render_mode="human"),
    ):
        with pytest.raises(ValueError, match="has no 'human' render mode"):
            make()
    fleet = gym.make("BrakeWearFleetSmall-v0", atlas=atlas, render_mode="ansi_list")
    fleet.reset(seed=0)
    fleet.step(fleet.action_space.sample())
    frames = fleet.render()  # the reset's frame and the step's
    assert len(frames) == 2 and all(isinstance(f, str) and f for f in frames)
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
        (np.array([0, 1]), r"one action.*not an array of shape \(2,\): got array\(\[0, 1\]\)"),
        (np.array([1]), r"not an array of shape \(1,\): got array\(\[1\]\)"),
        (1.0, r"int 0 \(keep\) or 1 \(replace\) of Discrete\(2\), got 1.0 \(float\)"),
        (0.7, r"of Discrete\(2\), got 0.7 \(float\)"),
        (float("nan"), r"got nan \(float\)"),
        (np.float32(0.0), r"got np.float32\(0.0\) \(float32\)"),
        (np.array(1.0), r"got array\(1.\) \(ndarray\)"),
        (np.array(True), r"got array\(True\) \(ndarray\)"),
        ("1", r"got '1' \(str\)"),
        (None, r"got None \(NoneType\)"),
        ([1], r"got \[1\] \(list\)"),
        ((0,), r"got \(0,\) \(tuple\)"),
        (2, "must be 0 .keep. or 1 .replace., got 2"),
        (np.int64(-1), r"got np.int64\(-1\)"),
    ],
)
def test_actions_outside_discrete_2_are_refused(atlas, action, match):
    env = BrakeWearEnv(atlas=atlas, **FAST)
    env.reset(seed=0)
    with pytest.raises(ValueError, match=match) as err:
        env.step(action)
    assert str(err.value).startswith("BrakeWear-v0: ")
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


def test_step_after_the_episode_is_a_clear_error(atlas):
    env = BrakeWearEnv(atlas=atlas, **{**FAST, "episode_events": 1001})
    env.reset(seed=0)
    for _ in range(2):
        env.step(0)
    with pytest.raises(RuntimeError, match=r"BrakeWear-v0: the episode is over; call reset\(\)"):
        env.step(0)


def test_vector_env_refuses_what_is_not_one_int_action_per_env(atlas):
    vec = BrakeWearVectorEnv(num_envs=2, atlas=atlas, **FAST)
    with pytest.raises(RuntimeError, match=r"BrakeWear-v0: call reset\(\) before step\(\)"):
        vec.step(np.array([0, 1]))
    vec.reset(seed=0)
    for bad, shown in [
        (np.array([1.0, 0.0]), r"array\(\[1., 0.\]\)"),
        (np.array([0.7, 0.0]), r"array\(\[0.7, 0. \]\)"),
        (np.array([np.nan, 0.0]), r"array\(\[nan,  0.\]\)"),
        (["1", "0"], r"\['1', '0'\]"),
        (np.array([0, 2]), r"array\(\[0, 2\]\)"),
        (np.array([1]), r"array\(\[1\]\)"),
        (np.array([[0, 1]]), r"array\(\[\[0, 1\]\]\)"),
        (1, "got 1$"),
        (None, "got None$"),
    ]:
        with pytest.raises(ValueError, match=r"^BrakeWear-v0: actions must be 2 integers in") as e:
            vec.step(bad)
        assert re.search(shown, str(e.value)), (shown, str(e.value))
    for good in (np.array([0, 1]), [1, 0], np.array([1, 1], dtype=np.uint8)):
        vec.step(good)


def test_sb3_and_gymnasium_vector_envs_pass_their_actions(atlas):
    """SB3's DummyVecEnv and Gymnasium's SyncVectorEnv hand each env a numpy integer of
    shape () (an element of the batch of actions)."""
    from stable_baselines3.common.vec_env import DummyVecEnv

    seen = []

    class Spy(BrakeWearEnv):
        def step(self, action):
            seen.append(action)
            return super().step(action)

    make = lambda: Spy(atlas=atlas, **FAST)  # noqa: E731
    for vec in (DummyVecEnv([make]), gym.vector.SyncVectorEnv([make, make])):
        vec.reset()
        vec.step(np.ones(vec.num_envs, dtype=np.int64))
    assert seen and all(isinstance(a, np.integer) and np.shape(a) == () for a in seen)
