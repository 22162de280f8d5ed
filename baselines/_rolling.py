"""Sums over each pad's recent events, carried across batches, for many pads at once.

The window of an event in block ``b = event // block_events`` holds the pad's logged
events in blocks ``b - n_blocks + 1 .. b`` up to that event: between ``(n_blocks - 1) *
block_events + 1`` and ``n_blocks * block_events`` events once a pad has that many.
Blocks follow the event index (counted from installation), not the rows seen, so a log
that starts mid-life has the same windows as the whole log once a window lies inside it.

Sums are integers (the caller quantises), so they are exact: a window's sum is the
difference of two cumulative sums, whatever the batches the events came in, whatever the
other pads of the batch, and whether the log started at installation or mid-life. Per pad
only the cumulative sum and its value at the last ``n_blocks`` block starts are carried.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

I64 = NDArray[np.int64]
_SEG = np.int64(1 << 31)  # block indices are < 2**31 (events < 1e9, docs/schema.md)


class RollingSums:
    """Carried window sums of ``n_cols`` integer columns for ``n_pads`` pads.

    Args:
        n_pads: Number of slots.
        n_cols: Columns summed.
        block_events: Events per block [-].
        n_blocks: Blocks per window [-].
    """

    def __init__(self, n_pads: int, n_cols: int, block_events: int, n_blocks: int) -> None:
        self.block_events = block_events
        self.n_blocks = n_blocks
        self.total = np.zeros((n_pads, n_cols), dtype=np.int64)  # sum of all rows so far
        self.last_block = np.full(n_pads, -1, dtype=np.int64)  # block of the last row
        # before[p, j % n_blocks]: sum of pad p's rows in blocks < j, for the last n_blocks j.
        self.before = np.zeros((n_pads, n_blocks, n_cols), dtype=np.int64)

    def reset(self, pads: NDArray[np.intp]) -> None:
        self.total[pads] = 0
        self.last_block[pads] = -1
        self.before[pads] = 0

    def advance(
        self,
        event: I64,
        values: I64,
        starts: NDArray[np.intp],
        slots: NDArray[np.intp],
        want: NDArray[np.bool_],
    ) -> I64:
        """Take the next rows of several pads; window sums at the rows ``want``.

        Args:
            event: Event index of each row (increasing within a pad's rows).
            values: Rows x columns to sum.
            starts, slots: Start row and slot of each pad's contiguous rows.
            want: Rows whose window sums are returned.

        Returns:
            Window sums at the wanted rows, in row order (rows x columns).
        """
        n = len(event)
        seg = np.repeat(np.arange(len(starts)), np.diff(np.append(starts, n)))
        cum = np.cumsum(values, axis=0)
        before_seg = np.where(starts[:, None] > 0, cum[starts - 1], 0)
        # Cumulative sum of each row since its pad's installation (exact integers).
        total = cum - before_seg[seg] + self.total[slots][seg]
        block = event // self.block_events
        key = seg * _SEG + block
        rows = np.flatnonzero(want)
        first = block[rows] - self.n_blocks + 1
        out = total[rows] - self._sum_before(first, seg[rows], key, total, starts, slots)
        # Carry: each pad's total and its sums before the last n_blocks block starts.
        ends = np.append(starts[1:], n) - 1
        last = block[ends]
        js = last[:, None] + np.arange(1 - self.n_blocks, 1)[None, :]
        segs = np.repeat(np.arange(len(starts)), self.n_blocks)
        new_before = self._sum_before(js.ravel(), segs, key, total, starts, slots)
        self.before[slots[:, None], js % self.n_blocks] = new_before.reshape((*js.shape, -1))
        self.total[slots] = total[ends]
        self.last_block[slots] = last
        return out

    def _sum_before(
        self,
        j: I64,
        seg: NDArray[np.intp],
        key: I64,
        total: I64,
        starts: NDArray[np.intp],
        slots: NDArray[np.intp],
    ) -> I64:
        """Sum of the rows of pad ``slots[seg]`` in blocks < ``j``, one per query."""
        idx = np.searchsorted(key, seg * _SEG + j, side="left") - 1  # last row of block < j
        in_batch = idx >= starts[seg]
        slot = slots[seg]
        carried = np.where(
            (j > self.last_block[slot])[:, None],
            self.total[slot],  # every earlier row is in a block < j
            self.before[slot, j % self.n_blocks],
        )
        return np.where(in_batch[:, None], total[np.maximum(idx, 0)], carried)
