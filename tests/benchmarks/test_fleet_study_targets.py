"""benchmarks/analysis/fleet_study_targets.py: each target rule on made-up fleet
``costs.json`` contents where it passes and where it fails."""

from __future__ import annotations

from typing import Any

from tests.benchmarks import load_script

ft = load_script("fleet_study_targets")


def iv(point: float, low: float, high: float) -> dict[str, float]:
    return {"point": point, "low": low, "high": high}


def summary(ratio: dict[str, float], diff: dict[str, float], seeds: int = 10,
            train_s: float = 600.0, twin_minus: float = -1.0) -> dict[str, Any]:  # fmt: skip
    return {
        "agents": {"twin": {"ratio_to_heuristic": ratio, "minus_heuristic": diff,
                            "seeds": seeds, "train_seconds": [train_s] * seeds,
                            "heuristic": "(n, N)"}},
        "rows": [{"predictor": "twin", "policy": "(n, N)",
                  "ratio_to_reference": iv(1.1, 1.05, 1.15), "gap_to_reference": iv(2, 1, 3)}],
        "ranking": {"head": "twin", "head_minus": {
            "window": {"difference": iv(twin_minus, twin_minus - 1, twin_minus + 0.5),
                       "ratio": iv(0.95, 0.9, 1.0)}}},
    }  # fmt: skip


def verdicts(s: dict[str, Any]) -> list[str]:
    return [r[-1] for r in ft.rows(s)[1:]]


def test_the_rl_target_needs_ten_percent_an_interval_below_zero_ten_seeds_and_time():
    good = summary(iv(0.85, 0.8, 0.9), iv(-3, -4, -2))
    assert verdicts(good) == ["met", "reported", "met"]
    assert verdicts(summary(iv(0.95, 0.9, 1.0), iv(-1, -2, -0.5)))[0] == "MISSED"  # 5% only
    assert verdicts(summary(iv(0.85, 0.7, 1.1), iv(-3, -6, 0.5)))[0] == "MISSED"  # spans 0
    assert verdicts(summary(iv(0.85, 0.8, 0.9), iv(-3, -4, -2), seeds=5))[0] == "MISSED"
    assert verdicts(summary(iv(0.85, 0.8, 0.9), iv(-3, -4, -2), train_s=901))[0] == "MISSED"


def test_the_twin_must_beat_each_predictor_with_an_interval_below_zero():
    assert verdicts(summary(iv(0.85, 0.8, 0.9), iv(-3, -4, -2), twin_minus=0.2))[-1] == "MISSED"


def test_the_shared_agent_is_reported_not_judged():
    s = summary(iv(0.85, 0.8, 0.9), iv(-3, -4, -2))
    s["agents"]["twin, shared"] = {
        "kind": "shared", "predictor": "twin", "heuristic": "(n, N)", "seeds": 10,
        "ratio_to_heuristic": iv(3.9, 3.0, 5.0), "minus_heuristic": iv(64, 44, 88),
        "ratio_to_reference": iv(4.0, 3.0, 5.2),
    }  # fmt: skip
    got = ft.rows(s)[1:]
    assert [r[-1] for r in got] == ["met", "reported", "reported", "reported", "met"]
    assert got[1][0] == "shared PPO (twin's RUL) against the tuned (n, N)"
    assert got[3][0] == "gap to the reference: twin / shared PPO (IQM)"


def test_against_the_oracle_the_twin_is_reported_and_the_oracle_must_not_lose():
    s = summary(iv(0.85, 0.8, 0.9), iv(-3, -4, -2))
    s["ranking"]["head_minus"]["oracle"] = {"difference": iv(-0.5, -0.9, -0.1),
                                            "ratio": iv(0.9, 0.8, 0.98)}  # fmt: skip
    s["best_heuristic"] = {"twin": "(n, N)", "oracle": "(n, N)"}
    twin = [3.0, 3.2, 2.9, 3.1]
    s["rows"][0]["episodes"] = {"cost": twin}
    s["rows"].append({"predictor": "oracle", "policy": "(n, N)",
                      "episodes": {"cost": [c + 0.5 for c in twin]}})  # fmt: skip
    got = ft.rows(s)[1:]
    assert got[3][0] == "twin's best policy against oracle's best" and got[3][-1] == "reported"
    assert got[-1][0].startswith("the oracle's best heuristic no worse than twin's")
    assert got[-1][-1] == "MISSED"  # the twin's is cheaper on every episode
    s["rows"][-1]["episodes"]["cost"] = [c - 0.5 for c in twin]
    assert ft.rows(s)[-1][-1] == "met"
    # a study ranked on the net cost is judged on the net cost
    s["ranking"]["objective"] = "net"
    s["rows"][0]["episodes"]["net"] = [c - 1 for c in twin]
    s["rows"][-1]["episodes"]["net"] = [c - 0.5 for c in twin]
    got = ft.rows(s)[-1]
    assert got[0].endswith("(twin minus it, net)") and got[-1] == "MISSED"


def test_the_bracket_takes_the_row_of_least_net_cost():
    """The bound is on the net cost: the best policy is the one of least net cost, even
    where another row's headline cost is lower."""
    s = {"rows": [
        {"predictor": "oracle", "policy": "a", "cost": 3.0, "net_cost": 2.5,
         "ratio_to_bound": iv(1.6, 1.5, 1.7), "gap_to_bound": iv(1, 0.9, 1.1)},
        {"predictor": "oracle", "policy": "b", "cost": 3.2, "net_cost": 2.1,
         "ratio_to_bound": iv(1.03, 1.01, 1.06), "gap_to_bound": iv(0.1, 0.0, 0.2)},
    ], "bound": {"cost": 2.0}, "best_heuristic": {"oracle": "a"}}  # fmt: skip
    bracket = ft.planner_rows(s)[0]
    assert "oracle / b" in bracket[0] and bracket[-1] == "met"
    s["rows"][1]["ratio_to_bound"] = iv(1.3, 1.2, 1.4)
    assert ft.planner_rows(s)[0][-1] == "MISSED"
