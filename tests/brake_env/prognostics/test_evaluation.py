"""The evaluation harness on a tiny dataset with predictors whose scores are known."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from brake_env.data.datasets import DatasetSpec, make_dataset
from brake_env.model.atlas import Atlas
from brake_env.model.regime import WearRegime
from brake_env.prognostics.evaluation import EvaluationConfig, evaluate
from brake_env.prognostics.plots import plot_all
from brake_env.prognostics.protocol import EventBatch, NoPrognostics, Oracle, Predictor, RULEstimate

# Large K: lives of ~1e3-3e3 events keep the test fast.
TINY = DatasetSpec(n_train=3, n_id=2, n_ood_slow=1, n_ood_fast=1, wear=WearRegime(2e-4, 2e-5))


class Biased(Predictor):
    """The truth shifted by known offsets, with an interval, volume and K."""

    name = "biased"
    interval_level = 0.9

    def _update(self, events: EventBatch) -> RULEstimate:
        assert events.rul_events is not None and events.volume_frac is not None
        assert events.wear_coeff is not None
        rul = events.rul_events.astype(np.float64)
        return RULEstimate(
            rul_mean=rul + 10.0,
            rul_lower=rul - 5.0,
            rul_upper=rul + 5.0,
            volume_frac=events.volume_frac + 0.01,
            wear_coeff=events.wear_coeff * 1.25,
        )


@pytest.fixture(scope="module")
def logs(small_atlas: Atlas) -> dict[str, pd.DataFrame]:
    return make_dataset(small_atlas, TINY, seed=3).logs


def test_known_scores(logs: dict[str, pd.DataFrame]) -> None:
    preds = {"oracle": Oracle(), "biased": Biased(), "none": NoPrognostics()}
    ev = evaluate(preds, logs)
    json.dumps(ev.metrics, allow_nan=False)  # strict JSON: no NaN or inf anywhere
    assert ev.splits == ["id", "ood"]
    assert set(ev.metrics["splits"]["ood"]["runs"]) == {"ood-slow-00", "ood-fast-00"}
    assert ev.samples == {"id": "id-00", "ood": "ood-fast-00"}  # fastest OOD run
    b = ev.metrics["models"]["biased"]
    for split in ("id", "ood"):
        o = ev.metrics["models"]["oracle"]["splits"][split]["mean"]
        assert o["rul_rmse"] == 0.0 and o["relative_accuracy"] == 1.0
        assert all(v == 0 for v in o["convergence_event"].values())
        mu = b["splits"][split]["mean"]
        assert mu["rul_rmse"] == pytest.approx(10.0)
        assert mu["volume_rmse"] == pytest.approx(0.01)
        assert mu["k_rel_error"]["mean"] == pytest.approx(0.25)
        assert mu["interval_coverage"] == 1.0
        assert mu["alpha_lambda"] == 1.0
    assert b["interval_level"] == 0.9
    # NoPrognostics: the mean training life, a constant; its RMSE per run by hand.
    life = logs["train"].groupby("run_id", observed=True).size().mean()
    run = logs["id"][logs["id"]["run_id"] == "id-01"]
    expect = np.sqrt(np.mean((life - run["rul_events"].to_numpy()) ** 2))
    got = ev.metrics["models"]["none"]["splits"]["id"]["runs"]["id-01"]["rul_rmse"]
    assert got == pytest.approx(expect)
    table = ev.table()
    assert "R2" in table and "Mean" in table and "OOD model" in table
    assert "| biased |" in ev.summary_table(markdown=True)


def test_batches_give_the_same_scores(logs: dict[str, pd.DataFrame]) -> None:
    whole = evaluate({"b": Biased()}, logs)
    batched = evaluate({"b": Biased()}, logs, EvaluationConfig(batch_events=97))
    for split in ("id", "ood"):
        a = whole.metrics["models"]["b"]["splits"][split]["runs"]
        c = batched.metrics["models"]["b"]["splits"][split]["runs"]
        assert a == c


def test_figures(logs: dict[str, pd.DataFrame], tmp_path: Path) -> None:
    ev = evaluate({"oracle": Oracle(), "biased": Biased()}, logs, EvaluationConfig(trace_points=50))
    assert len(ev.traces["biased"]["id"]["id-00"]) == 50
    figs = plot_all(ev, tmp_path)
    assert set(figs) == {"volume", "wear_coeff", "rul", "convergence"}
    assert all(p.stat().st_size > 10_000 for p in figs.values())


def test_bad_input(logs: dict[str, pd.DataFrame]) -> None:
    with pytest.raises(ValueError, match="no predictors"):
        evaluate({}, logs)
    with pytest.raises(ValueError, match="no test log"):
        evaluate({"o": Oracle()}, {"train": logs["train"]})
    with pytest.raises(ValueError, match="'train' log"):
        evaluate({"o": Oracle()}, {"id": logs["id"]})
    with pytest.raises(ValueError, match="ground truth"):
        evaluate({"o": Oracle()}, {**logs, "id": logs["id"].drop(columns="rul_events")})
    late = logs["id"][logs["id"]["event"] >= 5]
    with pytest.raises(ValueError, match="event 0"):
        evaluate({"o": Oracle()}, {**logs, "id": late})
    with pytest.raises(ValueError, match="tolerances"):
        EvaluationConfig(tolerances=(0.0,))


def test_no_prognostics_takes_lives_only_from_failed_runs(logs: dict[str, pd.DataFrame]) -> None:
    train = logs["train"]
    lives = train.groupby("run_id", observed=True)["event"].max() + 1
    # Logged from mid-life: the life is still the last event + 1, not the row count.
    tail = train.groupby("run_id", observed=True).tail(50)
    assert NoPrognostics().fit(tail).mean_life_events == pytest.approx(lives.mean())
    # One run removed before failure (its last row not marked failed): left out.
    cut = train.copy()
    first = str(cut["run_id"].iloc[0])
    rows = np.flatnonzero(cut["run_id"] == first)
    cut = cut.drop(index=cut.index[rows[len(rows) // 2 :]])
    cut["failed"] = cut["failed"].astype(bool)
    assert NoPrognostics().fit(cut).mean_life_events == pytest.approx(lives.drop(first).mean())
    none_failed = cut.assign(failed=False)
    with pytest.raises(ValueError, match="no training run ended at failure"):
        NoPrognostics().fit(none_failed)
