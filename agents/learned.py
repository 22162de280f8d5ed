"""Learned agents in the cost study: trained as units of the runner (:mod:`agents.units`),
evaluated pad by pad on the study's pads, and their learning curve (README "Maintenance
cost by predictor").

A trained agent acting deterministically is a stateless policy of its observation, and its
observation at a decision point is a function of the pad's age and the predictor's estimates
there (:func:`agents.features.pad_observations`). So, like a rule, it is evaluated on the
decision points of a :class:`~agents.pad_study.PadSet`: the very pads, operating conditions
and estimates every other policy meets (common random numbers), with one forward pass.
"""

from __future__ import annotations

import copy
import json
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray
from stable_baselines3.common.callbacks import BaseCallback

from agents import outcomes as oc
from agents.features import pad_observations
from agents.pad_study import PadSet
from agents.policies.rules import PolicyId
from agents.results import AgentRuns
from agents.units import agent_unit, write_trained
from brake_env.env.brake_wear import REPLACE
from brake_env.env.config import EnvConfig
from brake_env.prognostics.protocol import Predictor

if TYPE_CHECKING:
    from agents.compare import CompareConfig
    from agents.train import TrainedAgent
    from brake_env.runner import Unit

F32 = NDArray[np.float32]
_CHUNK = 1 << 16  # observations per forward pass


def decide(act: Callable[[F32], NDArray[Any]], obs: F32, pads: PadSet) -> oc.Outcomes:
    """Outcomes of a deterministic policy ``act`` (observations -> actions) on ``pads``."""
    parts = [np.asarray(act(obs[i : i + _CHUNK])) for i in range(0, len(obs), _CHUNK)]
    actions = np.concatenate(parts) if parts else np.zeros(0, dtype=np.int64)
    return oc.at_decision(pads, oc.first_true(actions.reshape(-1) == REPLACE, pads))


def agent_outcomes(
    agent: TrainedAgent, pads: PadSet, fields: tuple[str, ...], max_age: float
) -> oc.Outcomes:
    """A saved agent's outcomes on ``pads`` (its predictor's estimates must be there)."""
    obs = pad_observations(pads, agent.predictor, fields, max_age)
    return decide(lambda x: agent.predict(x)[0], obs, pads)


class LearningCurve(BaseCallback):
    """Cost ratio to the oracle on fixed pads against training steps; keeps the best agent.

    Every ``every`` calls (vector-env steps) the agent acts deterministically on every
    decision point of ``pads``, normalised with the training env's current statistics.

    Args:
        pads: The curve's pads, with the predictor's and the oracle's estimates.
        predictor: The agent's predictor.
        fields: The estimate fields the agent sees.
        env_kwargs: The training env's keyword arguments (its costs and episode length).
        every: Vector-env steps between points.
    """

    def __init__(
        self,
        pads: PadSet,
        predictor: str,
        fields: tuple[str, ...],
        env_kwargs: Mapping[str, Any],
        every: int,
    ) -> None:
        super().__init__()
        config = EnvConfig.from_kwargs(**dict(env_kwargs))
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


def agent_units(
    config: CompareConfig,
    predictors: Any,
    atlas: Any,
    curve_pads: Any,
    seed: int,
    hyperparams: Mapping[str, dict[str, Any]] | None = None,
) -> list[Unit]:
    """The training of each agent of a comparison as a unit keyed ``agent/<predictor>``
    (the best checkpoint on ``curve_pads``, the tuning pads, kept); ``predictors``,
    ``atlas`` and ``curve_pads`` as :meth:`~brake_env.runner.Runner.share` gave them."""
    hp = hyperparams or {}
    c = config
    args = (c.algo, c.timesteps, seed, c.env_kwargs)
    return [
        agent_unit(n, predictors, atlas, curve_pads, *args, hp.get(n)) for n in c.agent_predictors
    ]


def agent_runs(
    config: CompareConfig,
    predictors: Mapping[str, Predictor],
    trained: Mapping[str, Any],
    eval_pads: PadSet,
    out_dir: Path,
) -> AgentRuns:
    """The agents of :func:`agent_units`' results ``trained`` (by predictor) written to
    ``out_dir/agents/<predictor>``, and each evaluated on ``eval_pads``."""
    from agents.train import TrainedAgent, agent_fields

    runs = AgentRuns()
    for name, unit in trained.items():
        res = write_trained(unit, out_dir / "agents" / name)
        runs.seconds[name] = res.seconds
        runs.curves[name] = res.curve
        pid = PolicyId("agent", name, algo=config.algo)
        fields = agent_fields(predictors[name])
        agent = TrainedAgent(res.out_dir)
        runs.outcomes[pid] = agent_outcomes(agent, eval_pads, fields, config.episode_events)
    return runs
