"""Withheld-effect validation: the cases, the confusion matrix and targets, a tiny run."""

from __future__ import annotations

from typing import Any

from brake_env.model.atlas import Atlas
from sim2real.commands.units import validate_gap
from sim2real.diagnosis.attribute import NONE
from sim2real.diagnosis.config import DiagnosisConfig
from sim2real.effects.library import LIBRARY
from sim2real.validation.validate import ValidationSpec, cases, run_case, summarise

TINY = DiagnosisConfig(
    fit_events_per_run=400,
    calibration_events_per_run=400,
    score_events_per_run=2000,
    grid_points=2,
)
OOL = "pad_glazing:g=0.15 (not a candidate)"


def test_cases_cover_the_library_the_controls_and_the_out_of_library_effect() -> None:
    spec = ValidationSpec(seeds_mid=2, low_magnitude=True, n_controls=3, n_out_of_library=1)
    cs = cases(spec, seed=5)
    assert len(cs) == 3 * len(LIBRARY) + 3 + 1
    assert len({c.seed for c in cs}) == len(cs)
    assert all(5000 <= c.seed < 6000 for c in cs)
    assert {c.expected for c in cs} == {cls.name for cls in LIBRARY} | {NONE}
    for cls in LIBRARY:
        p = cls.params[0]
        mine = [c for c in cs if c.expected == cls.name]
        assert [c.label for c in mine].count(f"{cls.name}:{p.name}={p.mid:g}") == 2
        assert all(len(c.effects) == 1 and type(c.effects[0]) is cls for c in mine)
    controls = [c for c in cs if c.label == "control"]
    assert len(controls) == 3 and all(c.effects == [] and c.expected == NONE for c in controls)
    (ool,) = [c for c in cs if c.label == OOL]
    assert ool.expected == NONE and ool.effects[0].name == "pad_glazing"
    assert [(c.label, c.seed) for c in cases(spec, seed=5)] == [(c.label, c.seed) for c in cs]


def _rec(case: str, expected: str, answer: str, shrink: float | None, **kw: float) -> dict:
    return {
        "case": case,
        "expected": expected,
        "answer": answer,
        "correct": answer == expected,
        "shrink": shrink,
        **kw,
    }


def test_summarise_counts_each_case_in_its_row_and_scores_the_targets() -> None:
    records = [
        _rec("tc_bias:bias_k=10", "tc_bias", "tc_bias", 0.9, rul_before=500.0, rul_shrink=0.6),
        _rec("speed_friction:a=0.2", "speed_friction", NONE, None),
        _rec("speed_friction:a=0.1", "speed_friction", "speed_friction", 0.8),  # low: no target
        _rec("control", NONE, NONE, None, rul_before=100.0),
        _rec("control", NONE, "tc_bias", 0.5),
        _rec(OOL, NONE, NONE, None),
    ]
    out = summarise(records)
    assert out["labels"] == ["speed_friction", "tc_bias", NONE]
    assert out["rows"] == ["speed_friction", "tc_bias", "pad_glazing (not a candidate)", NONE]
    conf = out["confusion"]
    assert conf["speed_friction"] == {"speed_friction": 1, "tc_bias": 0, NONE: 1}
    assert conf["tc_bias"] == {"speed_friction": 0, "tc_bias": 1, NONE: 0}
    assert conf["pad_glazing (not a candidate)"] == {"speed_friction": 0, "tc_bias": 0, NONE: 1}
    assert conf[NONE] == {"speed_friction": 0, "tc_bias": 1, NONE: 1}
    t = out["targets"]
    assert (t["top1_mid_library"]["value"], t["top1_mid_library"]["n"]) == (0.5, 2)
    assert not t["top1_mid_library"]["met"]
    assert (t["none_on_controls"]["value"], t["none_on_controls"]["n"]) == (0.5, 2)
    assert t["abstain_out_of_library"]["value"] == 1.0 and t["abstain_out_of_library"]["met"]
    assert t["gap_shrink_median"]["value"] == t["gap_shrink_min"]["value"] == 0.9
    # RUL "affected" above 1.5x the controls' median error (150 events): the tc_bias case.
    rul = t["rul_rmse_shrink_median_affected"]
    assert rul["affected_above_events"] == 150.0 and rul["value"] == 0.6 and rul["met"]


def _without_times(rec: dict[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in rec.items() if not k.startswith("seconds")}


def test_tiny_validation_runs_each_case_and_is_deterministic(s2r_atlas: Atlas) -> None:
    spec = ValidationSpec(
        seeds_mid=1,
        n_controls=1,
        n_out_of_library=1,
        n_runs=4,
        k_mean=4e-5,
        with_rul=False,
        config=TINY,
    )
    r = validate_gap(s2r_atlas, spec, seed=0, case_filter=["tc_bias", "control", OOL])
    assert [c["case"] for c in r["cases"]] == ["tc_bias:bias_k=10", "control", OOL]
    assert r["rows"] == ["tc_bias", "pad_glazing (not a candidate)", NONE]
    conf = r["confusion"]
    assert sum(sum(row.values()) for row in conf.values()) == len(r["cases"])
    for row in r["rows"]:
        assert set(conf[row]) == set(r["labels"]) and sum(conf[row].values()) == 1
    for c in r["cases"]:
        assert c["answer"] in r["labels"] and c["correct"] == (c["answer"] == c["expected"])
        assert c["gap_before"] >= 0.0 and c["channel"] in ("temp", "stop")
    # The clear case is named, the control and the out-of-library effect get none.
    assert [c["answer"] for c in r["cases"]] == ["tc_bias", NONE, NONE]
    assert r["cases"][0]["shrink"] > 0.7
    control = next(c for c in cases(spec, seed=0) if c.label == "control")
    assert _without_times(run_case(s2r_atlas, spec, control)) == _without_times(r["cases"][1])
