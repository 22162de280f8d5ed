"""No ratio to a figure that is not positive (issue 44, item 4): a row's ratio to a negative
Lagrangian bound is not written, the report prints none where a cost is not positive (the
difference stays), and the targets' bracket says why it is not judged."""

from __future__ import annotations

import numpy as np

from agents.fleet.study.run import _planner_lines
from agents.fleet.study.summary import to_bound
from benchmarks.analysis import fleet_study_targets as ft


def rows(net: list[float]) -> list[dict]:
    return [{"predictor": "oracle", "policy": "a", "net_cost": float(np.mean(net)),
             "episodes": {"net": net}}]  # fmt: skip


def test_no_ratio_to_a_negative_bound_the_gap_still_there():
    r = rows([0.4, 0.5, 0.6])
    to_bound(r, np.array([-0.7, -0.6, -0.7]))
    assert "ratio_to_bound" not in r[0] and r[0]["gap_to_bound"]["point"] > 0
    r = rows([0.4, 0.5, 0.6])
    to_bound(r, np.array([0.3, 0.35, 0.4]))
    assert r[0]["ratio_to_bound"]["point"] > 1


def test_no_ratio_of_a_negative_net_cost():
    r = rows([-0.4, -0.5, -0.6])
    to_bound(r, np.array([-0.7, -0.6, -0.7]))
    assert "ratio_to_bound" not in r[0]


def test_the_report_prints_no_ratio_to_a_negative_base_cost():
    iv = {"point": 7.0, "low": 6.0, "high": 8.0}
    roll = {"base": "threshold", "cost": -0.2, "base_cost": -0.1, "minus_base": iv,
            "ratio_to_base": iv, "seconds_per_shift": 0.1, "seconds": 60.0}  # fmt: skip
    text = "\n".join(_planner_lines({"rollout": {"oracle": roll}}))
    assert "ratio n/a (a cost not positive" in text and text.count("7.000") == 1
    roll = {**roll, "cost": 0.2, "base_cost": 0.3}
    assert "\n".join(_planner_lines({"rollout": {"oracle": roll}})).count("7.000") == 2


def test_the_bracket_is_not_judged_without_a_ratio():
    r = rows([0.4, 0.5, 0.6])
    to_bound(r, np.array([-0.7, -0.6, -0.7]))
    s = {"rows": r, "bound": {"cost": -0.67}, "best_heuristic": {"oracle": "a"}}
    got = ft.planner_rows(s)
    assert got[0][1] == ft.NO_RATIO and got[0][2] == "not judged"
    assert ft.NO_RATIO in got[1][1]
