"""The predictor protocol (docs/results/prognostics.md) and the two predictors that need no model.

Every RUL predictor is fitted on training runs, reset when a pad is installed, and updated
with a batch of braking events of that pad. ``update`` returns one estimate *per event of
the batch* (the estimate after that event), so a predictor can be run event by event inside
the environment (batches of ``decision_interval`` events) or over a whole logged run at once
(one batch), with the same code and the same numbers.

Events travel as an :class:`EventBatch`: numpy arrays named like the event-log columns
(docs/schema.md), so a predictor written against logs runs unchanged online.
Ground-truth columns are present in simulated data and used only by :class:`Oracle`.

Gaps. ``event`` counts braking events since the pad was installed, and it may skip
indices (the schema allows it; real loggers drop events). Every predictor reads a gap the
same way: the missing events were braked but not logged, so the pad wore on through them.
Nothing was measured about them, so they are taken as drawn from the pad's operating mix:
each wears the expected amount per event for what the predictor believes about the pad
(the twin: the wear path ``K * n`` of each K of its posterior; the physics line: its fixed
rate; the window model and the MLP: the event index, which counts the gap). An estimate
after event ``n`` is the RUL counted from event ``n``, the last one logged, and it is
exactly the estimate the same predictor gives after ``n`` on the full log, except that the
evidence of the missing events is missing (the posterior is wider, the windows hold fewer
events). A gap longer than the life the predictor believes in gives RUL 0, not an error.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping
from typing import Any, ClassVar, Self

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from brake_env._validate import check_state
from brake_env.data.schema import FAILED
from brake_env.prognostics.events import (
    F64,
    MEASURED,
    TRUTH,
    EventBatch,
    RULEstimate,
    RULPredictor,
    iter_runs,
)
from brake_env.prognostics.fleet import Fleet, LoopFleet, loops_pads, predict_runs

# The event types live in .events; importing them from here keeps working.
__all__ = [
    "F64",
    "MEASURED",
    "TRUTH",
    "EventBatch",
    "NoPrognostics",
    "Oracle",
    "Predictor",
    "RULEstimate",
    "RULPredictor",
    "iter_runs",
    "predict_log",
]


class Predictor(ABC):
    """Base class implementing the protocol's bookkeeping; subclasses fill the hooks.

    ``update`` checks that the batch continues the current pad (event indices follow on
    from the previous batch) and that the estimate has one value per event, then calls
    ``_update``. ``fit`` takes a validated event log of run-to-failure training runs.

    Attributes:
        name: Short name used in tables and on the command line.
        interval_level: Nominal coverage of ``rul_lower``/``rul_upper``, or None when the
            predictor gives no interval.
        kept_by_evaluate: ``brakewear evaluate`` saves the fitted predictor as a model
            directory (one whose fit is costly or random, so its numbers can be reused).
    """

    name: ClassVar[str] = "predictor"
    interval_level: ClassVar[float | None] = None
    kept_by_evaluate: ClassVar[bool] = False

    def __init__(self) -> None:
        self._next_event: int | None = None  # None: a new pad, its first batch starts anywhere

    def fit(self, train_log: pd.DataFrame) -> Self:
        """Fit on training runs (an event log). Predictors without parameters do nothing."""
        self._fit(train_log)
        return self

    def reset(self) -> None:
        """A new pad is installed."""
        self._next_event = None
        self._reset()

    def update(self, events: EventBatch) -> RULEstimate:
        """Take the next events of the installed pad; estimates after each of them.

        ``event`` counts from the pad's installation, so the first batch after ``reset``
        may start anywhere: a log that starts mid-life (first row at event 30,000) means
        30,000 events nobody logged. Events may skip indices, within a batch or between
        batches: the skipped events were braked but not logged, and the pad wore on (the
        module docstring, "Gaps"). They never go back.
        """
        if len(events) == 0:
            raise ValueError(f"{self.name}: update() needs at least one event")
        first = int(events.event[0])
        if self._next_event is None:
            if first < 0:
                raise ValueError(f"{self.name}: event indices start at 0, got {first}")
        elif first < self._next_event:
            raise ValueError(
                f"{self.name}: batch starts at event {first}, but the previous batch ended at"
                f" event {self._next_event - 1} (call reset() when a pad is installed)"
            )
        if len(events) > 1 and np.any(np.diff(events.event) <= 0):
            i = int(np.flatnonzero(np.diff(events.event) <= 0)[0]) + 1
            raise ValueError(
                f"{self.name}: events must increase within a batch (event"
                f" {int(events.event[i])} after {int(events.event[i - 1])})"
            )
        est = self._update(events)
        if len(est) != len(events):
            raise RuntimeError(f"{self.name}: {len(est)} estimates for {len(events)} events")
        self._next_event = int(events.event[-1]) + 1
        return est

    @loops_pads
    def fleet(self, n_pads: int) -> Fleet:
        """State for ``n_pads`` pads updated together (see :mod:`.fleet`). The default runs
        a copy of this fitted predictor per pad; predictors override it to vectorise."""
        return LoopFleet(self, n_pads)

    def get_state(self) -> tuple[dict[str, Any], dict[str, NDArray[Any]]]:
        """What fitting learned: JSON-able settings and named numpy arrays, so a fitted
        predictor is saved without pickle (docs/results/prognostics.md)."""
        raise NotImplementedError(f"{self.name}: this predictor cannot be saved")

    def set_state(self, meta: Mapping[str, Any], arrays: Mapping[str, NDArray[Any]]) -> None:
        """Restore what :meth:`get_state` returned, on a predictor made by the same factory."""
        raise NotImplementedError(f"{self.name}: this predictor cannot be loaded")

    def fitted_wear_coeff(self) -> float | None:
        """The typical wear coefficient K fitting learned, for the plausibility check of
        fitted parameters (:func:`brake_env.data.plausibility.check_wear_coeff`); None when
        the predictor learns no K or is not fitted."""
        return None

    def self_check(self, log: pd.DataFrame) -> Mapping[str, Any] | None:
        """The fitted predictor's test of its own model on ``log`` (no truth read), or None
        when it has none. A mapping with at least ``warns`` (bool) and ``message`` (one
        line naming the size of the misfit and what to do): ``fit`` and ``predict`` print
        it, record it and refuse on it with ``--strict``. The twin's is :mod:`twin.misfit`."""
        return None

    def _fit(self, train_log: pd.DataFrame) -> None:  # noqa: B027 - optional hook
        pass

    def _reset(self) -> None:  # noqa: B027 - optional hook
        pass

    @abstractmethod
    def _update(self, events: EventBatch) -> RULEstimate: ...


class Oracle(Predictor):
    """The true RUL, read from the ground truth of the events: the comparison's bound."""

    name = "oracle"

    def get_state(self) -> tuple[dict[str, Any], dict[str, NDArray[Any]]]:
        return {}, {}  # nothing learned: it reads the truth

    def set_state(self, meta: Mapping[str, Any], arrays: Mapping[str, NDArray[Any]]) -> None:
        check_state("oracle", meta, arrays)  # nothing learned: nothing may be there

    def _update(self, events: EventBatch) -> RULEstimate:
        if events.rul_events is None:
            raise ValueError("oracle: the events carry no ground truth (rul_events)")
        return RULEstimate(
            rul_mean=events.rul_events.astype(np.float64),
            volume_frac=None if events.volume_frac is None else events.volume_frac.copy(),
            wear_coeff=None if events.wear_coeff is None else events.wear_coeff.copy(),
        )


class NoPrognostics(Predictor):
    """No condition information: always the mean life of a new pad from the training runs.

    With it, an agent knows only what the environment's event counter tells it, so it is
    the baseline every real predictor has to beat.

    Args:
        mean_life_events: The constant estimate; set by ``fit`` when not given.
    """

    name = "none"

    def __init__(self, mean_life_events: float | None = None) -> None:
        super().__init__()
        self.mean_life_events = mean_life_events

    def _fit(self, train_log: pd.DataFrame) -> None:
        # A life is the last event + 1 of a run that failed (events count from installation,
        # so a log that starts mid-life still gives the whole life); a run removed before
        # failure (``failed`` false on its last row) only bounds its life and is left out.
        runs = train_log.groupby("run_id", observed=True, sort=False)
        lives = runs["event"].max() + 1
        if FAILED in train_log:
            failed = runs[FAILED].last().astype(bool)
            if not failed.any():
                raise ValueError(
                    f"none: no training run ended at failure (runs {list(lives.index[:5])}"
                    " were all removed before it), so there is no life to average"
                )
            lives = lives[failed]
        self.mean_life_events = float(lives.mean())

    def get_state(self) -> tuple[dict[str, Any], dict[str, NDArray[Any]]]:
        return {"mean_life_events": self.mean_life_events}, {}

    def set_state(self, meta: Mapping[str, Any], arrays: Mapping[str, NDArray[Any]]) -> None:
        check_state("none", meta, arrays, meta_keys=["mean_life_events"])
        m = meta["mean_life_events"]
        # inf is a saved choice (a pad that never wears out); NaN or a word is damage.
        if m is not None and not (isinstance(m, int | float) and float(m) > 0):
            raise ValueError(f"none: saved setting 'mean_life_events' is {m!r}, not a life > 0")
        self.mean_life_events = None if m is None else float(m)

    def _update(self, events: EventBatch) -> RULEstimate:
        if self.mean_life_events is None:
            raise RuntimeError("none: call fit() or give mean_life_events")
        return RULEstimate(rul_mean=np.full(len(events), self.mean_life_events))


def predict_log(predictor: RULPredictor, log: pd.DataFrame, batch_events: int = 0) -> pd.DataFrame:
    """Run ``predictor`` over every run of an event log, each run a new pad.

    A predictor with a fleet of its own (:meth:`Predictor.fleet`) takes all runs together,
    with estimates at every event; any other is reset at each run and fed its events. The
    numbers are the same either way (the fleet contract).

    Args:
        predictor: A fitted predictor.
        log: A validated event log; each run is a pad, logged from installation or from
            any later event.
        batch_events: Events of a run per ``update`` call; 0 for as many as fit a call.

    Returns:
        One row per event, run by run in order of first appearance: ``run_id``, ``event``
        and the estimate's columns (``rul_mean`` and whichever optional ones it gives).
    """
    runs = list(iter_runs(log))
    parts = []
    for (run_id, events), est in zip(
        runs, predict_runs(predictor, [ev for _, ev in runs], batch_events), strict=True
    ):
        frame = est.to_frame()
        frame.insert(0, "event", events.event)
        frame.insert(0, "run_id", run_id)
        parts.append(frame)
    return pd.concat(parts, ignore_index=True)
