"""Many pads through one calibrated twin at once (docs/results/prognostics.md).

Per pad the fleet keeps the grid log-likelihood as a difference array over the K grid: an
event's log-likelihood is piecewise constant over the grid, with one jump where each grid
K's layer changes, so taking an event in is a scatter of one value per layer (about 80),
whatever the grid's size (768 points). The log posterior is built (a cumulative sum over
the grid) only where an estimate is asked for.

Where estimates are wanted at many consecutive events of a pad (evaluation asks for every
event), they come from a window of the grid. Each event's log-likelihood is <= 0 at every
grid K and the survival term only grows, so a grid point's log posterior never rises:
within a block of events, a point whose log posterior before the block lies more than
``NEGLIGIBLE_LOG`` below the maximum after the block weighs less than ``exp(-60)`` of it at
every event of the block, and leaving it out changes no estimate beyond rounding.
"""

from __future__ import annotations

import itertools

import numpy as np
from numpy.typing import NDArray

from brake_env.prognostics.fleet import SlotFleet, last_rows, slot_runs, take_events
from brake_env.prognostics.protocol import EventBatch, RULEstimate
from twin.posterior import F64, Summary, TwinGrid

NEGLIGIBLE_LOG = 60.0  # log-posterior margin below which grid points are left out [-]
DENSE_EVERY = 32  # a run asking for estimates more often than every this many events is
# read block by block from a window of the grid
# Rows whose evidence is computed together when taken in on the whole grid: the arrays are
# (rows, layers), ~80 layers, not (rows, grid points), so many more rows fit than a read-out
# window's chunk; fewer, larger calls cost ~15% less CPU (a cost study's hot path).
TAKE_IN_ROWS = 4096


class TwinFleet(SlotFleet):
    """Per-pad posterior state of one calibrated digital twin for ``n_pads`` slots.

    The estimates equal those of :class:`twin.DigitalTwin` fed the same events pad by pad,
    to rounding (tested to 1e-9 relative).

    Args:
        grid: The calibrated twin's grid (``DigitalTwin.grid``); kept as it is now.
        n_pads: Number of slots.
    """

    def __init__(self, grid: TwinGrid, n_pads: int) -> None:
        super().__init__("twin", n_pads)
        self.grid = grid
        self.chunk = grid.config.chunk_events
        # Difference arrays of the grid log-likelihood; the extra last column takes the
        # jumps of layers no grid K reaches.
        self._diff = np.zeros((n_pads, grid.n_grid + 1))

    def _reset_slots(self, pads: NDArray[np.intp]) -> None:
        self._diff[pads] = 0.0

    def loglik(self, pad: int) -> F64:
        """The grid log-likelihood of slot ``pad`` after its events so far [-]."""
        return np.cumsum(self._diff[pad, :-1])

    def _update(
        self,
        pads: NDArray[np.intp],
        events: EventBatch,
        want: NDArray[np.bool_],
        starts: NDArray[np.intp],
        slots: NDArray[np.intp],
    ) -> RULEstimate:
        # Events may skip indices (gaps: braked, not logged). Each event's evidence is read
        # at its own index, the layer K * event of every grid K, so the unlogged events wear
        # the expected amount for each K and only their temperatures are missing.
        ends = np.append(starts[1:], len(pads))
        rows = np.flatnonzero(want)
        out = np.empty((5, rows.size))
        # Runs that ask for estimates at many of their events are read from a window of the
        # grid, block by block; the others are taken in all together, round by round up to
        # the next row asked for, each read on the whole grid.
        lengths = ends - starts
        asked = np.add.reduceat(want.astype(np.intp), starts)
        dense = (asked > 1) & (asked * DENSE_EVERY > lengths)
        if not dense.all():
            self._rounds(pads, events, want, np.repeat(~dense, lengths), out, rows)
        for a, b, slot in zip(starts[dense], ends[dense], slots[dense], strict=True):
            for c0 in range(int(a), int(b), self.chunk):
                c1 = min(c0 + self.chunk, int(b))
                at = np.flatnonzero(want[c0:c1])
                res = self._block(int(slot), events[c0:c1], at)
                self._put(out, rows, c0 + at, res)
        return RULEstimate(*out)

    # ------------------------------------------------------------------ evidence in
    def _evidence(self, ev: EventBatch) -> tuple[F64, F64, NDArray[np.intp]]:
        """Each event's log-likelihood (rows, layers reached) and its jumps over the grid
        as (values, grid index) (rows, layers reached): the first layer's value at index 0,
        then each layer's step to the next at the index from which on the grid K are in the
        next one."""
        g = self.grid
        layers = g.layers_reached(ev.event)
        ll = g.layer_loglik(ev.speed_kmh, ev.mass_kg, ev.slope_rad, ev.temp_c, layers)
        vals = np.empty_like(ll)
        vals[:, 0] = ll[:, 0]
        np.subtract(ll[:, 1:], ll[:, :-1], out=vals[:, 1:])
        at = np.zeros(ll.shape, dtype=np.intp)
        at[:, 1:] = g.first_index(ev.event, slice(layers.start, layers.stop - 1))
        return ll, vals, at

    def _rounds(
        self,
        pads: NDArray[np.intp],
        events: EventBatch,
        want: NDArray[np.bool_],
        mine: NDArray[np.bool_],
        out: F64,
        rows: NDArray[np.intp],
    ) -> None:
        """Take in the rows ``mine`` (whole runs), all slots together: round ``r`` takes
        each run's rows up to its ``r``-th row asked for, which is then read out."""
        w = want & mine
        if not (w & ~last_rows(pads)).any():  # at most each run's last row: one round
            self._take_in(pads, events, np.flatnonzero(mine))
            done = np.flatnonzero(w)
            if done.size:
                self._put(out, rows, done, self._summarise_latest(pads[done], events.event[done]))
            return
        before: NDArray[np.intp] = np.cumsum(w) - w  # rows asked for before each row
        starts, _ = slot_runs(pads)
        seg: NDArray[np.intp] = before - np.repeat(
            before[starts], np.diff(np.append(starts, len(pads)))
        )
        idx = np.flatnonzero(mine)
        idx = idx[np.argsort(seg[idx], kind="stable")]  # by round, each in row order
        bounds = np.searchsorted(seg[idx], np.arange(int(seg[idx[-1]]) + 2))
        for a, b in itertools.pairwise(bounds):
            part = idx[a:b]
            self._take_in(pads, events, part)
            done = part[want[part]]
            if done.size:
                self._put(out, rows, done, self._summarise_latest(pads[done], events.event[done]))

    def _take_in(self, pads: NDArray[np.intp], events: EventBatch, idx: NDArray[np.intp]) -> None:
        """Add the events at rows ``idx`` (in row order) to their slots' difference arrays."""
        width = self._diff.shape[1]
        flat = self._diff.reshape(-1)
        for c0 in range(0, idx.size, TAKE_IN_ROWS):
            r = idx[c0 : c0 + TAKE_IN_ROWS]
            _, vals, at = self._evidence(take_events(events, r))
            at += (pads[r] * width)[:, None]
            np.add.at(flat, at.ravel(), vals.ravel())

    # ------------------------------------------------------------------ read-out
    def _summarise_latest(self, slots: NDArray[np.intp], event: NDArray[np.int64]) -> Summary:
        """Estimates of ``slots`` after their latest events (``event``), on the full grid."""
        g = self.grid
        post = np.cumsum(self._diff[slots, :-1], axis=1)
        post += g.log_prior
        return g.summarise(post, 0, event.astype(np.float64) + 1.0)

    def _block(self, slot: int, ev: EventBatch, at: NDArray[np.intp]) -> Summary | None:
        """Take in the next events of one slot (gaps allowed); estimates after the events ``at``."""
        g, d = self.grid, self._diff[slot]
        ll, vals, idx = self._evidence(ev)
        if at.size == 0:
            np.add.at(d, idx.ravel(), vals.ravel())
            return None
        n_after = ev.event.astype(np.float64) + 1.0
        before = np.cumsum(d[:-1])
        np.add.at(d, idx.ravel(), vals.ravel())
        lo, hi = self._window(before, np.cumsum(d[:-1]), n_after[0], n_after[-1])
        m = int(at[-1]) + 1
        ll, vals, idx = ll[:m], vals[:m], idx[:m]
        # Each event's log-likelihood on the window: its value at ``lo`` (the layer there),
        # then the jumps of the layers whose edge lies inside the window.
        width = hi - lo
        rows = np.zeros((m, width + 1))
        layer_lo = (idx[:, 1:] <= lo).sum(axis=1)
        rows[:, 0] = ll[np.arange(m), layer_lo]
        inside = (idx > lo) & (idx < hi)
        r = np.nonzero(inside)[0]
        np.add.at(rows, (r, idx[inside] - lo), vals[inside])
        acc = np.cumsum(rows[:, :width], axis=1)
        acc[0] += before[lo:hi]
        _accumulate_rows(acc)
        post = acc[at]
        post += g.log_prior[lo:hi]
        return g.summarise(post, lo, n_after[at])

    def _window(self, before: F64, after: F64, n_first: float, n_last: float) -> tuple[int, int]:
        """Grid range outside which every point is negligible throughout a block, from the
        grid log-likelihood before and after it (see the module docstring)."""
        g = self.grid
        low = after + g.log_prior
        low -= 0.5 * (g.survival(np.array([n_last]))[0] / g.life_std) ** 2
        high = before + g.log_prior
        high -= 0.5 * (g.survival(np.array([n_first]))[0] / g.life_std) ** 2
        keep = np.flatnonzero(high >= low.max() - NEGLIGIBLE_LOG)
        return int(keep[0]), int(keep[-1]) + 1

    @staticmethod
    def _put(out: F64, rows: NDArray[np.intp], at: NDArray[np.intp], res: Summary | None) -> None:
        if res is not None and at.size:
            out[:, np.searchsorted(rows, at)] = np.stack(res)


def _accumulate_rows(acc: F64) -> None:
    """Cumulative sum over the rows (events) of ``acc``, in place. numpy's cumsum along
    the first axis runs one column at a time; for wide windows, adding whole rows is
    several times faster (the same additions in the same order)."""
    if acc.shape[1] <= 96:
        np.cumsum(acc, axis=0, out=acc)
        return
    for i in range(1, acc.shape[0]):
        acc[i] += acc[i - 1]
