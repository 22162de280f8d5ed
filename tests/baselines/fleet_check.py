"""The fleet contract, checked against the reference: estimates of a predictor's own fleet
equal those of :class:`LoopFleet` (one single-pad predictor per slot) at the same events."""

from __future__ import annotations

import numpy as np
import pandas as pd

from brake_env.prognostics.fleet import ESTIMATE_FIELDS, LoopFleet
from brake_env.prognostics.protocol import EventBatch, Predictor, RULEstimate, iter_runs


def _concat(parts: list[EventBatch]) -> EventBatch:
    kw = {}
    for name in ("event", "speed_kmh", "mass_kg", "slope_rad", "energy_j", "temp_c", "stop_dist_m"):
        kw[name] = np.concatenate([getattr(p, name) for p in parts])
    return EventBatch(**kw)


def assert_fleet_matches_loop(
    predictor: Predictor, log: pd.DataFrame, seed: int, n_pads: int = 3, max_batch: int = 300
) -> int:
    """Feed both fleets the runs of ``log`` on ``n_pads`` slots: interleaved pads, random
    batch sizes, a mid-life start for every other run, random rows summarised. Returns the
    number of estimates compared."""
    rng = np.random.default_rng(seed)
    runs = [ev for _, ev in iter_runs(log)]
    runs = [ev[int(rng.integers(len(ev) // 2)) :] if i % 2 else ev for i, ev in enumerate(runs)]
    queues: list[list[EventBatch]] = [runs[i::n_pads] for i in range(n_pads)]
    pos = [0] * n_pads
    fast, ref = predictor.fleet(n_pads), LoopFleet(predictor, n_pads)
    assert not isinstance(fast, LoopFleet), f"{predictor.name} does not vectorise its fleet"
    compared = 0
    while any(queues):
        live = [s for s in range(n_pads) if queues[s]]
        slots = rng.permutation(live)[: int(rng.integers(1, len(live) + 1))]
        pads, parts = [], []
        for s in slots:
            run = queues[s][0]
            size = int(rng.integers(1, max_batch))
            parts.append(run[pos[s] : pos[s] + size])
            pads.append(np.full(len(parts[-1]), s, dtype=np.intp))
            pos[s] += size
            if pos[s] >= len(run):  # the pad fails or is removed: next run is a new pad
                queues[s].pop(0)
                pos[s] = 0
        p = np.concatenate(pads)
        want = rng.random(len(p)) < 0.3
        want[-1] = True
        got, exp = fast.update(p, _concat(parts), want), ref.update(p, _concat(parts), want)
        _assert_same(got, exp)
        compared += len(got)
        for s in slots:
            if pos[s] == 0:
                fast.reset(s)
                ref.reset(s)
    return compared


def _assert_same(got: RULEstimate, exp: RULEstimate) -> None:
    for f in ESTIMATE_FIELDS:
        a, b = getattr(got, f), getattr(exp, f)
        assert (a is None) == (b is None), f
        if a is not None:
            np.testing.assert_array_equal(a, b, err_msg=f)
