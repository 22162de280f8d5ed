"""The fleet API on its reference implementation: per-slot copies updated in turn, the row
helpers, and every run of a log through one fleet (``predict_runs``, ``predict_log``)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from brake_env.prognostics.fleet import (
    ESTIMATE_FIELDS,
    Fleet,
    LoopFleet,
    concat,
    concat_events,
    last_rows,
    predict_runs,
    select,
    slot_runs,
    take_events,
    vectorises,
)
from brake_env.prognostics.protocol import (
    EventBatch,
    NoPrognostics,
    Oracle,
    Predictor,
    RULEstimate,
    predict_log,
)


class Running(Predictor):
    """A stateful toy: the running mean temperature of the pad so far, and a countdown
    from where its first batch started (so order, resets and mid-life starts all show)."""

    name = "running"
    interval_level = 0.9

    def _reset(self) -> None:
        self._sum, self._n, self._start = 0.0, 0, None

    def _update(self, events: EventBatch) -> RULEstimate:
        if self._start is None:
            self._start = int(events.event[0])
        total = self._sum + np.cumsum(events.temp_c)
        n = self._n + np.arange(1, len(events) + 1)
        self._sum, self._n = float(total[-1]), int(n[-1])
        mean = total / n
        return RULEstimate(
            rul_mean=1e5 - events.event + self._start,
            rul_lower=mean - 1.0,
            rul_upper=mean + 1.0,
            volume_frac=None,
            wear_coeff=n.astype(np.float64),
        )


class RunningFleet(Running):
    """The same, with a fleet of its own (here the reference), so it goes the fleet way."""

    def fleet(self, n_pads: int) -> Fleet:
        return LoopFleet(self, n_pads)


def _run(seed: int, n: int, start: int = 0) -> EventBatch:
    rng = np.random.default_rng(seed)
    cols = {k: rng.normal(100.0, 10.0, n) for k in ("speed_kmh", "mass_kg", "slope_rad")}
    # Whole degrees: running sums are exact, so batching cannot change a bit.
    temp = rng.integers(250, 350, n).astype(np.float64)
    cols.update(energy_j=rng.random(n), temp_c=temp, stop_dist_m=np.ones(n))
    return EventBatch(event=np.arange(start, start + n), **cols)


def _same(a: RULEstimate, b: RULEstimate) -> None:
    for f in ESTIMATE_FIELDS:
        x, y = getattr(a, f), getattr(b, f)
        assert (x is None) == (y is None), f
        if x is not None:
            np.testing.assert_array_equal(x, y, err_msg=f)


def test_loop_fleet_equals_each_pad_alone() -> None:
    runs = [_run(0, 900), _run(1, 700, start=5000), _run(2, 400)]  # one starts mid-life
    want = []
    for ev in runs:
        p = Running()
        p.reset()
        want.append(p.update(ev))
    fleet = Running().fleet(3)
    rng = np.random.default_rng(3)
    pos = [0, 0, 0]
    while any(p < len(r) for p, r in zip(pos, runs, strict=True)):
        pads, parts, rows = [], [], []
        for i in rng.permutation(3):
            n = int(rng.integers(1, 200))
            part = runs[i][pos[i] : pos[i] + n]
            if len(part):
                pads.append(np.full(len(part), i))
                parts.append(part)
                rows.append(np.arange(pos[i], pos[i] + len(part)))
                pos[i] += len(part)
        p = np.concatenate(pads)
        ask = rng.random(len(p)) < 0.2 if rng.random() < 0.5 else None
        est = fleet.update(p, concat_events(parts), ask)
        mask = last_rows(p) if ask is None else ask
        r = np.concatenate(rows)[mask]
        for i in range(3):
            _same(select(est, p[mask] == i), select(want[i], r[p[mask] == i]))


def test_reset_installs_a_new_pad_in_a_slot() -> None:
    fleet = Running().fleet(2)
    fleet.update(np.zeros(50, dtype=np.intp), _run(0, 50))
    fleet.reset([0])
    est = fleet.update(np.zeros(30, dtype=np.intp), _run(1, 30), np.ones(30, dtype=bool))
    p = Running()
    p.reset()
    _same(est, p.update(_run(1, 30)))


def test_row_helpers() -> None:
    pads = np.array([2, 2, 0, 1, 1, 1])
    assert last_rows(pads).tolist() == [False, True, True, False, False, True]
    starts, slots = slot_runs(pads)
    assert starts.tolist() == [0, 2, 3] and slots.tolist() == [2, 0, 1]
    a, b = _run(0, 5), _run(1, 3, start=7)
    both = concat_events([a, b])
    assert len(both) == 8 and both.event.tolist() == [0, 1, 2, 3, 4, 7, 8, 9]
    assert take_events(both, np.array([5, 6, 7])) == b  # contiguous: a view
    picked = take_events(both, np.array([0, 6]))
    assert picked.event.tolist() == [0, 8] and picked.temp_c[1] == b.temp_c[1]
    est = RULEstimate(rul_mean=np.arange(4.0), wear_coeff=np.ones(4))
    two = concat([select(est, np.array([True, False, True, False])), select(est, np.array([3]))])
    assert two.rul_mean.tolist() == [0.0, 2.0, 3.0] and two.rul_lower is None
    assert vectorises(RunningFleet()) and not vectorises(Running()) and not vectorises(Oracle())


@pytest.mark.parametrize("batch", [0, 97])
def test_predict_runs_through_a_fleet_equals_run_by_run(batch: int) -> None:
    runs = [_run(0, 500), _run(1, 260, start=40), _run(2, 31)]
    ticks: list[int] = []
    got = predict_runs(RunningFleet(), runs, batch, ticks.append)
    want = predict_runs(Running(), runs)
    assert sum(ticks) == sum(len(r) for r in runs)
    if batch:  # a call per round of batches: every run's next 97 events
        assert ticks == [97 + 97 + 31, 97 + 97, 97 + 66, 97, 97, 15]
    for g, w in zip(got, want, strict=True):
        _same(g, w)


def test_predict_log_gives_every_event_of_every_run() -> None:
    runs = {"b": _run(0, 300), "a": _run(1, 120, start=10)}
    frames = []
    for name, ev in runs.items():
        f = pd.DataFrame({k: getattr(ev, k) for k in ("event", "speed_kmh", "mass_kg")})
        for k in ("slope_rad", "energy_j", "temp_c", "stop_dist_m"):
            f[k] = getattr(ev, k)
        f.insert(0, "run_id", name)
        frames.append(f)
    log = pd.concat(frames, ignore_index=True)
    whole = predict_log(RunningFleet(), log)
    assert whole["run_id"].tolist() == ["b"] * 300 + ["a"] * 120  # order of appearance
    assert list(whole.columns) == [
        "run_id",
        "event",
        "rul_mean",
        "rul_lower",
        "rul_upper",
        "wear_coeff",
    ]
    pd.testing.assert_frame_equal(predict_log(RunningFleet(), log, batch_events=50), whole)
    pd.testing.assert_frame_equal(predict_log(Running(), log), whole)
    assert predict_log(NoPrognostics(1e4), log)["rul_mean"].eq(1e4).all()


def test_bad_calls() -> None:
    with pytest.raises(ValueError, match="n_pads must be >= 1"):
        LoopFleet(Running(), 0)
    fleet = Running().fleet(2)
    with pytest.raises(ValueError, match="3 slots for 2 events"):
        fleet.update(np.zeros(3, dtype=np.intp), _run(0, 2))
    with pytest.raises(ValueError, match="at least one event"):
        fleet.update(np.zeros(0, dtype=np.intp), _run(0, 0))
    fleet.update(np.array([1, 1]), _run(0, 2))
    fleet.update(np.array([1]), _run(0, 1, start=5))  # a gap: events 2-4 braked, unlogged
    with pytest.raises(ValueError, match="event 3, but the previous batch ended at event 5"):
        fleet.update(np.array([1]), _run(0, 1, start=3))
    with pytest.raises(ValueError, match="batch_events must be >= 0"):
        predict_runs(Running(), [_run(0, 3)], -1)
