"""The one cost arithmetic (agents.study.costs): exact values on small fleets, in the
weighted (pad study) and the pooled (episodes) reading."""

from __future__ import annotations

import numpy as np
import pytest

from agents.study import costs
from brake_env.env.config import CostWeights

LABELS = np.array(["id", "id", "ood-slow", "ood-fast", "ood-fast"])
FAILED = np.array([True, False, False, True, False])


def test_a_pad_costs_a_failure_or_a_planned_replacement() -> None:
    w = CostWeights()
    np.testing.assert_array_equal(costs.pad_cost(FAILED, w), [10_000, 1000, 1000, 10_000, 1000])


def test_failure_rates_pooled_and_weighted() -> None:
    pooled = costs.failure_rates(FAILED, LABELS, None)
    assert pooled == {"all": 40.0, "id": 50.0, "ood-slow": 0.0, "ood-fast": 50.0,
                      "ood": pytest.approx(100 / 3)}  # fmt: skip
    weights = {"id": 0.5, "ood-slow": 0.25, "ood-fast": 0.25}
    mixed = costs.failure_rates(FAILED, LABELS, weights)
    # each label's rate weighted by its share, not by how many pads were drawn
    assert mixed["all"] == pytest.approx(0.5 * 50 + 0.25 * 0 + 0.25 * 50)
    assert mixed["ood"] == pytest.approx(25.0)
    assert np.isnan(costs.failure_rates(FAILED[:2], LABELS[:2], None)["ood"])  # no OOD pad
    assert np.isnan(costs.failure_rates(FAILED[:0], LABELS[:0], None)["all"])


def test_cost_per_1000_is_a_ratio_of_means_not_a_mean_of_ratios() -> None:
    cost = np.array([1000.0, 10_000.0])
    events = np.array([1000, 9000])
    labels = np.array(["id", "id"])
    got = float(costs.cost_per_1000(cost, events, labels, None))
    assert got == pytest.approx(1000 * 11_000 / 10_000)
    assert got != pytest.approx(1000 * np.mean(cost / events))


def test_unused_life_is_zero_for_failures_and_the_share_left_otherwise() -> None:
    left = np.array([0, 500, 250])
    life = np.array([1000, 1000, 1000])
    labels = np.array(["id", "id", "ood-fast"])
    assert costs.unused_life(left, life, labels, None) == pytest.approx(0.25)
    assert costs.unused_life(left, life, labels, {"id": 0.5, "ood-fast": 0.5}) == pytest.approx(
        0.5 * 0.25 + 0.5 * 0.25
    )
