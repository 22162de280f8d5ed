"""Carried window sums: exact against a brute-force sum, whatever the batches and pads."""

from __future__ import annotations

import numpy as np

from baselines._rolling import RollingSums
from brake_env.prognostics.fleet import slot_runs


def _brute(event: np.ndarray, values: np.ndarray, block: int, n_blocks: int) -> np.ndarray:
    """Window sum of each row of one pad's whole stream, by definition."""
    b = event // block
    return np.array(
        [values[: i + 1][b[: i + 1] >= b[i] - n_blocks + 1].sum(axis=0) for i in range(len(b))]
    )


def test_window_sums_equal_brute_force_over_interleaved_batches() -> None:
    rng = np.random.default_rng(0)
    block, n_blocks, n_pads = 7, 3, 4
    streams = []
    for p in range(n_pads):  # gaps in the event index; pads 1 and 3 start mid-life
        steps = rng.integers(1, 4, 300)
        ev = np.cumsum(steps) - steps[0] + (0 if p % 2 == 0 else int(rng.integers(50, 500)))
        streams.append((ev.astype(np.int64), rng.integers(-1000, 1000, (300, 2))))
    sums = RollingSums(n_pads, 2, block, n_blocks)
    pos = np.zeros(n_pads, dtype=int)
    got: list[list[np.ndarray]] = [[] for _ in range(n_pads)]
    while (pos < 300).any():
        live = rng.permutation(np.flatnonzero(pos < 300))
        pads, ev, vals = [], [], []
        for p in live[: rng.integers(1, len(live) + 1)]:
            k = int(min(rng.integers(1, 40), 300 - pos[p]))
            pads.append(np.full(k, p))
            ev.append(streams[p][0][pos[p] : pos[p] + k])
            vals.append(streams[p][1][pos[p] : pos[p] + k])
            pos[p] += k
        pad = np.concatenate(pads).astype(np.intp)
        starts, slots = slot_runs(pad)
        out = sums.advance(
            np.concatenate(ev), np.concatenate(vals), starts, slots, np.ones(len(pad), bool)
        )
        for p in np.unique(pad):
            got[p].append(out[pad == p])
    for p in range(n_pads):
        np.testing.assert_array_equal(np.concatenate(got[p]), _brute(*streams[p], block, n_blocks))


def test_reset_forgets_a_pad() -> None:
    sums = RollingSums(2, 1, 5, 2)
    one = np.ones((10, 1), dtype=np.int64)
    ev = np.arange(10, dtype=np.int64)
    starts, slots = np.array([0], dtype=np.intp), np.array([1], dtype=np.intp)
    sums.advance(ev, one, starts, slots, np.ones(10, bool))
    sums.reset(np.array([1]))
    out = sums.advance(ev + 10, one, starts, slots, np.ones(10, bool))
    np.testing.assert_array_equal(out[:, 0], [1, 2, 3, 4, 5, 6, 7, 8, 9, 10])  # no history
