"""``brakewear fleet-distil`` on a hostile study ``costs.json`` (issue 44, item 4): each case
refused with one error naming the file and what is wrong, before anything is written to
``--out`` (the output mark aside); the report prints no ratio to a non-positive figure."""

from __future__ import annotations

import copy
import json
import re
from dataclasses import asdict
from pathlib import Path

import pytest

from agents.fleet.commands.distil import read_study
from agents.fleet.settings import FleetStudyConfig
from agents.fleet.study.distil_summary import distil_report
from brake_env.cli.main import main
from brake_env.output import OUTPUT_MARK

STUDY = FleetStudyConfig(
    shifts=24, predictors=("oracle",), heuristics=("threshold",), trials=2, tune_episodes=1,
    eval_episodes=3, n_train_runs=2, rollout_predictors=("oracle",), rollout_horizon=3,
    rollout_samples=2, rollout_chunk=3, bound_iterations=2,
)  # fmt: skip
ARGS = ["--predictor", "oracle", "--seeds", "1", "--label-episodes", "1", "--label-rounds", "0",
        "--imitation-epochs", "1", "--workers", "0", "--quiet"]  # fmt: skip


def episodes(cost: float) -> dict:
    return {"seed": [0, 1, 2], "cost": [cost] * 3, "net": [cost - 0.5] * 3}


def good() -> dict:
    config = asdict(STUDY)
    del config["effects"]
    rows = [
        {"predictor": "oracle", "policy": "threshold", "params": {"threshold": 3.0},
         "episodes": episodes(2.0)},
        {"predictor": "oracle", "policy": "rollout on threshold", "params": None,
         "episodes": episodes(1.8)},
    ]  # fmt: skip
    return {"config": config, "rows": rows, "best_heuristic": {"oracle": "threshold"},
            "bound": {"episodes": [1.0, 1.1, 1.2]}}  # fmt: skip


def edited(how) -> dict:
    s = copy.deepcopy(good())
    how(s)
    return s


HOSTILE = {
    "config without objective": (lambda s: s["config"].pop("objective"), r"config.*objective"),
    "config without seed": (lambda s: s["config"].pop("seed"), r"config.*seed"),
    "an unknown config key": (lambda s: s["config"].update(colour=1), r"config.*colour"),
    "a list for config": (lambda s: s.update(config=[1, 2]), r"config.*list"),
    "a string for a config number": (lambda s: s["config"].update(shifts="x"), r"config.*shifts"),
    "NaN for a config number": (lambda s: s["config"].update(trials=float("nan")), r"config"),
    "no row of the best heuristic": (lambda s: s["rows"].pop(0), r"threshold.*has no row of it"),
    "NaN parameter": (lambda s: s["rows"][0]["params"].update(threshold=float("nan")),
                      r"parameters of .*threshold.*nan"),
    "string parameter": (lambda s: s["rows"][0]["params"].update(threshold="x"),
                         r"parameters of .*threshold.*'x'"),
    "an unknown parameter": (lambda s: s["rows"][0].update(params={"other": 1.0}),
                             r"parameters of .*threshold"),
    "a list for rows": (lambda s: s.update(rows={"a": 1}), r"rows"),
    "a row without episodes": (lambda s: s["rows"][0].pop("episodes"),
                               r"row .*threshold.*episodes"),
    "NaN episode costs": (lambda s: s["rows"][1]["episodes"]["cost"].__setitem__(1, float("nan")),
                          r"row .*rollout on threshold.*cost"),
    "too few episode costs": (lambda s: s["rows"][0]["episodes"].update(cost=[1.0]),
                              r"row .*threshold.*cost"),
    "a string bound": (lambda s: s.update(bound="x"), r"bound"),
    "NaN bound episodes": (lambda s: s["bound"].update(episodes=[1.0, float("nan"), 1.0]),
                           r"bound"),
    "a number for best_heuristic": (lambda s: s.update(best_heuristic=3), r"best_heuristic"),
}  # fmt: skip


def write(tmp_path: Path, summary: dict) -> Path:
    d = tmp_path / "study"
    d.mkdir()
    (d / "costs.json").write_text(json.dumps(summary))
    return d


def test_the_good_study_reads(tmp_path):
    config, summary = read_study(str(write(tmp_path, good())))
    assert config == STUDY and summary["best_heuristic"] == {"oracle": "threshold"}


@pytest.mark.parametrize("case", sorted(HOSTILE))
def test_a_hostile_costs_json_is_refused_before_anything_is_written(tmp_path, capsys, case):
    how, names = HOSTILE[case]
    study = write(tmp_path, edited(how))
    out = tmp_path / "out"
    assert main(["fleet-distil", "--study", str(study), "--out", str(out), *ARGS]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "costs.json" in err[0], err
    assert re.search(names, err[0]), err[0]
    left = sorted(p.name for p in out.iterdir()) if out.exists() else []
    assert left in ([], [OUTPUT_MARK])


def summary_with(base: float, planner: float, bound: float, net: float) -> dict:
    iv = {"point": 1.0, "low": 0.9, "high": 1.1}
    ratio = {"point": 7.0, "low": 6.0, "high": 8.0}
    seed = {"seed": 0, "figure": net, "cost": net + 0.5, "net": net, "failures": 0.0,
            "agreement": 0.9, "train_seconds": 1.0, "evaluate_seconds": 1.0}  # fmt: skip
    compared = {
        "base": {"cost": base, "difference": iv, "ratio": ratio, "iqm": iv},
        "planner": {"cost": planner, "difference": iv, "ratio": ratio},
        "bound": {"cost": bound, "ratio": ratio},
    }
    return {
        "base": "threshold", "predictor": "oracle", "objective": "net",
        "labels": {"rounds": [], "seconds": 1.0, "repaired": 0, "shifts": 10},
        "central": {"seeds": [seed], "compared": compared,
                    "speed": {"planner_seconds_per_decision": 0.1,
                              "agent_seconds_per_decision": 0.001, "times_faster": 100.0}},
    }  # fmt: skip


def test_the_report_prints_no_ratio_to_a_non_positive_figure():
    text = distil_report(summary_with(-0.4, -0.5, -0.7, -0.3))
    assert "7.000 [6.000, 8.000]" not in text  # no ratio printed
    assert "no ratio where a cost is not positive" in text
    assert text.count("1.000 [0.900, 1.100]") >= 3  # the differences are
    positive = distil_report(summary_with(2.0, 1.8, 1.0, 1.9))
    assert positive.count("7.000 [6.000, 8.000]") == 3 and "no ratio" not in positive
    # a negative bound alone: its ratio not printed, the others are
    one = distil_report(summary_with(2.0, 1.8, -0.7, 1.9))
    assert one.count("7.000 [6.000, 8.000]") == 2 and "no ratio" in one
