"""benchmarks/analysis/fleet_bound_gap.py on a made-up study: the best row, the gap and its
parts."""

from __future__ import annotations

import pytest

from tests.benchmarks import load_script


def _row(policy: str, net: list[float], spares: float) -> dict:
    cost = [n + 1.0 for n in net]  # the life left is worth 1 a vehicle-shift
    model = [c - spares for c in cost]
    episodes = {"seed": [0, 1, 2], "net": net, "cost": cost, "model_terms": model}
    return {"predictor": "twin", "policy": policy, "episodes": episodes}


def test_the_gap_of_the_best_row_splits_into_spares_and_the_rest() -> None:
    fb = load_script("fleet_bound_gap")
    study = {"rows": [_row("rule", [3.0, 3.0, 3.0], 0.2), _row("planner", [2.0, 2.5, 1.5], 0.1)],
             "bound": {"episodes": [1.5, 1.5, 1.5]}}  # fmt: skip
    got = {r[0].strip(): r[1] for r in fb.split(study)}
    assert got["best policy: twin/planner"] == "2.000"
    assert got["gap: policy minus bound"].startswith("0.500 [")
    assert got["of it, the policy's spares' order and holding"] == "0.100 [0.100, 0.100]"
    assert got["the rest"].startswith("0.400 [")
    assert got["ratio policy / bound"] == "1.333"
    with pytest.raises(SystemExit, match="no bound"):
        fb.split({"rows": study["rows"]})
    with pytest.raises(SystemExit, match="2 bound episodes, 3 of the policy"):
        fb.split({**study, "bound": {"episodes": [1.0, 1.0]}})
