"""What the cost comparison returns (:class:`CompareResult`) and writes as ``costs.json``.

Policies are keyed by :class:`~agents.policies.rules.PolicyId`; their labels become the keys of
the JSON, whose layout is described in docs/results/single-pad.md.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents.policies.rules import PolicyId
from agents.study.config import StudyConfig

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class Estimate:
    """A figure and its confidence interval (``low == high == point`` where it has none)."""

    point: float
    low: float
    high: float

    @classmethod
    def exact(cls, value: float) -> Estimate:
        return cls(value, value, value)

    def to_dict(self) -> dict[str, float]:
        return {"value": self.point, "low": self.low, "high": self.high}

    @property
    def half_width(self) -> float:
        """The larger distance from the point to a bound."""
        return max(self.point - self.low, self.high - self.point)


@dataclass(frozen=True)
class PolicyRow:
    """One policy on the held-out pads under one cost ratio.

    Attributes:
        parameter: Its tuned threshold or replacement age [events] (``0`` and ``inf`` are
            "never replace"); None for policies without one.
        cost_per_1000_events: Long-run cost per 1000 braking events of a fleet of the
            regime's mix, with its interval.
        ratio_to_oracle: That cost over the oracle's on the same pads, with its paired
            bootstrap interval [-].
        failures_per_100_pads: ``all`` (the regime's mix; no interval), ``id``,
            ``ood-slow``, ``ood-fast`` and ``ood`` (Clopper-Pearson intervals; NaN where
            the regime has no such pad).
        mean_unused_life_frac: Mean share of its life a pad still had when taken off [-].
        note: Why a figure reads as it does (a tuning that fell back to never replacing).
        life_left: Each held-out pad's true RUL when it was taken off (0: a failure) [events].
    """

    parameter: float | None
    cost_per_1000_events: Estimate
    ratio_to_oracle: Estimate
    failures_per_100_pads: dict[str, Estimate]
    mean_unused_life_frac: float
    note: str = ""
    life_left: NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, np.int64), repr=False)

    def to_dict(self) -> dict[str, Any]:
        return {
            "parameter": self.parameter,
            "cost_per_1000_events": self.cost_per_1000_events.to_dict(),
            "ratio_to_oracle": self.ratio_to_oracle.to_dict(),
            "failures_per_100_pads": {
                k: v.to_dict() for k, v in self.failures_per_100_pads.items()
            },
            "mean_unused_life_frac": self.mean_unused_life_frac,
            "note": self.note,
        }


@dataclass(frozen=True)
class Gap:
    """The difference in cost ratio between two policies adjacent in the ranking.

    Attributes:
        cheaper, dearer: The two policies.
        difference: The dearer's ratio to the oracle minus the cheaper's, with its paired
            bootstrap interval [-].
        significant: The interval excludes 0.
    """

    cheaper: PolicyId
    dearer: PolicyId
    difference: Estimate

    @property
    def significant(self) -> bool:
        return self.difference.low > 0 or self.difference.high < 0

    def to_dict(self) -> dict[str, Any]:
        return {
            "cheaper": self.cheaper.label,
            "dearer": self.dearer.label,
            "difference": self.difference.to_dict(),
            "significant": self.significant,
        }


@dataclass(frozen=True)
class RatioResult:
    """The comparison under one failure-to-planned cost ratio, each tuned family tuned for
    it (agents as trained).

    Attributes:
        failure_to_planned: Cost of a failure in planned replacements [-].
        oracle_cost_per_1000_events: The oracle's cost under these weights.
        policies: Each policy's row, cheapest first (the ranking).
        gaps: Each pair of policies adjacent in the ranking.
        predictor_ranking: Predictors from the cheapest best policy to the dearest.
        ood_pair: The two predictors the OOD failure gap compares.
        ood_failure_gap: OOD failures per 100 pads of the first predictor's best policy
            minus the second's, with its paired bootstrap interval (None unless both ran).
    """

    failure_to_planned: float
    oracle_cost_per_1000_events: float
    policies: dict[PolicyId, PolicyRow]
    gaps: tuple[Gap, ...]
    predictor_ranking: tuple[str, ...]
    ood_pair: tuple[str, str] = ("twin", "physics")
    ood_failure_gap: Estimate | None = None

    def best(self, predictor: str) -> PolicyId | None:
        """The predictor's cheapest policy."""
        return next((p for p in self.policies if p.predictor == predictor), None)

    def to_dict(self) -> dict[str, Any]:
        return {
            "failure_to_planned": self.failure_to_planned,
            "oracle_cost_per_1000_events": self.oracle_cost_per_1000_events,
            "ranking": [p.label for p in self.policies],
            "policies": {p.label: row.to_dict() for p, row in self.policies.items()},
            "gaps": [g.to_dict() for g in self.gaps],
            "predictor_ranking": list(self.predictor_ranking),
            "ood_failure_gap_{}_minus_{}".format(*self.ood_pair): (
                None if self.ood_failure_gap is None else self.ood_failure_gap.to_dict()
            ),
        }


@dataclass(frozen=True)
class Tuning:
    """Every tuning candidate's cost on the tuning pads.

    Attributes:
        n_pads: Tuning pads.
        enough: There were enough to tune on (else no tuned family is reported).
        parameters: Each family's candidates [events], in candidate order.
        curves: Cost ratio -> family -> each candidate's cost per 1000 events.
        best: Cost ratio -> family -> the cheapest candidate.
    """

    n_pads: int
    enough: bool
    parameters: dict[PolicyId, F64]
    curves: dict[float, dict[PolicyId, F64]]
    best: dict[float, dict[PolicyId, float]]

    def to_dict(self) -> dict[str, Any]:
        return {
            "n_pads": self.n_pads,
            "enough": self.enough,
            "candidates": {p.label: v.tolist() for p, v in self.parameters.items()},
            "cost_per_1000_events": {
                f"{r:g}": {p.label: v.tolist() for p, v in c.items()}
                for r, c in self.curves.items()
            },
        }


@dataclass(frozen=True)
class AgentRuns:
    """The agents of a comparison.

    Attributes:
        outcomes: Each trained agent's outcomes on the held-out pads.
        skipped: Agents not trained, and why.
        seconds: Training time of each [s].
        curves: Each agent's learning curve (the points of
            :class:`agents.learning.curve.LearningCurve`).
    """

    outcomes: dict[PolicyId, Any] = field(default_factory=dict)
    skipped: dict[PolicyId, str] = field(default_factory=dict)
    seconds: dict[str, float] = field(default_factory=dict)
    curves: dict[str, list[dict[str, float]]] = field(default_factory=dict)


@dataclass(frozen=True)
class Timing:
    """Wall time of each stage of the comparison [s].

    Attributes:
        fit_s: Fitting each predictor (those fitted here).
        pads_s: Simulating the tuning and held-out pads and running the predictors.
        held_out_s: Of that, for the held-out pads: ``simulate`` and each predictor.
        tune_s: Evaluating the tuning candidates.
        train_s: Training each agent.
        evaluate_s: Evaluating the policies and their intervals.
        total_s: The whole comparison.
    """

    fit_s: dict[str, float]
    pads_s: float
    held_out_s: dict[str, float]
    tune_s: float
    train_s: dict[str, float]
    evaluate_s: float
    total_s: float


@dataclass(frozen=True)
class CompareResult:
    """Everything ``brakewear compare`` found.

    Attributes:
        seed: The comparison's seed.
        config: What was run.
        failure_to_planned: The env's cost ratio, the headline's.
        tune_pads, eval_pads: Tuning and held-out pads of each wear-regime label.
        sensitivity: The comparison under each failure-to-planned ratio; the headline is
            the env's ratio (:attr:`headline`).
        tuning: Each tuning candidate's cost on the tuning pads.
        skipped: Policies given no figure, and why (a budget too small to tune or train).
        timing: Wall time of each stage.
        learning_curves: Each agent's learning curve, by its predictor.
    """

    seed: int
    config: StudyConfig
    failure_to_planned: float
    tune_pads: dict[str, int]
    eval_pads: dict[str, int]
    sensitivity: dict[float, RatioResult]
    tuning: Tuning
    skipped: dict[PolicyId, str]
    timing: Timing
    learning_curves: dict[str, list[dict[str, float]]] = field(default_factory=dict)

    @property
    def headline(self) -> RatioResult:
        return self.sensitivity[self.failure_to_planned]

    def to_dict(self) -> dict[str, Any]:
        """The content of ``costs.json`` (NaN and inf left in; the writer makes them null)."""
        head = self.headline
        return {
            "seed": self.seed,
            "config": self.config.to_dict(),
            "failure_to_planned": self.failure_to_planned,
            "pads": {"tune": self.tune_pads, "evaluate": self.eval_pads},
            **head.to_dict(),
            "tuned_parameters": {
                p.label: _param(row.parameter) for p, row in head.policies.items() if p.tuned
            },
            "skipped": {p.label: why for p, why in self.skipped.items()},
            "sensitivity": {f"{r:g}": s.to_dict() for r, s in self.sensitivity.items()},
            "tuning": self.tuning.to_dict(),
            "timing_s": asdict(self.timing),
            "learning_curves": self.learning_curves,
        }


def _param(value: float | None) -> float | str | None:
    return "never" if value is not None and (value == 0 or math.isinf(value)) else value
