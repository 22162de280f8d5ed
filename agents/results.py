"""What the cost comparison returns (:class:`CompareResult`) and writes as ``costs.json``.

Policies are keyed by :class:`~agents.policies.PolicyId`; their labels become the keys of
the JSON, whose layout is described in the README ("Maintenance cost by predictor").
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, Any

from agents.evaluation import CostReport, ratio_per_seed, t_interval
from agents.policies import PolicyId
from brake_env.env.config import CostWeights

if TYPE_CHECKING:
    from agents.compare import CompareConfig


@dataclass(frozen=True)
class PolicyCost:
    """A policy's cost under one failure-to-planned cost ratio (a row of the sensitivity).

    Attributes:
        cost_per_1000_events: Cost per 1000 braking events under the ratio's weights.
        ratio_to_oracle: That cost over the oracle's on the same episodes [-].
        ratio_to_oracle_ci95: Student-t 95% interval of the per-episode ratio [-].
        failures_per_100_pads: Failures per 100 pads taken off.
        parameter: The tuned threshold or replacement age [events]; None for policies
            without one.
    """

    cost_per_1000_events: float
    ratio_to_oracle: float
    ratio_to_oracle_ci95: tuple[float, float]
    failures_per_100_pads: float
    parameter: float | None

    @classmethod
    def of(
        cls, report: CostReport, weights: CostWeights, oracle: CostReport, parameter: float | None
    ) -> PolicyCost:
        """``report``'s decisions priced with ``weights``, against the oracle's."""
        cost = report.cost_with(weights)
        per_seed = ratio_per_seed(
            report.episode_costs_with(weights), oracle.episode_costs_with(weights)
        )
        return cls(
            cost_per_1000_events=cost,
            ratio_to_oracle=cost / oracle.cost_with(weights),
            ratio_to_oracle_ci95=t_interval(per_seed.tolist()),
            failures_per_100_pads=report.failures_per_100_pads,
            parameter=parameter,
        )


@dataclass(frozen=True)
class RatioResult:
    """The comparison under one failure-to-planned cost ratio, each policy family tuned for
    it (agents as trained).

    Attributes:
        failure_to_planned: Cost of a failure in planned replacements [-].
        oracle_cost_per_1000_events: The oracle's cost under these weights.
        policies: Each policy family's row.
        predictor_ranking: Predictors from the cheapest best policy to the dearest.
    """

    failure_to_planned: float
    oracle_cost_per_1000_events: float
    policies: dict[PolicyId, PolicyCost]
    predictor_ranking: tuple[str, ...]

    def to_dict(self) -> dict[str, Any]:
        return {
            "failure_to_planned": self.failure_to_planned,
            "oracle_cost_per_1000_events": self.oracle_cost_per_1000_events,
            "policies": {p.label: asdict(row) for p, row in self.policies.items()},
            "predictor_ranking": list(self.predictor_ranking),
        }


@dataclass(frozen=True)
class Timing:
    """Wall time of each stage of the comparison [s].

    Attributes:
        fit_s: Fitting each predictor (those fitted here).
        tune_s: Running the tuning candidates.
        train_s: Training each agent.
        evaluate_s: Running every policy on the held-out episodes.
        total_s: The whole comparison.
    """

    fit_s: dict[str, float]
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
        tune_seeds: Episodes the thresholds and the fixed interval were tuned on.
        eval_seeds: Held-out episodes every policy was evaluated on.
        policies: The headline: each policy family (tuned for the env's weights), each
            agent, replace-on-failure and the oracle, on the held-out episodes, with their
            ratios to the oracle. Each report's ``name`` is its policy's label.
        parameters: The tuned parameter of each headline policy family.
        sensitivity: The comparison under each failure-to-planned ratio.
        tuning: Each tuning candidate's report on the tuning episodes.
        timing: Wall time of each stage.
    """

    seed: int
    config: CompareConfig
    failure_to_planned: float
    tune_seeds: tuple[int, ...]
    eval_seeds: tuple[int, ...]
    policies: dict[PolicyId, CostReport]
    parameters: dict[PolicyId, float]
    sensitivity: dict[float, RatioResult]
    tuning: dict[PolicyId, CostReport]
    timing: Timing

    def to_dict(self) -> dict[str, Any]:
        """The content of ``costs.json`` (NaN left in; the writer turns it into null)."""
        return {
            "seed": self.seed,
            "config": self.config.to_dict(),
            "failure_to_planned": self.failure_to_planned,
            "tune_seeds": list(self.tune_seeds),
            "eval_seeds": list(self.eval_seeds),
            "tuned_parameters": {p.label: v for p, v in self.parameters.items()},
            "policies": {
                p.label: {**r.to_dict(), "parameter": self.parameters.get(p)}
                for p, r in self.policies.items()
            },
            "sensitivity": {f"{r:g}": s.to_dict() for r, s in self.sensitivity.items()},
            "tuning": {p.label: r.cost_per_1000_events for p, r in self.tuning.items()},
            "timing_s": asdict(self.timing),
        }
