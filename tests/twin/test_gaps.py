"""Gaps in ``event`` (braked, not logged): the twin and its fleet take them everywhere, and
an estimate after a gap means what the protocol says (module docstring, "Gaps")."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from brake_env.data.datasets import Dataset
from brake_env.prognostics.fleet import ESTIMATE_FIELDS, concat_events, predict_runs, take_events
from brake_env.prognostics.protocol import EventBatch, iter_runs, predict_log
from twin import DigitalTwin


def _drop(ev: EventBatch, frac: float, seed: int) -> EventBatch:
    """``ev`` with a random ``frac`` of its events left out (the first and last kept)."""
    rng = np.random.default_rng(seed)
    keep = rng.random(len(ev)) >= frac
    keep[[0, -1]] = True
    return take_events(ev, np.flatnonzero(keep))


def _shift(ev: EventBatch, by: int) -> EventBatch:
    """``ev`` with every event index moved on by ``by`` (events not logged before it)."""
    return EventBatch.from_arrays({**ev.__dict__, "event": ev.event + by})


def test_random_gaps_give_estimates_close_to_the_full_log(
    dataset: Dataset, fitted: DigitalTwin
) -> None:
    """10% of the events dropped: at the kept events the RUL differs from the full log's by
    a small fraction of the life (the missing evidence widens the posterior, no more)."""
    for _, ev in list(iter_runs(dataset.logs["id"]))[:2]:
        fitted.reset()
        full = fitted.update(ev)
        gapped = _drop(ev, 0.1, seed=3)
        fitted.reset()
        est = fitted.update(gapped)
        at = np.searchsorted(ev.event, gapped.event)
        life = len(ev)
        err = np.abs(est.rul_mean - full.rul_mean[at])
        assert np.all(np.isfinite(est.rul_mean)) and len(est) == len(gapped)
        # Early in life (posterior still broad) the dropped evidence moves the estimate by up
        # to ~10% of the life; from ~20% of the life on it is the full log's.
        assert np.quantile(err, 0.9) < 0.01 * life
        assert np.all(err[gapped.event > 0.3 * life] < 0.01 * life)
        truth = ev.rul_events
        rmse_full = np.sqrt(np.mean((full.rul_mean - truth) ** 2))
        rmse_gap = np.sqrt(np.mean((est.rul_mean - truth[at]) ** 2))
        assert rmse_gap < 1.5 * rmse_full
        # The estimate counts from the last logged event: the volume follows the index.
        n_done = gapped.event + 1.0
        want = fitted.wear.volume_at_work(est.wear_coeff * n_done)
        np.testing.assert_allclose(est.volume_frac, want, rtol=1e-12)


def test_fleet_with_gaps_equals_the_single_pad(dataset: Dataset, fitted: DigitalTwin) -> None:
    """The fleet contract holds with gaps, within batches and between them, dense or sparse."""
    runs = [_drop(ev, 0.3, seed=i) for i, (_, ev) in enumerate(iter_runs(dataset.logs["id"]))]
    want = []
    for ev in runs:
        fitted.reset()
        want.append(fitted.update(ev))
    for batch in (0, 777):
        got = predict_runs(fitted, runs, batch_events=batch)
        for g, w in zip(got, want, strict=True):
            for f in ESTIMATE_FIELDS:
                np.testing.assert_allclose(getattr(g, f), getattr(w, f), rtol=1e-9, atol=1e-6)


def test_gap_between_batches_equals_one_batch(dataset: Dataset, fitted: DigitalTwin) -> None:
    _, ev = next(iter_runs(dataset.logs["id"]))
    a, b = ev[:1000], ev[1500:3000]  # 500 events braked between the two batches
    fitted.reset()
    one = fitted.update(concat_events([a, b]))
    fitted.reset()
    fitted.update(a)
    two = fitted.update(b)
    np.testing.assert_allclose(two.rul_mean, one.rul_mean[1000:], rtol=1e-9)
    fleet = fitted.fleet(1)
    fleet.update(np.zeros(1000, np.intp), a)
    last = fleet.update(np.zeros(1500, np.intp), b)
    assert last.rul_mean[0] == pytest.approx(one.rul_mean[-1], rel=1e-9)
    with pytest.raises(ValueError, match=r"batch starts at event 1500, but the previous"):
        fitted.update(b)  # events never go back
    with pytest.raises(ValueError, match=r"slot 0's batch starts at event 1500, expected >= 3000"):
        fleet.update(np.zeros(1500, np.intp), b)


def test_gaps_at_the_start(dataset: Dataset, fitted: DigitalTwin) -> None:
    """A log that starts late (events 0..k-1 not logged) is a gap at the start: estimates
    at its events are those of the full log without the early evidence, close to it once the
    later events have spoken."""
    _, ev = next(iter_runs(dataset.logs["id"]))
    fitted.reset()
    full = fitted.update(ev)
    start = len(ev) // 3
    fitted.reset()
    late = fitted.update(ev[start:])
    life = len(ev)
    assert abs(late.rul_mean[-1] - full.rul_mean[-1]) < 0.05 * life
    # A gap right after the first event: the same.
    fitted.reset()
    est = fitted.update(concat_events([ev[:1], ev[start:]]))
    assert abs(est.rul_mean[-1] - full.rul_mean[-1]) < 0.05 * life


def test_huge_gaps_give_rul_zero_not_an_error(dataset: Dataset, fitted: DigitalTwin) -> None:
    """A gap of 1e8 events (far beyond any life the posterior allows) after 1,000 logged
    events, or before the first one: the pad must have failed, RUL 0, finite bounds."""
    _, ev = next(iter_runs(dataset.logs["id"]))
    for gapped in (
        concat_events([ev[:1000], _shift(ev[1000:1010], 10**8)]),
        _shift(ev[:10], 10**8),
    ):
        fitted.reset()
        est = fitted.update(gapped)
        for f in ESTIMATE_FIELDS:
            assert np.all(np.isfinite(getattr(est, f))), f
        assert est.rul_mean[-1] == pytest.approx(0.0, abs=1.0)
        assert est.rul_lower[-1] == 0.0
        fleet = fitted.fleet(2)
        got = fleet.update(np.zeros(len(gapped), np.intp), gapped)
        assert got.rul_mean[-1] == pytest.approx(est.rul_mean[-1], rel=1e-9, abs=1e-9)


def test_predict_log_takes_a_log_with_gaps(dataset: Dataset, fitted: DigitalTwin) -> None:
    log = dataset.logs["id"]
    rng = np.random.default_rng(0)
    gapped = log[rng.random(len(log)) >= 0.01].reset_index(drop=True)
    out = predict_log(fitted, gapped)
    assert len(out) == len(gapped)
    assert np.all(np.isfinite(out["rul_mean"]))
    pd.testing.assert_series_equal(out["event"], gapped["event"], check_names=False)
