"""Many pads through one predictor at once (docs/results/prognostics.md).

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
import itertools
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from dataclasses import fields
from typing import Any, TypeVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from brake_env.prognostics.events import EventBatch, RULEstimate, RULPredictor

ESTIMATE_FIELDS = ("rul_mean", "rul_lower", "rul_upper", "volume_frac", "wear_coeff")
CALL_ROWS = 1 << 18  # rows per fleet update in predict_runs: bounds memory, paces progress


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


def concat_events(parts: Sequence[EventBatch]) -> EventBatch:
    """Events of several batches (of any pads), one after the other; a truth column only
    when every part has it."""
    kw: dict[str, Any] = {}
    for f in fields(EventBatch):
        xs = [getattr(p, f.name) for p in parts]
        kw[f.name] = None if any(x is None for x in xs) else np.concatenate(xs)
    return EventBatch(**kw)


def take_events(events: EventBatch, rows: NDArray[np.intp]) -> EventBatch:
    """The events at ``rows`` (indices); a view when they are contiguous and increasing."""
    if rows.size and rows[-1] - rows[0] + 1 == rows.size and np.all(np.diff(rows) == 1):
        return events[int(rows[0]) : int(rows[-1]) + 1]
    kw: dict[str, Any] = {f.name: getattr(events, f.name) for f in fields(EventBatch)}
    taken: dict[str, Any] = {k: None if v is None else v[rows] for k, v in kw.items()}
    return EventBatch(**taken)


_Method = TypeVar("_Method", bound=Callable[..., Any])


def loops_pads(fleet_method: _Method) -> _Method:
    """Marks a ``fleet`` method that loops over copies of the predictor (:class:`LoopFleet`,
    the base class's default), so that :func:`vectorises` tells it from a fleet of its own."""
    fleet_method.loops_pads = True  # type: ignore[attr-defined]
    return fleet_method


def vectorises(predictor: RULPredictor) -> bool:
    """Whether ``predictor`` has a fleet of its own (not the per-slot copies of
    :class:`LoopFleet`)."""
    own = getattr(type(predictor), "fleet", None)
    return own is not None and not getattr(own, "loops_pads", False)


def predict_runs(
    predictor: RULPredictor,
    runs: Sequence[EventBatch],
    batch_events: int = 0,
    progress: Callable[[int], object] | None = None,
) -> list[RULEstimate]:
    """Estimates at every event of each run, each run a new pad (evaluation, logs).

    A predictor with a fleet of its own takes all runs through one fleet, ``CALL_ROWS``
    rows per update (``batch_events`` > 0: that many events of every run per update, the
    runs interleaved); any other runs pad by pad (``reset``, then ``update`` with batches
    of ``batch_events``, 0: the whole run), without copies of itself.

    Args:
        predictor: A fitted predictor.
        runs: The events of each run, from any event of the pad on.
        batch_events: Events of a run per update; 0 for as many as fit a call.
        progress: Called with the number of events after each update.
    """
    if batch_events < 0:
        raise ValueError(f"predict_runs: batch_events must be >= 0, got {batch_events}")
    if not vectorises(predictor):
        return [_one_pad(predictor, ev, batch_events, progress) for ev in runs]
    sizes = np.array([len(ev) for ev in runs], dtype=np.intp)
    starts = np.r_[0, np.cumsum(sizes)]
    events = concat_events(runs)
    pads = np.repeat(np.arange(len(runs), dtype=np.intp), sizes)
    pos = np.arange(len(pads)) - starts[pads]  # row within its run
    if batch_events:  # round r: the r-th batch of every run, runs in order
        order = np.lexsort((pads, pos // batch_events))
        calls = np.searchsorted(
            pos[order] // batch_events, np.arange(pos.max() // batch_events + 2)
        )
    else:
        order = np.arange(len(pads))
        calls = np.r_[np.arange(0, len(pads), CALL_ROWS), len(pads)]
    fleet = predictor.fleet(len(runs))  # type: ignore[attr-defined]
    parts = []
    for a, b in itertools.pairwise(calls):
        if b > a:
            rows = order[a:b]
            parts.append(fleet.update(pads[rows], take_events(events, rows), np.ones(b - a, bool)))
            if progress:
                progress(int(b - a))
    est = concat(parts)
    back = np.empty_like(order)
    back[order] = np.arange(len(order))
    return [select(est, back[a:b]) for a, b in itertools.pairwise(starts)]


def one_per_event(est: RULEstimate, n_events: int, predictor: object) -> RULEstimate:
    """``est``, checked to hold one estimate per event of the batch ``predictor`` was given
    (a predictor that is no :class:`Predictor` is not checked by one): else one ValueError
    naming the predictor and both counts."""
    if len(est) != n_events:
        name = getattr(predictor, "name", type(predictor).__name__)
        raise ValueError(
            f"{name}: update gave {len(est)} estimates for {n_events} events (a predictor"
            " gives one estimate after each event)"
        )
    return est


def _one_pad(
    predictor: RULPredictor, ev: EventBatch, batch: int, progress: Callable[[int], object] | None
) -> RULEstimate:
    predictor.reset()
    step = batch or len(ev)
    parts = []
    for i in range(0, len(ev), step):
        part = ev[i : i + step]
        parts.append(one_per_event(predictor.update(part), len(part), predictor))
        if progress:
            progress(len(parts[-1]))
    return parts[0] if len(parts) == 1 else concat(parts)


class LoopFleet(Fleet):
    """The reference fleet: one copy of the fitted predictor per slot, updated in turn."""

    def __init__(self, predictor: RULPredictor, n_pads: int) -> None:
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
        if len(pads) == 0:
            raise ValueError("Fleet.update: needs at least one event")
        want = last_rows(pads) if summarise is None else np.asarray(summarise, dtype=bool)
        starts, slots = slot_runs(pads)
        ends = np.append(starts[1:], len(pads))
        parts = []
        for a, b, slot in zip(starts, ends, slots, strict=True):
            pad = self._pads[int(slot)]
            est = one_per_event(pad.update(events[int(a) : int(b)]), int(b - a), pad)
            parts.append(select(est, want[a:b]))
        return concat(parts)


class SlotFleet(Fleet):
    """A fleet whose pads' carried state lives in arrays indexed by slot.

    ``update`` checks a fleet update the way :meth:`Predictor.update` checks one pad's batch
    (the first batch after a reset starts at any event, later ones after the previous one
    ended, with or without a gap), all slots at once and before any state changes;
    subclasses compute the estimates of all pads together in ``_update``.

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
        # A batch may start after its slot's next event (a gap: events braked, not logged;
        # protocol module docstring, "Gaps"), never before it.
        bad = np.flatnonzero((first < 0) | ((expected >= 0) & (first < expected)))
        if bad.size:
            i = int(bad[0])
            raise ValueError(
                f"{self.name}: slot {int(slots[i])}'s batch starts at event {int(first[i])},"
                f" expected {'>= ' + str(int(expected[i])) if expected[i] >= 0 else '>= 0'}"
                " (reset a slot when its pad is installed)"
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


class RowFleet(SlotFleet):
    """The fleet of a predictor whose estimate at an event depends on that event alone (it
    carries nothing from one event to the next): one call over the wanted rows of all pads.

    Args:
        name: The predictor's name.
        n_pads: Slots.
        estimate: ``estimate(events, want)``: the estimates at the rows ``want`` of ``events``.
    """

    def __init__(
        self,
        name: str,
        n_pads: int,
        estimate: Callable[[EventBatch, NDArray[np.bool_]], RULEstimate],
    ) -> None:
        super().__init__(name, n_pads)
        self._estimate = estimate

    def _update(
        self,
        pads: NDArray[np.intp],
        events: EventBatch,
        want: NDArray[np.bool_],
        starts: NDArray[np.intp],
        slots: NDArray[np.intp],
    ) -> RULEstimate:
        return self._estimate(events, want)
