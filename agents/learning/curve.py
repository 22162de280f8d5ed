"""Learned agents on the cost study's pads: evaluated pad by pad, and their learning curve
(docs/results/single-pad.md).

A trained agent acting deterministically is a stateless policy of its observation, and its
observation at a decision point is a function of the pad's age and the predictor's estimates
there (:func:`agents.learning.features.pad_observations`). So, like a rule, it is evaluated on the
decision points of a :class:`~agents.study.pads.PadSet`: the very pads, operating conditions
and estimates every other policy meets (common random numbers), with one forward pass.
"""

from __future__ import annotations

import copy
import json
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from stable_baselines3.common.callbacks import BaseCallback

from agents.learning.features import pad_observations
from agents.policies.rules import Policy
from agents.study import outcomes as oc
from agents.study.pads import PadSet
from brake_env.env.brake_wear import REPLACE
from brake_env.env.config import EnvConfig

F32 = NDArray[np.float32]
_CHUNK = 1 << 16  # observations per forward pass


def decide(act: Callable[[F32], NDArray[Any]], obs: F32, pads: PadSet) -> oc.Outcomes:
    """Outcomes of a deterministic policy ``act`` (observations -> actions) on ``pads``."""
    parts = [np.asarray(act(obs[i : i + _CHUNK])) for i in range(0, len(obs), _CHUNK)]
    actions = np.concatenate(parts) if parts else np.zeros(0, dtype=np.int64)
    return oc.at_decision(pads, oc.first_true(actions.reshape(-1) == REPLACE, pads))


def agent_outcomes(
    agent: Policy, predictor: str, pads: PadSet, fields: tuple[str, ...], max_age: float
) -> oc.Outcomes:
    """A saved agent's outcomes on ``pads`` (``predictor``'s estimates must be there)."""
    obs = pad_observations(pads, predictor, fields, max_age)
    return decide(lambda x: agent.predict(x)[0], obs, pads)


class LearningCurve(BaseCallback):
    """Cost ratio to the oracle on fixed pads against training steps; keeps the best agent.

    Every ``every`` calls (vector-env steps) the agent acts deterministically on every
    decision point of ``pads``, normalised with the training env's current statistics.

    Args:
        pads: The curve's pads, with the predictor's and the oracle's estimates.
        predictor: The agent's predictor.
        fields: The estimate fields the agent sees.
        env: The training env's settings (its costs and episode length).
        every: Vector-env steps between points.
    """

    def __init__(
        self, pads: PadSet, predictor: str, fields: tuple[str, ...], env: EnvConfig, every: int
    ) -> None:
        super().__init__()
        config = env
        self.pads, self.every, self.costs = pads, every, config.costs
        self.obs = pad_observations(pads, predictor, fields, config.episode_events)
        self.oracle_cost = float(oc.cost_per_1000(pads, oc.oracle(pads), self.costs))
        self.points: list[dict[str, float]] = []
        self._best: tuple[float, int, Any, Any] | None = None
        self._t0 = time.perf_counter()

    def _on_step(self) -> bool:
        if self.n_calls % self.every == 0:
            self.evaluate()
        return True

    def _on_training_end(self) -> None:
        if not self.points or self.points[-1]["timesteps"] != self.num_timesteps:
            self.evaluate()

    def evaluate(self) -> float:
        """Add a point for the agent as it is now; its cost ratio to the oracle."""
        venv = self.model.get_vec_normalize_env()

        def act(x: F32) -> NDArray[Any]:
            z = venv.normalize_obs(x) if venv is not None else x
            return self.model.predict(z, deterministic=True)[0]

        out = decide(act, self.obs, self.pads)
        ratio = float(oc.cost_per_1000(self.pads, out, self.costs)) / self.oracle_cost
        fails = oc.failures_per_100(self.pads, out)["all"]
        self.points.append(
            {
                "timesteps": float(self.num_timesteps),
                "ratio_to_oracle": ratio,
                "failures_per_100_pads": fails,
                "seconds": time.perf_counter() - self._t0,
            }
        )
        if self._best is None or ratio < self._best[0]:
            state = copy.deepcopy(self.model.policy.state_dict())
            rms = copy.deepcopy(venv.obs_rms) if venv is not None else None
            self._best = (ratio, self.num_timesteps, state, rms)
        return ratio

    def restore_best(self, model: Any, venv: Any) -> int:
        """Put the best agent seen back into ``model`` and its statistics into ``venv``;
        the training step it was seen at."""
        if self._best is None:
            return int(model.num_timesteps)
        _, step, state, rms = self._best
        model.policy.load_state_dict(state)
        if rms is not None:
            venv.obs_rms = copy.deepcopy(rms)
        return int(step)

    def save(self, path: Path) -> None:
        best = None if self._best is None else {"timesteps": self._best[1], "ratio": self._best[0]}
        doc = {"pads": len(self.pads), "best": best, "points": self.points}
        path.write_text(json.dumps(doc, indent=2) + "\n")
