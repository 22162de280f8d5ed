"""Where a policy takes each pad of a :class:`~agents.study.pads.PadSet` off, and the cost per
braking event that leads to (docs/results/single-pad.md).

A stateless policy (a rule, or a trained agent acting deterministically) decides at each
decision point from what it sees there, so a pad is taken off at its first decision to
replace (a planned replacement: it braked its age at that point) or, if none comes in time,
fails after its whole life (a failure). The next pad is installed at a decision point: a
renewal. The long-run cost per event of a fleet is then the expected cost of a pad over the
expected events of a pad (renewal-reward theorem), each expectation over the regime's mix
of labels; on a sample of pads, a ratio of weighted means (a ratio estimator).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents.study import costs as costs_
from agents.study.pads import PadSet
from brake_env.env.config import CostWeights

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]
_RUL_HIGH = 1e7  # RULObservation's clip of an estimate [events]


@dataclass(frozen=True)
class Outcomes:
    """Each pad's fate under one policy (or, with leading axes, under several).

    Attributes:
        events: Events the pad braked before it was taken off [events].
        failed: It failed (else a planned replacement took it off).
    """

    events: I64
    failed: NDArray[np.bool_]

    def __getitem__(self, i: Any) -> Outcomes:
        return Outcomes(self.events[i], self.failed[i])

    def cost(self, costs: CostWeights) -> F64:
        """Cost of each pad: a planned replacement or a failure [currency]."""
        return costs_.pad_cost(self.failed, costs)


def at_decision(pads: PadSet, k: I64) -> Outcomes:
    """Outcomes of replacing each pad at its decision ``k`` (0-based; its number of decision
    points or more: never, so it fails)."""
    planned = k < pads.n_decisions
    events = np.where(planned, pads.first + k * pads.decision_interval, pads.life)
    return Outcomes(events.astype(np.int64), ~planned)


def first_true(replace: NDArray[np.bool_], pads: PadSet) -> I64:
    """Index within its pad of each pad's first True row; its number of rows if none."""
    n = pads.n_decisions
    k = n.copy()
    live = np.flatnonzero(n > 0)
    if live.size:
        pos = np.where(replace, np.arange(replace.size) - np.repeat(pads.starts[:-1], n), n.max())
        k[live] = np.minimum(np.minimum.reduceat(pos, pads.starts[live]), n[live])
    return k


def observed(values: F64) -> F64:
    """An estimate as a policy sees it in the env: clipped to [0, 1e7] and rounded to
    float32 (``RULObservation``), so thresholds compare exactly as there."""
    return np.clip(values, 0.0, _RUL_HIGH).astype(np.float32).astype(np.float64)


def threshold_outcomes(pads: PadSet, values: F64, thresholds: F64) -> Outcomes:
    """Outcomes of ``RULThreshold(h)`` on ``values`` (an estimate at each row) for every h:
    shape (thresholds, pads). A pad is replaced at its first row whose value is below h,
    i.e. where its running minimum first drops below h."""
    x = observed(values)
    running = np.empty_like(x)
    for a, b in zip(pads.starts[:-1], pads.starts[1:], strict=True):
        np.minimum.accumulate(x[a:b], out=running[a:b])
    n = pads.n_decisions
    live = np.flatnonzero(n > 0)
    ks = np.empty((len(thresholds), len(pads)), dtype=np.int64)
    for j, h in enumerate(np.asarray(thresholds, dtype=np.float64)):
        ks[j] = n  # a pad with no decision point cannot be replaced
        if live.size:  # rows before the first crossing: the running minimum is still >= h
            ks[j, live] = np.add.reduceat((running >= h).astype(np.int64), pads.starts[live])
    return _stack([at_decision(pads, k) for k in ks])


def fixed_interval_outcomes(pads: PadSet, ages: F64) -> Outcomes:
    """Outcomes of ``FixedInterval(a)`` for every age a (``inf``: never), shape (ages, pads):
    replaced at the first decision point at which the pad's age is at least a."""
    out = []
    for a in np.asarray(ages, dtype=np.float64):
        if np.isinf(a):
            k = pads.n_decisions.copy()
        else:
            k = np.maximum(np.ceil((a - pads.first) / pads.decision_interval), 0)
        out.append(at_decision(pads, k.astype(np.int64)))
    return _stack(out)


def never(pads: PadSet) -> Outcomes:
    """Replace-on-failure: every pad brakes its whole life and fails."""
    return Outcomes(pads.life.copy(), np.ones(len(pads), dtype=bool))


def oracle(pads: PadSet) -> Outcomes:
    """The true RUL and a threshold of one decision interval: each pad replaced at its last
    decision point, the last one from which it could not finish the next step."""
    truth = pads.estimates["oracle"]["rul_mean"]
    return threshold_outcomes(pads, truth, np.array([pads.decision_interval]))[0]


def _stack(parts: list[Outcomes]) -> Outcomes:
    return Outcomes(np.stack([p.events for p in parts]), np.stack([p.failed for p in parts]))


# ---------------------------------------------------------------------- fleet figures
# The regime's mix: each label's pads stand for its share of a fleet (stratified sampling).
def cost_per_1000(pads: PadSet, out: Outcomes, costs: CostWeights) -> F64:
    """Long-run cost per 1000 braking events of a fleet of the regime's mix."""
    d = pads.draws
    return costs_.cost_per_1000(out.cost(costs), out.events, d.label, d.weights)


def failures_per_100(pads: PadSet, out: Outcomes) -> dict[str, float]:
    """Failures per 100 pads taken off, over the regime's mix (``all``), per label and over
    its OOD labels (``ood``); NaN where the regime has no such pad."""
    return costs_.failure_rates(out.failed, pads.draws.label, pads.draws.weights)


def unused_life(pads: PadSet, out: Outcomes) -> float:
    """Mean share of its life a pad still had when taken off (0 for a failure) [-]."""
    d = pads.draws
    return costs_.unused_life(pads.life - out.events, pads.life, d.label, d.weights)
