"""What a cost study runs (:class:`StudyConfig`): the env its pads live in, the predictors and
agents compared, the tuning candidates, the budgets and the intervals' settings. The type
every layer of the study takes; the commands build it from their arguments."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from brake_env.env.config import CostWeights, EnvConfig
from brake_env.model.regime import WearRegime
from brake_env.prognostics.registry import predictor_names

# Thresholds in decision intervals (0: never replace) and replacement ages in mean lives of
# an ID pad (inf: never): geometric grids (4 and 16 a doubling, with the powers of two
# themselves, one decision interval among them), fine enough that tuning is not limited
# by them.
THRESHOLDS = (0.0, *(2.0 ** (k / 4) for k in range(-16, 38)))
AGES = (*(2.0 ** (k / 16) for k in range(-64, 25)), math.inf)
# The env fields a study's settings report (``costs.json`` "config"), in this order.
_ENV_FIELDS = ("regime", "ood_share", "decision_interval", "episode_events")


def _default_env() -> EnvConfig:
    return EnvConfig(regime="mixed")


@dataclass(frozen=True)
class StudyConfig:
    """What ``brakewear compare`` (and ``train``'s evaluation) runs.

    Attributes:
        env: BrakeWear-v0's settings: the pads' wear regime (``mixed`` by default: half
            OOD), the decision interval, the agents' episode length and the cost weights,
            whose failure-to-planned ratio is the headline's.
        predictors: Predictors whose threshold policies are tuned and evaluated.
        agent_predictors: Predictors that also get a trained agent (may be empty).
        algo: ``ppo`` or ``dqn``.
        timesteps: Training steps of each agent.
        min_timesteps: Fewer training steps than this train no agent: the report says the
            budget is too small instead of giving a figure.
        n_train_runs: Run-to-failure pads the predictors are fitted on.
        tune_pads: Tuning pads of each wear-regime label the regime draws.
        eval_pads: Held-out pads of each label, every policy evaluated on them.
        min_tune_pads: Fewer tuning pads in all than this tune nothing (as for agents).
        failure_ratios: Failure-to-planned cost ratios of the sensitivity study (the env's
            own ratio is added).
        thresholds: Candidate RUL thresholds in decision intervals (0: never replace).
        ages: Candidate ages of the fixed-interval policy in mean lives of an ID pad
            (``inf``: never replace).
        level: Confidence level of the intervals [-].
        n_resamples: Bootstrap resamples.
        ood_pair: Two predictors whose best policies' OOD failures per 100 pads are set
            against each other with a paired interval (the paper's question: does the
            twin fail fewer OOD pads than the physics model?); named by the gap's key in
            ``costs.json``.
    """

    env: EnvConfig = field(default_factory=_default_env)
    predictors: tuple[str, ...] = field(default_factory=predictor_names)
    agent_predictors: tuple[str, ...] = ("twin", "oracle")
    algo: str = "ppo"
    timesteps: int = 100_000
    min_timesteps: int = 50_000
    n_train_runs: int = 10
    tune_pads: int = 100
    eval_pads: int = 1000
    min_tune_pads: int = 90
    failure_ratios: tuple[float, ...] = (5.0, 10.0, 50.0, 200.0)
    thresholds: tuple[float, ...] = THRESHOLDS
    ages: tuple[float, ...] = AGES
    level: float = 0.95
    n_resamples: int = 4000
    ood_pair: tuple[str, str] = ("twin", "physics")

    def __post_init__(self) -> None:
        if not isinstance(self.env, EnvConfig):
            raise TypeError(f"env must be an EnvConfig, got {self.env!r}")
        for group in (self.predictors, self.agent_predictors):
            bad = [p for p in group if p not in predictor_names()]
            if bad:
                raise ValueError(f"unknown predictor(s) {bad}; valid are {list(predictor_names())}")
        for name in ("tune_pads", "eval_pads", "n_resamples", "timesteps", "n_train_runs"):
            if getattr(self, name) < 1:
                raise ValueError(f"{name} must be >= 1, got {getattr(self, name)}")
        if not self.thresholds or not self.ages:
            raise ValueError("give at least one threshold and one fixed-interval age")
        if min(self.thresholds) < 0 or min(self.ages) <= 0:
            raise ValueError("thresholds must be >= 0 and ages > 0")
        if not 0 < self.level < 1:
            raise ValueError(f"level must be in (0, 1), got {self.level}")

    @property
    def wear(self) -> WearRegime:
        """The distribution of K of the training pads and of every studied pad."""
        return self.env.wear

    @property
    def decision_interval(self) -> int:
        return self.env.decision_interval

    @property
    def episode_events(self) -> int:
        return self.env.episode_events

    @property
    def costs(self) -> CostWeights:
        """The env's cost weights: the headline's."""
        return self.env.costs

    def ratios(self) -> tuple[float, ...]:
        """The sensitivity study's failure-to-planned ratios and the env's own."""
        return tuple(dict.fromkeys((*self.failure_ratios, self.costs.failure_to_planned)))

    def weights(self, ratio: float) -> CostWeights:
        """Cost weights of a failure-to-planned ratio (the env's own at its ratio)."""
        if np.isclose(ratio, self.costs.failure_to_planned):
            return self.costs
        return CostWeights.with_ratio(ratio, self.costs.planned_replacement)

    def to_dict(self) -> dict[str, Any]:
        """The settings as JSON-ready values: the env's study fields first, the wear
        regime's flat last (``costs.json`` "config")."""
        study = {
            name: getattr(self, name)
            for name in self.__dataclass_fields__
            if name not in ("env", "ood_pair")
        }
        env = {name: getattr(self.env, name) for name in _ENV_FIELDS}
        return {**env, **study, **self.wear.env_kwargs()}
