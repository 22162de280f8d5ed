"""What a learned agent sees: BrakeWear-v0's observation with pad age and RUL estimate in
log units of the decision interval.

The replacement decision hinges on "is the RUL below one or two steps?", a sliver near 0 of a
feature that spans ~1e5 events; ``log1p(x / decision_interval)`` gives that region the
resolution a small MLP can separate, and VecNormalize then centres it. The rule-based
policies read raw events and never need this.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from agents.policies import AGE_INDEX, RUL_INDEX


class AgentFeatures(gym.ObservationWrapper[NDArray[np.float32], Any, NDArray[np.float32]]):
    """Pad age and every appended RUL field mapped to ``log1p(x / decision_interval)``."""

    def __init__(self, env: gym.Env[NDArray[np.float32], Any]) -> None:
        super().__init__(env)
        base = env.observation_space
        assert isinstance(base, spaces.Box)
        self.scale = float(env.unwrapped.config.decision_interval)  # type: ignore[attr-defined]
        self.columns = np.r_[AGE_INDEX, np.arange(RUL_INDEX, base.shape[0])].astype(np.intp)
        low, high = base.low.copy(), base.high.copy()
        low[self.columns] = np.log1p(low[self.columns] / self.scale)
        high[self.columns] = np.log1p(high[self.columns] / self.scale)
        self.observation_space = spaces.Box(low, high, dtype=np.float32)

    def observation(self, observation: NDArray[np.float32]) -> NDArray[np.float32]:
        out = observation.copy()
        out[self.columns] = np.log1p(out[self.columns] / self.scale)
        return out
