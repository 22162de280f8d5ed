"""Ground truth that is simulated only when it is read (BrakeWear-v0 with ``truth``).

The true RUL of a pad needs its life simulated ahead to failure (~1e5 events). Paying that
at every installation made the default env crawl under random exploration (a replacement
every other step). Here the truth is promised, not computed: the first read of a pad's
``rul_events`` (in ``info["truth"]``, in the step's events, or a retired pad's
``life_left``) simulates that pad ahead, on a copy of its stream, exactly as installation
did before; nothing else changes, and an env that never reads the truth never pays it.

Copying is not reading: ``copy.deepcopy`` (SB3's ``DummyVecEnv`` deep-copies every step's
infos), ``copy.copy`` and pickling (``SubprocVecEnv``, Ray, saving rollouts) keep the truth
pending, so a copy costs what the step's events cost; the copy's truth, when read, is
simulated then and equals the original's. An object already read is copied with its values.

Each takes ``life``: a callable returning the pad's events to failure (``PadLife.n_events``,
cached by the pad), so this module needs nothing of the pad but that. A deep copy shares
it; a pickle pickles it (:class:`brake_env.env.pad_life.LifeOf` pickles the pad's seeds,
not the pad).
"""

from __future__ import annotations

import copy
from collections.abc import Callable, ItemsView, Iterator, ValuesView
from typing import Any

import numpy as np
from numpy.typing import NDArray

from brake_env.prognostics.protocol import EventBatch

Life = Callable[[], int]
_LAZY_KEYS = ("rul_events", "life_events")


class PendingRULEvents(EventBatch):
    """Events whose ``rul_events`` column is computed the first time it is read."""

    @classmethod
    def of(cls, cols: dict[str, Any], life: Life, start: int) -> PendingRULEvents:
        """Events ``cols`` (every column but ``rul_events``) of a pad, from event ``start``."""
        obj = object.__new__(cls)
        for k, v in cols.items():
            object.__setattr__(obj, k, v)
        object.__setattr__(obj, "_life", life)
        object.__setattr__(obj, "_start", start)
        object.__setattr__(obj, "_rul", None)
        return obj

    @property
    def rul_events(self) -> NDArray[np.int64]:
        rul: NDArray[np.int64] | None = self.__dict__["_rul"]
        if rul is None:
            life, a = self.__dict__["_life"](), self.__dict__["_start"]
            rul = np.arange(life - 1 - a, life - 1 - a - len(self.event), -1)
            object.__setattr__(self, "_rul", rul)
        return rul

    def __getitem__(self, sl: slice) -> EventBatch:
        """A slice stays pending (a wrapper slicing the step's events asks for nothing)."""
        start, _, step = sl.indices(len(self.event))
        if step != 1 or self.__dict__["_rul"] is not None:
            return super().__getitem__(sl)
        names = ("event", "speed_kmh", "mass_kg", "slope_rad", "energy_j", "temp_c")
        cols = {k: getattr(self, k)[sl] for k in (*names, "stop_dist_m")}
        cols.update((k, getattr(self, k)[sl]) for k in ("volume_frac", "wear_coeff"))
        return PendingRULEvents.of(cols, self.__dict__["_life"], self.__dict__["_start"] + start)

    def __deepcopy__(self, memo: dict[int, Any]) -> EventBatch:
        """A deep copy of the events, still pending (sharing ``life``, not calling it); a
        plain EventBatch once read."""
        if self.__dict__["_rul"] is not None:
            fields = EventBatch.__dataclass_fields__
            return _plain_batch({k: copy.deepcopy(getattr(self, k), memo) for k in fields})
        new = object.__new__(type(self))
        for k, v in self.__dict__.items():
            object.__setattr__(new, k, v if k == "_life" else copy.deepcopy(v, memo))
        return new

    def __reduce__(self) -> tuple[Any, ...]:
        """Pickled pending (``life`` pickled, not called); as a plain EventBatch once read."""
        if self.__dict__["_rul"] is not None:
            cols = {k: getattr(self, k) for k in EventBatch.__dataclass_fields__}
            return (_plain_batch, (cols,))
        cols = {k: v for k, v in self.__dict__.items() if not k.startswith("_")}
        return (PendingRULEvents.of, (cols, self.__dict__["_life"], self.__dict__["_start"]))


def _plain_batch(cols: dict[str, Any]) -> EventBatch:
    return EventBatch(**cols)


class LazyTruth(dict[str, Any]):
    """``info["truth"]``: ``rul_events`` and ``life_events`` filled in when first read (by
    key, ``get``, iteration, ``items``, ``values``, comparison or ``repr``); ``copy()``,
    ``copy.deepcopy`` and pickling keep them pending.

    Args:
        values: Every key, those two set to None until read.
        life: The pad's events to failure.
        pos: Events the pad had completed at the step.
    """

    def __init__(self, values: dict[str, Any], life: Life, pos: int) -> None:
        super().__init__(values)
        self._life: Life | None = life
        self._pos = pos

    def _resolve(self) -> None:
        if self._life is not None:
            life = self._life()
            super().__setitem__("rul_events", life - self._pos)
            super().__setitem__("life_events", life)
            self._life = None  # resolved; the pad may go

    def __getitem__(self, key: str) -> Any:
        if key in _LAZY_KEYS:
            self._resolve()
        return super().__getitem__(key)

    def get(self, key: str, default: Any = None) -> Any:
        return self[key] if key in self else default  # noqa: SIM401 (self.get is this)

    def __iter__(self) -> Iterator[str]:  # also keeps {**truth} and dict(truth) honest
        self._resolve()
        return super().__iter__()

    def items(self) -> ItemsView[str, Any]:  # type: ignore[override]
        self._resolve()
        return super().items()

    def values(self) -> ValuesView[Any]:  # type: ignore[override]
        self._resolve()
        return super().values()

    def __eq__(self, other: object) -> bool:
        self._resolve()
        if isinstance(other, LazyTruth):
            other._resolve()
        return super().__eq__(other)

    __hash__ = None

    def __repr__(self) -> str:
        self._resolve()
        return super().__repr__()

    def copy(self) -> dict[str, Any]:
        """A shallow copy, pending while this one is (sharing ``life``)."""
        if self._life is None:
            return dict(super().items())
        return LazyTruth(dict(super().items()), self._life, self._pos)

    def __deepcopy__(self, memo: dict[int, Any]) -> dict[str, Any]:
        values = {k: copy.deepcopy(v, memo) for k, v in super().items()}
        return values if self._life is None else LazyTruth(values, self._life, self._pos)

    def __reduce__(self) -> tuple[Any, ...]:
        """Pickled pending (``life`` pickled, not called); as a plain dict once read."""
        if self._life is None:
            return (dict, (dict(super().items()),))
        return (LazyTruth, (dict(super().items()), self._life, self._pos))
