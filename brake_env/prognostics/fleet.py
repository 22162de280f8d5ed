"""Many pads through one predictor at once (README "Prognostics").

A :class:`Fleet` holds the per-pad state of one fitted predictor for ``n_pads`` slots (the
sub-environments of a vector env, the runs of a log, the pads of a cost study). One
``update`` takes the events of several pads concatenated, so a predictor can vectorise over
pads, and summarises only the rows an estimate is asked for (by default each pad's last
event: a decision point).

The contract, checked by tests for every predictor: the estimates of a fleet equal those of
the single-pad predictor (``reset`` then ``update`` per pad) at the same events.
"""

from __future__ import annotations

import copy
from abc import ABC, abstractmethod
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from brake_env.prognostics.protocol import EventBatch, RULEstimate

if TYPE_CHECKING:
    from brake_env.prognostics.protocol import Predictor

ESTIMATE_FIELDS = ("rul_mean", "rul_lower", "rul_upper", "volume_frac", "wear_coeff")


class Fleet(ABC):
    """Per-pad state of one fitted predictor for ``n_pads`` slots.

    Args:
        n_pads: Number of slots; a slot holds one installed pad at a time.
    """

    def __init__(self, n_pads: int) -> None:
        if n_pads < 1:
            raise ValueError(f"Fleet: n_pads must be >= 1, got {n_pads}")
        self.n_pads = n_pads

    @abstractmethod
    def reset(self, pads: ArrayLike) -> None:
        """New pads are installed in slots ``pads``."""

    @abstractmethod
    def update(
        self,
        pads: NDArray[np.intp],
        events: EventBatch,
        summarise: NDArray[np.bool_] | None = None,
    ) -> RULEstimate:
        """Take the next events of several pads.

        Args:
            pads: Slot of each row of ``events``; the rows of one slot are contiguous and in
                event order, and continue that slot's previous rows.
            events: The events of those pads, concatenated.
            summarise: Rows at which an estimate is wanted; default each slot's last row.

        Returns:
            Estimates at the summarised rows, in row order.
        """


def last_rows(pads: NDArray[np.intp]) -> NDArray[np.bool_]:
    """True at the last row of each run of equal slots (each pad's latest event)."""
    out = np.ones(len(pads), dtype=bool)
    out[:-1] = pads[1:] != pads[:-1]
    return out


def slot_runs(pads: NDArray[np.intp]) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """(start row, slot) of each run of equal slots in ``pads``."""
    starts = np.flatnonzero(np.r_[True, pads[1:] != pads[:-1]]) if len(pads) else np.array([])
    return starts.astype(np.intp), pads[starts].astype(np.intp)


def select(est: RULEstimate, rows: NDArray[np.bool_] | NDArray[np.intp]) -> RULEstimate:
    """The estimate at ``rows`` (a mask or indices) of ``est``."""
    kw: dict[str, Any] = {
        f: None if getattr(est, f) is None else getattr(est, f)[rows] for f in ESTIMATE_FIELDS
    }
    return RULEstimate(**kw)


def concat(parts: list[RULEstimate]) -> RULEstimate:
    """Estimates of several batches, one after the other."""
    kw: dict[str, Any] = {}
    for f in ESTIMATE_FIELDS:
        xs = [getattr(p, f) for p in parts]
        kw[f] = None if any(x is None for x in xs) else np.concatenate(xs)
    return RULEstimate(**kw)


class LoopFleet(Fleet):
    """The reference fleet: one copy of the fitted predictor per slot, updated in turn."""

    def __init__(self, predictor: Predictor, n_pads: int) -> None:
        super().__init__(n_pads)
        self._pads = [copy.deepcopy(predictor) for _ in range(n_pads)]
        for p in self._pads:
            p.reset()

    def reset(self, pads: ArrayLike) -> None:
        for i in np.atleast_1d(np.asarray(pads, dtype=np.intp)):
            self._pads[int(i)].reset()

    def update(
        self,
        pads: NDArray[np.intp],
        events: EventBatch,
        summarise: NDArray[np.bool_] | None = None,
    ) -> RULEstimate:
        pads = np.asarray(pads, dtype=np.intp)
        if len(pads) != len(events):
            raise ValueError(f"Fleet.update: {len(pads)} slots for {len(events)} events")
        want = last_rows(pads) if summarise is None else np.asarray(summarise, dtype=bool)
        starts, slots = slot_runs(pads)
        ends = np.append(starts[1:], len(pads))
        parts = []
        for a, b, slot in zip(starts, ends, slots, strict=True):
            est = self._pads[int(slot)].update(events[int(a) : int(b)])
            parts.append(select(est, want[a:b]))
        return concat(parts)
