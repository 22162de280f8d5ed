"""Gaps in ``event`` (braked, not logged) for the baselines and the no-information
predictor: accepted within and between batches, read by the event index (protocol module
docstring, "Gaps")."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from baselines.physics import PhysicsPredictor
from baselines.window import WindowPredictor
from brake_env.model.atlas import Atlas
from brake_env.prognostics.protocol import NoPrognostics, Predictor, iter_runs, predict_log
from tests.baselines.synthetic import wear_log

LIVES = [3000, 3600, 4200, 3300, 3900, 4500]


def _gapped(log: pd.DataFrame, frac: float, seed: int) -> pd.DataFrame:
    rng = np.random.default_rng(seed)
    keep = rng.random(len(log)) >= frac
    last = log["run_id"].ne(log["run_id"].shift(-1)).to_numpy()
    return log[keep | last].reset_index(drop=True)


@pytest.fixture(scope="module")
def predictors(small_atlas: Atlas) -> list[Predictor]:
    train = wear_log(LIVES)
    return [
        PhysicsPredictor(small_atlas).fit(train),
        WindowPredictor().fit(train),
        NoPrognostics().fit(train),
    ]


def test_event_only_predictors_give_the_full_logs_estimate(predictors: list[Predictor]) -> None:
    """Physics line and no-information: the estimate at a kept event is the full log's."""
    test = wear_log([2500, 4000], seed=5, prefix="test")
    gapped = _gapped(test, 0.5, seed=1)
    for p in predictors[::2]:
        full = predict_log(p, test).set_index(["run_id", "event"])
        got = predict_log(p, gapped).set_index(["run_id", "event"])
        pd.testing.assert_frame_equal(got, full.loc[got.index])


@pytest.mark.parametrize("frac", [0.01, 0.1, 0.5])
def test_window_model_with_gaps_stays_close(predictors: list[Predictor], frac: float) -> None:
    """The window model's windows hold fewer events: a noisier reading, not a biased one."""
    window = predictors[1]
    test = wear_log([3800], seed=7, prefix="test")
    gapped = _gapped(test, frac, seed=2)
    got = predict_log(window, gapped)
    truth = gapped["rul_events"].to_numpy()
    late = gapped["event"].to_numpy() > 0.3 * 3800
    rmse = np.sqrt(np.mean((got["rul_mean"].to_numpy() - truth)[late] ** 2))
    full = predict_log(window, test)
    rmse_full = np.sqrt(
        np.mean((full["rul_mean"] - test["rul_events"]).to_numpy()[test["event"] > 0.3 * 3800] ** 2)
    )
    assert rmse < 1.5 * rmse_full + 0.01 * 3800


def test_huge_gaps_and_gaps_between_batches(predictors: list[Predictor]) -> None:
    test = wear_log([3000], seed=9, prefix="test")
    ((_, ev),) = iter_runs(test)
    for p in predictors:
        p.reset()
        a = p.update(ev[:100])
        b = p.update(ev[2000:2100])  # 1,900 events braked between the batches
        assert len(a) == len(b) == 100
        late = ev[2100:2101]
        huge = type(late).from_arrays({**late.__dict__, "event": late.event + 10**8})
        est = p.update(huge)
        assert np.isfinite(est.rul_mean).all() and est.rul_mean[0] >= 0
        if p.name != "none":
            assert est.rul_mean[0] == pytest.approx(0.0, abs=1.0)
        with pytest.raises(ValueError, match="previous batch ended at event 100002100"):
            p.update(ev[:1])
