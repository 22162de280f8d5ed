"""Censored training fleets: where runs are cut, what is measured, what truth is dropped."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from brake_env.data.censor import censor_log
from brake_env.data.datasets import DatasetSpec, make_dataset
from brake_env.data.schema import FAILED, MEASURED_VOLUME, validate_event_log
from brake_env.model.atlas import Atlas
from brake_env.model.regime import WearRegime

SPEC = DatasetSpec(n_train=40, n_id=0, n_ood_slow=0, n_ood_fast=0, wear=WearRegime(2e-4, 2e-5))


@pytest.fixture(scope="module")
def train(small_atlas: Atlas) -> pd.DataFrame:
    return make_dataset(small_atlas, SPEC, seed=2).logs["train"]


def test_runs_cut_within_range_truth_dropped_volume_measured_at_removal(
    train: pd.DataFrame,
) -> None:
    out = censor_log(train, np.random.default_rng(0), cut=(0.5, 0.9), volume_noise=0.02)
    validate_event_log(out)  # still a valid event log
    assert not {"volume_frac", "wear_coeff", "rul_events"} & set(out.columns)
    assert not out[FAILED].any()
    life = train.groupby("run_id", observed=True)["event"].size()
    g = out.groupby("run_id", observed=True)
    kept = g.size()
    frac = kept / life[kept.index]
    assert frac.between(0.5 - 1 / life.min(), 0.9).all()
    assert frac.std() > 0.08  # spread over the range, not one fraction for all
    # Every run keeps a prefix of its rows: events 0 .. n - 1, as in the source log.
    assert (g["event"].first() == 0).all() and (g["event"].last() == kept - 1).all()
    # One measurement per run, at its last kept row: the true volume after that event.
    meas = out[out[MEASURED_VOLUME].notna()]
    assert list(meas["run_id"]) == list(kept.index) and (meas["event"] == kept.to_numpy() - 1).all()
    true_after = train.set_index(["run_id", "event"])["volume_frac"]
    truth = true_after.loc[list(zip(meas["run_id"], meas["event"] + 1, strict=True))].to_numpy()
    rel = meas[MEASURED_VOLUME].to_numpy() / truth - 1.0
    assert 0.01 < rel.std() < 0.03 and abs(rel.mean()) < 0.01


def test_inspections_without_volume_and_seeds(train: pd.DataFrame) -> None:
    out = censor_log(train, np.random.default_rng(1), inspections=2)
    per_run = out[MEASURED_VOLUME].notna().groupby(out["run_id"], observed=True).sum()
    assert per_run.between(1, 3).all() and per_run.mean() > 2.5
    assert (out[MEASURED_VOLUME].dropna() <= 1.0).all()
    blind = censor_log(train, np.random.default_rng(1), volume_noise=None)
    assert blind[MEASURED_VOLUME].isna().all()
    again = censor_log(train, np.random.default_rng(1), inspections=2)
    pd.testing.assert_frame_equal(out, again)
    other = censor_log(train, np.random.default_rng(2), inspections=2)
    assert len(other) != len(out)


def test_bad_input_raises(train: pd.DataFrame) -> None:
    with pytest.raises(ValueError, match=r"lacks column\(s\) \['rul_events'\]"):
        censor_log(train.drop(columns="rul_events"), np.random.default_rng(0))
    with pytest.raises(ValueError, match="cut must satisfy"):
        censor_log(train, np.random.default_rng(0), cut=(0.5, 1.0))
    shuffled = train.sample(frac=1.0, random_state=0)
    with pytest.raises(ValueError, match="contiguous"):
        censor_log(shuffled, np.random.default_rng(0))
