"""The one cost arithmetic of the project: what a pad taken off costs, failures per 100 pads
by wear label, unused life and the long-run cost per 1000 events, from per-pad arrays.

Both ways of evaluating a policy use it: pad by pad on a study's pads
(:mod:`agents.study.outcomes`, weighted by the regime's share of each label) and episode by
episode on the env (:mod:`agents.study.episodes`, pooled over the pads the episodes took
off, ``label_weights=None``).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from brake_env.env.config import CostWeights
from brake_env.model.regime import LABELS

F64 = NDArray[np.float64]
OOD_LABELS = tuple(label for label in LABELS if label != "id")
# The groups failure rates are reported for: each label, and the OOD labels together.
RATE_GROUPS = (*LABELS, "ood")

LabelWeights = Mapping[str, float] | None  # a label's share of the fleet; None: as sampled


def pad_cost(failed: NDArray[np.bool_], costs: CostWeights) -> F64:
    """Cost of each pad taken off: a failure or a planned replacement [currency]."""
    return np.where(failed, costs.failure, costs.planned_replacement)


def label_mean(x: NDArray[Any], labels: NDArray[Any], weights: LabelWeights) -> F64:
    """Mean of ``x`` (..., pads) over a fleet: each label's mean weighted by its share, or
    (``weights=None``) the plain mean over the pads."""
    if weights is None:
        return np.asarray(x.mean(axis=-1), dtype=np.float64)
    total: Any = sum(w * x[..., labels == k].mean(axis=-1) for k, w in weights.items())
    return np.asarray(total, dtype=np.float64)


def cost_per_1000(
    cost: F64, events: NDArray[Any], labels: NDArray[Any], weights: LabelWeights
) -> F64:
    """Long-run cost per 1000 braking events (renewal reward: mean cost of a pad over its
    mean events)."""
    return 1000.0 * label_mean(cost, labels, weights) / label_mean(events * 1.0, labels, weights)


def failure_rates(
    failed: NDArray[np.bool_], labels: NDArray[Any], weights: LabelWeights
) -> dict[str, float]:
    """Failures per 100 pads taken off: ``all`` over the fleet, each label, and ``ood``
    (the OOD labels weighted by their shares, or pooled); NaN where there is no such pad."""
    none = failed.size == 0
    res = {
        "all": float("nan") if none else 100.0 * float(label_mean(failed * 1.0, labels, weights))
    }
    for label in LABELS:
        m = labels == label
        res[label] = 100.0 * float(failed[m].mean()) if m.any() else float("nan")
    if weights is None:
        m = np.isin(labels, OOD_LABELS)
        res["ood"] = 100.0 * float(failed[m].mean()) if m.any() else float("nan")
        return res
    ood = {k: w for k, w in weights.items() if k != "id"}
    total = sum(ood.values())
    res["ood"] = sum(w * res[k] for k, w in ood.items()) / total if total else float("nan")
    return res


def unused_life(
    life_left: NDArray[Any], life: NDArray[Any], labels: NDArray[Any], weights: LabelWeights
) -> float:
    """Mean share of its life a pad still had when taken off (0 for a failure) [-]."""
    return float(label_mean(life_left / life, labels, weights))
