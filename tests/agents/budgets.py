"""Tiny budgets shared by the agents' tests: fast-wearing pads, short episodes, a small PPO."""

from __future__ import annotations

import argparse

from brake_env.env.config import EnvConfig

FAST = {"k_mean": 1e-5, "k_std": 1e-6, "decision_interval": 500, "episode_events": 30_000}

TINY = {
    "n_envs": 2,
    "n_steps": 32,
    "batch_size": 32,
    "n_epochs": 1,
    "net_arch": [16],
    "initial_replace_prob": 0.05,
    "torch_threads": 1,
}

FAST_ENV = EnvConfig.from_kwargs(**FAST)

ARGS = argparse.Namespace(seed=0, quiet=True, preset="hot-duty", cache_dir=None, atlas=None)
