"""Train a plain-RL configuration and measure it on the dev split: the one entry point of
both algorithms (``python -m agents.fleet.benchmark.training.train``, the tuning's trials).

The dev measure is the suite's net cost per vehicle-shift on dev episodes ``0..episodes-1``
(the episodes every design choice is made on), every action checked against the env's mask.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from agents.fleet.benchmark.training import mappo, maskable
from agents.fleet.benchmark.training.config import TrainingConfig, suite_env
from agents.fleet.evaluation.costs import run_episode
from brake_env.model.atlas import Atlas

MODULES = {"maskable_ppo": maskable, "mappo": mappo}


def train(config: TrainingConfig, atlas: Atlas, log: Any = None) -> tuple[Any, dict[str, Any]]:
    """(the trained policy, ``training_steps`` and ``cpu_seconds``)."""
    return MODULES[config.algorithm].train(config, atlas, log)


def save(config: TrainingConfig, policy: Any, path: str | Path, meta: dict[str, Any]) -> Path:
    return MODULES[config.algorithm].save(policy, path, meta, config)


def load(algorithm: str, path: str | Path, env: Any) -> Any:
    return MODULES[algorithm].load(path, env)


def dev_net(config: TrainingConfig, policy: Any, atlas: Atlas, episodes: int) -> list[float]:
    """``policy``'s net cost per vehicle-shift on dev episodes ``0..episodes-1``.

    Raises:
        ValueError: More episodes than the dev split has, or an action outside the mask.
    """
    if not 1 <= episodes <= config.suite.dev_episodes:
        raise ValueError(f"dev episodes must be in [1, {config.suite.dev_episodes}], got"
                         f" {episodes}")  # fmt: skip
    make, _ = suite_env(config.suite, atlas, "dev")
    env = make()
    return [float(run_episode(env, policy, s, check_masks=True).net) for s in range(episodes)]


def summary(net: list[float]) -> str:
    return f"dev net {np.mean(net):.3f} (episodes: {', '.join(f'{x:.2f}' for x in net)})"
