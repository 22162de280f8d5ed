"""A learning curve during SB3 training: the agent's mean cost on the study's curve
episodes (seeds apart from every other set) every so many shifts, priced with the
normalisation statistics of that moment."""

from __future__ import annotations

from typing import Any

import numpy as np

from agents.fleet.evaluation.costs import run_episodes
from agents.fleet.settings import FleetStudyConfig


def mean_cost(env: Any, agent: Any, config: FleetStudyConfig) -> float:
    eps = run_episodes(env, agent, config.curve_seeds())
    return float(np.mean([e.per_vehicle_shift for e in eps]))


class LearningCurve:
    """The learning curve: the agent's mean cost on the curve episodes at the start of PPO
    (after any cloning) and every ``every`` shifts (an SB3 callback; ``cost(model,
    obs_mean, obs_var)`` prices the agent the model is at that moment, with the env's
    normalisation statistics of that moment). SB3 counts ``per_shift`` samples a shift."""

    def __init__(self, every: int, cost: Any, per_shift: int = 1) -> None:
        self.every, self.cost, self.per_shift = every * per_shift, cost, per_shift
        self.points: list[tuple[int, float]] = []

    def callback(self) -> Any:
        from stable_baselines3.common.callbacks import BaseCallback

        outer = self

        class Curve(BaseCallback):
            def __init__(self) -> None:
                super().__init__()
                self.next = outer.every

            def _on_training_start(self) -> None:  # the cloned policy, before PPO
                self._point()

            def _on_step(self) -> bool:
                if self.num_timesteps >= self.next:
                    self._point()
                    self.next += outer.every
                return True

            def _point(self) -> None:
                rms: Any = self.model.get_env().obs_rms  # type: ignore[union-attr]
                mean, var = rms.mean.astype(np.float32), rms.var.astype(np.float32)
                shifts = self.num_timesteps // outer.per_shift
                outer.points.append((shifts, outer.cost(self.model, mean, var)))

        return Curve()
