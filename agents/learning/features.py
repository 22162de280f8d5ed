"""What a learned agent sees: the pad's age and the predictor's RUL estimates, in log units of
the decision interval, and nothing else.

The replacement decision hinges on "is the RUL below one or two steps?", a sliver near 0 of a
feature that spans ~1e5 events: ``log1p(x / decision_interval)`` gives that region the
resolution a small MLP can separate (VecNormalize then centres it). The raw sensor readings
are left out: the predictor has already digested them, and six channels of noise only slow
the agent's learning of the one comparison that matters
(docs/results/single-pad.md). The same function builds the observation in the env
(:class:`AgentFeatures`) and at the decision points of a pad set (:func:`pad_observations`),
so an agent evaluated pad by pad sees exactly what it saw in training.
"""

from __future__ import annotations

from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from agents.policies.rules import AGE_INDEX, RUL_INDEX
from agents.study.outcomes import observed
from agents.study.pads import PadSet

F32 = NDArray[np.float32]


def rul_fields(predictor_gives_interval: bool) -> tuple[str, ...]:
    """The estimate fields an agent on a predictor sees: the lower bound too where the
    predictor gives an interval."""
    return ("rul_mean", "rul_lower") if predictor_gives_interval else ("rul_mean",)


def agent_features(age: F32, rul: F32, interval: float) -> F32:
    """(..., 1 + fields): ``log1p(x / interval)`` of the age and of each RUL field, in
    float32 as the env's observation is."""
    x = np.concatenate([np.asarray(age, np.float32)[..., None], np.asarray(rul, np.float32)], -1)
    return np.log1p(x / np.float32(interval)).astype(np.float32, copy=False)


class AgentFeatures(gym.ObservationWrapper[NDArray[np.float32], Any, NDArray[np.float32]]):
    """``RULObservation(BrakeWear-v0)``'s observation as the agent sees it (the module's
    docstring): age and every appended RUL field, ``log1p(x / decision_interval)``."""

    def __init__(self, env: gym.Env[NDArray[np.float32], Any]) -> None:
        super().__init__(env)
        base = env.observation_space
        assert isinstance(base, spaces.Box)
        if base.shape[0] <= RUL_INDEX:
            raise ValueError("AgentFeatures: wrap RULObservation(BrakeWear-v0), not the bare env")
        self.interval = float(env.unwrapped.config.decision_interval)  # type: ignore[attr-defined]
        low = self._features(base.low)
        high = self._features(base.high)
        self.observation_space = spaces.Box(low, high, dtype=np.float32)

    def _features(self, obs: NDArray[Any]) -> F32:
        obs = np.asarray(obs, dtype=np.float32)
        return agent_features(obs[..., AGE_INDEX], obs[..., RUL_INDEX:], self.interval)

    def observation(self, observation: NDArray[np.float32]) -> NDArray[np.float32]:
        return self._features(observation)


def pad_observations(pads: PadSet, predictor: str, fields: tuple[str, ...], max_age: float) -> F32:
    """The agent's observation at every decision point of ``pads`` (rows x (1 + fields)),
    as :class:`AgentFeatures` gives it in an env whose ages are clipped at ``max_age``
    (its ``episode_events``)."""
    est = pads.estimates[predictor]
    missing = [f for f in fields if f not in est]
    if missing:
        raise ValueError(f"pad_observations: predictor {predictor!r} gives no {missing}")
    age = np.clip(pads.age, 0, max_age).astype(np.float32)
    rul = np.stack([observed(est[f]) for f in fields], axis=-1).astype(np.float32)
    return agent_features(age, rul, pads.decision_interval)


class CostInPlanned(gym.RewardWrapper[NDArray[np.float32], Any]):
    """The reward in planned replacements: -1 for a planned replacement, -10 for a failure
    at the default weights. Value targets of order one need no running reward
    normalisation (whose scale moves as the policy changes how often it replaces), and
    the cost ratio the agent is trained on is the env's, unchanged."""

    def __init__(self, env: gym.Env[NDArray[np.float32], Any]) -> None:
        super().__init__(env)
        costs = env.unwrapped.config.costs  # type: ignore[attr-defined]
        if costs.planned_replacement <= 0:
            raise ValueError("CostInPlanned: the planned replacement must cost > 0")
        self.unit = float(costs.planned_replacement)

    def reward(self, reward: SupportsFloat) -> float:
        return float(reward) / self.unit
