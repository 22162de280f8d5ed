"""RL Zoo trains PPO on BrakeWear-v0 with the shipped hyperparameter file."""

from __future__ import annotations

import csv
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from agents.learning.hyperparameters import HYPERPARAMS_DIR, VecSettings, load_hyperparams
from brake_env.env.brake_wear import observation_space
from brake_env.env.config import EnvConfig

ZOO_FILE = HYPERPARAMS_DIR / "rl_zoo3" / "ppo.yml"
# Keys RL Zoo reads itself; the rest go to PPO.
ZOO_KEYS = {"n_envs", "n_timesteps", "policy", "normalize", "policy_kwargs", "env_kwargs"}


def test_zoo_file_has_the_values_of_brakewear_train():
    zoo = yaml.safe_load(ZOO_FILE.read_text())["BrakeWear-v0"]
    settings, algo_kwargs = VecSettings.split(load_hyperparams("none", "ppo"))
    assert {k: v for k, v in zoo.items() if k not in ZOO_KEYS} == algo_kwargs
    assert zoo["n_envs"] == settings.n_envs
    assert zoo["normalize"] == {"norm_obs": settings.norm_obs, "norm_reward": settings.norm_reward}
    assert zoo["policy_kwargs"] == {"net_arch": list(settings.net_arch)}
    EnvConfig.from_kwargs(**zoo["env_kwargs"])  # valid BrakeWear-v0 arguments


@pytest.mark.slow
def test_rl_zoo_trains_ppo_with_the_shipped_file(atlas, tmp_path: Path):
    from stable_baselines3 import PPO

    # Fast pads and short episodes (40 steps), so 1,024 steps see whole episodes; the
    # session's atlas from a file, so the run does not build one.
    path = atlas.save(tmp_path / "atlas.npz")
    env_kwargs = ["truth:False", "k_mean:1e-5", "k_std:1e-6", "episode_events:20000"]
    env_kwargs.append(f"atlas:{str(path)!r}")
    cmd = [
        sys.executable, "-m", "rl_zoo3.train", "--algo", "ppo", "--env", "BrakeWear-v0",
        "--gym-packages", "brake_env", "-n", "1024", "--conf-file", str(ZOO_FILE),
        "-f", str(tmp_path / "logs"), "--seed", "0", "--num-threads", "1",
        "--env-kwargs", *env_kwargs,
    ]  # fmt: skip
    proc = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    run = tmp_path / "logs" / "ppo" / "BrakeWear-v0_1"
    assert (run / "BrakeWear-v0" / "vecnormalize.pkl").is_file()
    model = PPO.load(run / "BrakeWear-v0.zip", device="cpu")
    space = observation_space(EnvConfig(episode_events=20_000))
    assert model.observation_space.shape == space.shape
    assert model.num_timesteps == 1024 and model.n_envs == 4
    # Monitor logs: every env finished episodes of 40 steps.
    for i in range(4):
        with open(run / f"{i}.monitor.csv") as f:
            rows = list(csv.DictReader(line for line in f if not line.startswith("#")))
        assert rows and all(int(r["l"]) == 40 for r in rows)
        assert np.isfinite([float(r["r"]) for r in rows]).all()
