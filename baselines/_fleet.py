"""The bookkeeping the baselines' vectorised fleets share (README "Prognostics").

:class:`SlotFleet` checks a fleet update the way :meth:`Predictor.update` checks one pad's
batch (the first batch after a reset starts at any event, later ones continue where the
previous one ended), all slots at once, before any state changes; subclasses compute the
estimates of all pads together in ``_update``.
"""

from __future__ import annotations

from abc import abstractmethod
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from brake_env.prognostics.fleet import Fleet, last_rows, slot_runs
from brake_env.prognostics.protocol import EventBatch, RULEstimate


class SlotFleet(Fleet):
    """A fleet whose pads' carried state lives in arrays indexed by slot.

    Args:
        name: The predictor's name, for messages.
        n_pads: Number of slots.
    """

    def __init__(self, name: str, n_pads: int) -> None:
        super().__init__(n_pads)
        self.name = name
        self._next_event = np.full(n_pads, -1, dtype=np.int64)  # -1: a new pad

    def reset(self, pads: ArrayLike) -> None:
        idx = self._slots(np.atleast_1d(np.asarray(pads)))
        self._next_event[idx] = -1
        self._reset_slots(idx)

    def update(
        self,
        pads: NDArray[np.intp],
        events: EventBatch,
        summarise: NDArray[np.bool_] | None = None,
    ) -> RULEstimate:
        pads = self._slots(np.asarray(pads))
        if len(pads) != len(events):
            raise ValueError(f"{self.name}: {len(pads)} slots for {len(events)} events")
        if len(pads) == 0:
            raise ValueError(f"{self.name}: update() needs at least one event")
        starts, slots = slot_runs(pads)
        if len(np.unique(slots)) != len(slots):
            raise ValueError(f"{self.name}: the rows of each slot must be contiguous")
        ends = np.append(starts[1:], len(pads))
        back = np.flatnonzero((np.diff(events.event) <= 0) & (pads[1:] == pads[:-1]))
        if back.size:
            i = int(back[0]) + 1
            raise ValueError(
                f"{self.name}: slot {int(pads[i])}'s events do not increase (event"
                f" {int(events.event[i])} after {int(events.event[i - 1])})"
            )
        first = events.event[starts]
        expected = self._next_event[slots]
        bad = np.flatnonzero((first < 0) | ((expected >= 0) & (first != expected)))
        if bad.size:
            i = int(bad[0])
            raise ValueError(
                f"{self.name}: slot {int(slots[i])}'s batch starts at event {int(first[i])},"
                f" expected {int(expected[i]) if expected[i] >= 0 else '>= 0'} (reset a slot"
                " when its pad is installed)"
            )
        if summarise is None:
            want = last_rows(pads)
        else:
            want = np.asarray(summarise, dtype=bool)
            if want.shape != pads.shape:
                raise ValueError(f"{self.name}: summarise has {want.size} rows, not {len(pads)}")
        est = self._update(pads, events, want, starts, slots)
        self._next_event[slots] = events.event[ends - 1] + 1
        return est

    def _slots(self, pads: NDArray[Any]) -> NDArray[np.intp]:
        if pads.size and pads.dtype.kind not in "iu":
            raise ValueError(f"{self.name}: slots must be ints, got {pads.dtype}")
        idx = pads.astype(np.intp)
        bad = np.unique(idx[(idx < 0) | (idx >= self.n_pads)])
        if bad.size:
            raise ValueError(f"{self.name}: slots must be in [0, {self.n_pads}), got {bad[:5]}")
        return idx

    def _reset_slots(self, pads: NDArray[np.intp]) -> None:
        """Forget the carried state of ``pads`` (stateless predictors carry none)."""

    @abstractmethod
    def _update(
        self,
        pads: NDArray[np.intp],
        events: EventBatch,
        want: NDArray[np.bool_],
        starts: NDArray[np.intp],
        slots: NDArray[np.intp],
    ) -> RULEstimate:
        """Estimates at the rows ``want``, in row order; ``starts``/``slots`` give each
        slot's run of rows."""
