"""The winner's parameter refined, with a bootstrap interval over calibration runs."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from brake_env.model.atlas import Atlas
from sim2real.diagnosis.attribute import parameter_grid
from sim2real.diagnosis.config import DiagnosisConfig
from sim2real.diagnosis.diagnose import DiagnosisResult, diagnose
from sim2real.diagnosis.refine import bootstrap_curves, curve_maximiser
from sim2real.effects.library import HeatPartition
from sim2real.effects.truth import TruthSpec, simulate_truth
from sim2real.validation.report import text_report
from tests.sim2real.conftest import SMALL, short_runs

FAST = DiagnosisConfig(
    fit_events_per_run=800,
    calibration_events_per_run=800,
    score_events_per_run=4000,
    grid_points=4,
)
PHI = 0.25  # the simulated truth


def test_curve_maximiser_finds_a_parabola_s_vertex_on_uneven_values() -> None:
    x = np.array([0.0, 0.1, 0.17, 0.2, 0.26, 0.4])
    y = np.stack([-((x - 0.21) ** 2), -3 * (x - 0.15) ** 2 + 7])
    np.testing.assert_allclose(curve_maximiser(x, y), [0.21, 0.15])


def test_curve_maximiser_keeps_to_the_values_at_the_ends_and_where_not_concave() -> None:
    x = np.array([0.0, 0.1, 0.2, 0.4])
    rising = x.copy()
    kink = np.array([0.0, 1.0, 1.0, 5.0])  # best at the end: that end
    flat_top = np.array([0.0, 1.0, 0.0, -5.0])  # a peak: between the neighbours
    out = curve_maximiser(x, np.stack([rising, kink, flat_top]))
    assert out[0] == out[1] == 0.4
    assert 0.0 < out[2] < 0.2


def test_bootstrap_curves_resample_runs_with_replacement() -> None:
    ll = np.arange(12.0).reshape(4, 3)  # 4 values, 3 runs
    a = bootstrap_curves(ll, 50, np.random.default_rng(3))
    b = bootstrap_curves(ll, 50, np.random.default_rng(3))
    np.testing.assert_array_equal(a, b)
    same_runs = np.repeat(ll[:, :1], 3, axis=1)  # every run alike: every resample alike
    alike = bootstrap_curves(same_runs, 20, np.random.default_rng(0))
    np.testing.assert_allclose(alike, np.broadcast_to(3 * ll[:, 0], (20, 4)))
    assert a.shape == (50, 4) and len({tuple(r) for r in a}) > 1


@pytest.fixture(scope="module")
def refined(s2r_atlas: Atlas) -> DiagnosisResult:
    """A heat-partition log (phi 0.25), diagnosed with that one candidate (~10 s)."""
    log = simulate_truth(SMALL, [HeatPartition(phi=PHI)], TruthSpec(short_runs(4)), seed=31)
    return diagnose(log["train"], s2r_atlas, [HeatPartition], FAST, seed=1)


def _parameter(res: DiagnosisResult) -> dict[str, Any]:
    a = res.summary["attribution"]
    assert a["verdict"] == "heat_partition", a["reason"]
    assert a["parameter"] is not None
    return dict(a["parameter"])


def test_refined_value_beats_every_grid_value_on_the_calibration_runs(refined) -> None:
    p = _parameter(refined)
    row = refined.summary["attribution"]["candidates"][0]
    tried = {g["value"]: g["cal_loglik"] for g in row["grid"]}
    assert sorted(tried) == p["values_tried"]
    grid = parameter_grid(0.0, 0.0, 0.4, FAST.grid_points)
    assert set(grid) <= set(tried) and p["value"] in tried
    assert all(tried[p["value"]] >= tried[v] for v in tried)
    assert 0 < p["refine_evaluations"] <= FAST.refine_evals
    assert len(tried) == len(grid) + 1 + p["refine_evaluations"]  # grid, its parabola, search


def test_interval_holds_the_estimate_inside_the_range(refined) -> None:
    p = _parameter(refined)
    lo, hi = p["interval"]
    assert 0.0 <= lo <= p["value"] <= hi <= 0.4
    assert hi - lo < 0.4
    assert p["level"] == FAST.level and p["resamples"] == FAST.resamples
    assert p["method"] == "bootstrap over calibration runs"
    shown = f"fitted phi = {p['value']:.4g}, 90% interval [{lo:.4g}, {hi:.4g}]"
    assert shown in text_report(refined)  # the terminal text and report.md


def test_refined_effect_is_the_winner_and_scores_the_held_out_runs(refined) -> None:
    p = _parameter(refined)
    a = refined.summary["attribution"]
    key = HeatPartition(phi=p["value"]).key
    assert a["winner"] == key == a["candidates"][0]["effect"]
    assert refined.winner is not None and refined.winner.key == key
    assert refined.held_after is not None and "after" in refined.summary["quantify"]


def test_refined_value_is_closer_to_the_truth_than_the_grid(refined) -> None:
    p = _parameter(refined)
    assert abs(p["value"] - PHI) < 0.5 * abs(p["grid_value"] - PHI)


def test_new_settings_are_checked() -> None:
    with pytest.raises(ValueError, match="refine_evals"):
        DiagnosisConfig(refine_evals=-1)
    with pytest.raises(ValueError, match="refine_tol"):
        DiagnosisConfig(refine_tol=0.0)
    with pytest.raises(ValueError, match="resamples"):
        DiagnosisConfig(resamples=0)
