"""What the fleet agents' tests share: the small fleet on 20-shift episodes, and how often
an agent does what its teacher does."""

from __future__ import annotations

from typing import Any

import numpy as np

from agents.fleet.learning.agent import oracle_fleet_env
from brake_env.env.fleet.config import SMALL_FLEET, FleetConfig

CFG = FleetConfig(**SMALL_FLEET, episode_shifts=20, events_per_shift=100)


def agreement(agent: Any, teacher: Any, atlas: Any, seeds: tuple[int, ...] = (7, 8)) -> float:
    """Fraction of the teacher's shifts (held-out episodes, the teacher driving) on which
    the agent's deterministic action is the teacher's."""
    env = oracle_fleet_env(CFG, atlas)
    same = []
    for seed in seeds:
        obs, _ = env.reset(seed=seed)
        done = False
        while not done:
            want, _ = teacher.predict(obs)
            got, _ = agent.predict(obs)
            same.append(bool(np.array_equal(want, got)))
            obs, _, terminated, truncated, _ = env.step(want)
            done = terminated or truncated
    return float(np.mean(same))
