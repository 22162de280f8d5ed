"""benchmarks/analysis/single_pad_targets.py: each target rule on made-up ``costs.json``
contents where it passes and where it fails, and the script's printout."""

from __future__ import annotations

import json

import pytest

from tests.benchmarks import load_script

ct = load_script("single_pad_targets")


def est(value: float, low: float, high: float) -> dict[str, float]:
    return {"value": value, "low": low, "high": high}


def row(ratio: dict[str, float], ood: dict[str, float] | None = None) -> dict:
    return {"ratio_to_oracle": ratio, "failures_per_100_pads": {"ood": ood or est(0, 0, 1)}}


def costs(**ratios: dict[str, float]) -> dict:
    """A costs.json whose ranking follows the ratios given (labels with '_' for '/')."""
    policies = {k.replace("_", "/").replace("fixed/interval", "fixed-interval"): row(r)
                for k, r in ratios.items()}  # fmt: skip
    ranking = sorted(policies, key=lambda p: policies[p]["ratio_to_oracle"]["value"])
    return {"ranking": ranking, "policies": policies}


GOOD = costs(
    oracle=est(1, 1, 1),
    twin_threshold=est(1.02, 1.01, 1.04),
    twin_ppo=est(1.03, 1.02, 1.05),
    physics_threshold=est(1.6, 1.58, 1.62),
    fixed_interval=est(2.5, 2.48, 2.53),
)
GOOD["ood_failure_gap_twin_minus_physics"] = est(-2.0, -2.5, -1.5)


@pytest.mark.parametrize("rule", ct.RULES)
def test_each_target_passes_on_a_good_study(rule) -> None:
    assert rule(GOOD).met is True


@pytest.mark.parametrize(
    ("rule", "change"),
    [
        (ct.twin_best, {"twin/threshold": est(1.06, 1.05, 1.07), "twin/ppo": est(1.08, 1, 1.2)}),
        (ct.twin_best, {"twin/threshold": est(1.04, 1.0, 1.11), "twin/ppo": est(1.08, 1, 1.2)}),
        (ct.fixed_interval, {"fixed-interval": est(1.2, 1.19, 1.21)}),
        (ct.ppo_twin, {"twin/ppo": est(1.08, 1.07, 1.09)}),
        (ct.half_widths, {"physics/threshold": est(1.6, 1.5, 1.7)}),
    ],
)
def test_each_target_fails_where_its_figure_misses(rule, change) -> None:
    bad = json.loads(json.dumps(GOOD))
    for label, ratio in change.items():
        bad["policies"][label]["ratio_to_oracle"] = ratio
    bad["ranking"] = sorted(
        bad["policies"], key=lambda p: bad["policies"][p]["ratio_to_oracle"]["value"]
    )
    assert rule(bad).met is False


def test_the_ood_target_needs_an_interval_below_zero() -> None:
    bad = {**GOOD, "ood_failure_gap_twin_minus_physics": est(-1.0, -2.0, 0.5)}
    assert ct.ood_failures(bad).met is False
    assert ct.ood_failures({**GOOD, "ood_failure_gap_twin_minus_physics": None}).met is None


def test_targets_not_measured_say_so_and_the_script_prints_each(tmp_path, capsys) -> None:
    only_oracle = costs(oracle=est(1, 1, 1))
    assert [t.met for t in ct.check(only_oracle)][:4] == [None, None, None, None]
    path = tmp_path / "costs.json"
    path.write_text(json.dumps(GOOD))
    assert ct.main([str(path)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == len(ct.RULES) and all(line.startswith("[met]") for line in lines)
