"""The baselines' fleets check an update as one pad's ``update`` does, before any state
changes, with one clear error per mistake."""

from __future__ import annotations

import numpy as np
import pytest

from baselines.physics import PhysicsPredictor
from brake_env.model.atlas import Atlas
from brake_env.prognostics.fleet import vectorises
from brake_env.prognostics.protocol import EventBatch
from tests.baselines.synthetic import synthetic_log


def _events(first: int, n: int) -> EventBatch:
    log = synthetic_log([first + n])
    return EventBatch.from_frame(log[log["event"] >= first].drop(columns="run_id"))


def test_bad_updates_are_refused_and_change_nothing(small_atlas: Atlas) -> None:
    p = PhysicsPredictor(small_atlas).fit(synthetic_log([300, 400]))
    assert vectorises(p)
    fleet = p.fleet(2)
    zeros, ev = np.zeros(10, dtype=np.intp), _events(5, 10)
    with pytest.raises(ValueError, match=r"slots must be in \[0, 2\), got \[2\]"):
        fleet.update(np.full(10, 2), ev)
    with pytest.raises(ValueError, match="contiguous"):
        fleet.update(np.r_[zeros[:4], np.ones(3, np.intp), zeros[:3]], ev)
    with pytest.raises(ValueError, match="summarise has 3 rows"):
        fleet.update(zeros, ev, np.ones(3, bool))
    with pytest.raises(ValueError, match="at least one event"):
        fleet.update(zeros[:0], ev[0:0])
    backwards = EventBatch.from_arrays({**ev.__dict__, "event": ev.event[::-1].copy()})
    with pytest.raises(ValueError, match="do not increase"):
        fleet.update(zeros, backwards)
    est = fleet.update(zeros, ev)  # a new pad may start mid-life (event 5)
    assert len(est) == 1 and est.rul_mean[0] == p.update(ev).rul_mean[-1]
    with pytest.raises(ValueError, match=r"slot 0's batch starts at event 12, expected >= 15"):
        fleet.update(zeros, _events(12, 10))  # events never go back; gaps are allowed
    fleet.reset(0)  # a new pad: any start again
    assert len(fleet.update(zeros, _events(20, 10), np.ones(10, bool))) == 10
