"""What a predictor reads and gives (docs/results/prognostics.md): an :class:`EventBatch` of one
pad's braking events, named like the event-log columns (docs/schema.md), so a
predictor written against logs runs unchanged online; the :class:`RULEstimate` after each
of them; and :class:`RULPredictor`, the protocol any estimator follows. The fleets
(:mod:`.fleet`) and the predictor base class (:mod:`.protocol`) build on these.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass, fields
from typing import Any, Protocol, Self, runtime_checkable

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from brake_env.data.schema import TRUTH
from brake_env.model.streams import SENSOR_CHANNELS

__all__ = ["F64", "MEASURED", "TRUTH", "EventBatch", "RULEstimate", "RULPredictor", "iter_runs"]

F64 = NDArray[np.float64]

# Measured channels of an event, in the order the environment observes them.
MEASURED = SENSOR_CHANNELS


@dataclass(frozen=True, eq=False)
class EventBatch:
    """Consecutive braking events of one pad, oldest first.

    Attributes:
        event: Index of each event since the pad was installed, 0-based [-].
        speed_kmh, mass_kg, slope_rad, energy_j, temp_c, stop_dist_m: Measured channels,
            in the units of the event-log schema.
        volume_frac, wear_coeff, rul_events: Ground truth (simulated data only), else None.
    """

    event: NDArray[np.int64]
    speed_kmh: F64
    mass_kg: F64
    slope_rad: F64
    energy_j: F64
    temp_c: F64
    stop_dist_m: F64
    volume_frac: F64 | None = None
    wear_coeff: F64 | None = None
    rul_events: NDArray[np.int64] | None = None

    def __post_init__(self) -> None:
        n = len(self.event)
        for f in fields(self):
            x = getattr(self, f.name)
            if x is not None and len(x) != n:
                raise ValueError(f"EventBatch.{f.name} has {len(x)} values, event has {n}")

    def __len__(self) -> int:
        return len(self.event)

    def __eq__(self, other: object) -> bool:
        """Same events, value for value (env checkers compare infos for determinism)."""
        if not isinstance(other, EventBatch):
            return NotImplemented
        pairs = ((getattr(self, f.name), getattr(other, f.name)) for f in fields(self))
        return all(
            (a is None and b is None) or (a is not None and b is not None and np.array_equal(a, b))
            for a, b in pairs
        )

    __hash__ = None  # type: ignore[assignment]  # mutable arrays inside

    @property
    def has_truth(self) -> bool:
        return self.rul_events is not None

    def __getitem__(self, sl: slice) -> EventBatch:
        parts: dict[str, Any] = {f.name: getattr(self, f.name) for f in fields(self)}
        sliced: dict[str, Any] = {k: None if v is None else v[sl] for k, v in parts.items()}
        return EventBatch(**sliced)

    @classmethod
    def from_arrays(cls, arrays: Mapping[str, np.ndarray]) -> EventBatch:
        """From a mapping of column name to array (the env's ``info["events"]``)."""
        missing = [k for k in ("event", *MEASURED) if k not in arrays]
        if missing:
            raise KeyError(f"EventBatch: missing array(s) {missing}")
        kw: dict[str, Any] = {k: np.asarray(arrays[k], dtype=np.float64) for k in MEASURED}
        kw.update((k, np.asarray(arrays[k])) for k in TRUTH if arrays.get(k) is not None)
        return cls(event=np.asarray(arrays["event"], dtype=np.int64), **kw)

    @classmethod
    def from_frame(cls, df: pd.DataFrame) -> EventBatch:
        """From the rows of one run of a validated event log (:func:`read_event_log`)."""
        if "run_id" in df and df["run_id"].nunique() > 1:
            raise ValueError("EventBatch.from_frame takes one run; split the log by run_id")
        cols = {k: df[k].to_numpy() for k in ("event", *MEASURED, *TRUTH) if k in df}
        return cls.from_arrays(cols)


def iter_runs(log: pd.DataFrame) -> Iterator[tuple[str, EventBatch]]:
    """(run_id, events) of every run of an event log, in order of first appearance."""
    codes, names = pd.factorize(log["run_id"], sort=False)
    order = np.argsort(codes, kind="stable")
    bounds = np.searchsorted(codes[order], np.arange(len(names) + 1))
    for i, name in enumerate(names):
        rows = order[bounds[i] : bounds[i + 1]]
        yield str(name), EventBatch.from_frame(log.iloc[rows].drop(columns="run_id"))


@dataclass(frozen=True, eq=False)
class RULEstimate:
    """A predictor's estimate after each event of a batch.

    Attributes:
        rul_mean: Expected remaining useful life, in braking events, after each event.
        rul_lower, rul_upper: Bounds of a predictive interval (see the predictor for its
            level), or None.
        volume_frac: Estimated pad volume fraction after each event, or None.
        wear_coeff: Estimated Archard coefficient K after each event, or None.
    """

    rul_mean: F64
    rul_lower: F64 | None = None
    rul_upper: F64 | None = None
    volume_frac: F64 | None = None
    wear_coeff: F64 | None = None

    def __len__(self) -> int:
        return len(self.rul_mean)

    @property
    def latest(self) -> float:
        """The estimate after the batch's last event."""
        return float(self.rul_mean[-1])

    def to_frame(self) -> pd.DataFrame:
        return pd.DataFrame(
            {
                f.name: getattr(self, f.name)
                for f in fields(self)
                if getattr(self, f.name) is not None
            }
        )


@runtime_checkable
class RULPredictor(Protocol):
    """Anything that estimates RUL from braking events (docs/results/prognostics.md)."""

    @property
    def name(self) -> str: ...

    def fit(self, train_log: pd.DataFrame) -> Self: ...

    def reset(self) -> None: ...

    def update(self, events: EventBatch) -> RULEstimate: ...
