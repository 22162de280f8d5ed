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
from collections.abc import Callable, ItemsView, Iterator, KeysView, ValuesView
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


class _PendingDict(dict[str, Any]):
    """A dict whose ``_LAZY_KEYS`` are filled in by ``_resolve`` when first read (by key,
    ``in``, ``get``, iteration, ``keys``, ``items``, ``values``, comparison or ``repr``)."""

    def _resolve(self) -> None:
        raise NotImplementedError

    @property
    def pending(self) -> bool:
        """Its truth is not read yet."""
        raise NotImplementedError

    def __getitem__(self, key: str) -> Any:
        if key in _LAZY_KEYS:
            self._resolve()
        return super().__getitem__(key)

    def __contains__(self, key: object) -> bool:
        if key in _LAZY_KEYS:
            self._resolve()
        return super().__contains__(key)

    def get(self, key: str, default: Any = None) -> Any:
        return self[key] if key in self else default  # noqa: SIM401 (self.get is this)

    def __iter__(self) -> Iterator[str]:  # also keeps {**truth} and dict(truth) honest
        self._resolve()
        return super().__iter__()

    def keys(self) -> KeysView[str]:  # type: ignore[override]
        self._resolve()
        return super().keys()

    def items(self) -> ItemsView[str, Any]:  # type: ignore[override]
        self._resolve()
        return super().items()

    def values(self) -> ValuesView[Any]:  # type: ignore[override]
        self._resolve()
        return super().values()

    def __eq__(self, other: object) -> bool:
        self._resolve()
        if isinstance(other, _PendingDict):
            other._resolve()
        return super().__eq__(other)

    __hash__ = None

    def __repr__(self) -> str:
        self._resolve()
        return super().__repr__()

    def _known(self) -> dict[str, Any]:
        """Its values so far, nothing read."""
        return dict(super().items())


class LazyTruth(_PendingDict):
    """``info["truth"]``: ``rul_events`` and ``life_events`` filled in when first read;
    ``copy()``, ``copy.deepcopy`` and pickling keep them pending.

    Args:
        values: Every key, those two set to None until read.
        life: The pad's events to failure.
        pos: Events the pad had completed at the step.
    """

    def __init__(self, values: dict[str, Any], life: Life, pos: int) -> None:
        super().__init__(values)
        self._life: Life | None = life
        self._pos = pos

    @property
    def pending(self) -> bool:
        return self._life is not None

    def _resolve(self) -> None:
        if self._life is not None:
            life = self._life()
            dict.__setitem__(self, "rul_events", life - self._pos)
            dict.__setitem__(self, "life_events", life)
            self._life = None  # resolved; the pad may go

    def __contains__(self, key: object) -> bool:
        return dict.__contains__(self, key)  # its keys are all there, pending or not

    def known(self) -> dict[str, Any]:
        """Every key but the two pending ones (all of them once read), nothing read."""
        if self._life is None:
            return self._known()
        return {k: v for k, v in self._known().items() if k not in _LAZY_KEYS}

    def copy(self) -> dict[str, Any]:
        """A shallow copy, pending while this one is (sharing ``life``)."""
        if self._life is None:
            return self._known()
        return LazyTruth(self._known(), self._life, self._pos)

    def __deepcopy__(self, memo: dict[int, Any]) -> dict[str, Any]:
        values = {k: copy.deepcopy(v, memo) for k, v in self._known().items()}
        return values if self._life is None else LazyTruth(values, self._life, self._pos)

    def __reduce__(self) -> tuple[Any, ...]:
        """Pickled pending (``life`` pickled, not called); as a plain dict once read."""
        if self._life is None:
            return (dict, (self._known(),))
        return (LazyTruth, (self._known(), self._life, self._pos))


class StackedTruth(_PendingDict):
    """``infos["truth"]`` of a Gymnasium vector env of BrakeWear-v0: Gymnasium's layout
    (each key an array over the sub-envs, with its ``_key`` mask), ``rul_events`` and
    ``life_events`` (and masks) filled in from the sub-envs' :class:`LazyTruth` when first
    read. Gymnasium's own stacking iterates each sub-env's truth, which would read it.

    Args:
        num_envs: Sub-environments.
        values: The keys stacked so far.
    """

    def __init__(self, num_envs: int, values: dict[str, Any] | None = None) -> None:
        super().__init__(values or {})
        self._n = num_envs
        self._pending: dict[int, dict[str, Any]] = {}

    @property
    def pending(self) -> bool:
        return bool(self._pending)

    def add(self, env_num: int, truth: dict[str, Any]) -> dict[str, Any]:
        """Sub-env ``env_num``'s truth, its ``rul_events`` and ``life_events`` stacked when
        read. Returns its other keys, for Gymnasium's stacking."""
        self._pending[env_num] = truth
        if isinstance(truth, LazyTruth):
            return {k: v for k, v in truth.known().items() if k not in _LAZY_KEYS}
        return {k: v for k, v in truth.items() if k not in _LAZY_KEYS}

    def _resolve(self) -> None:
        if not self._pending:
            return
        pending, self._pending = self._pending, {}
        for key in _LAZY_KEYS:
            values = self._known().get(key, np.zeros(self._n, dtype=np.int64))
            mask = self._known().get(f"_{key}", np.zeros(self._n, dtype=bool))
            for i, truth in pending.items():
                values[i], mask[i] = truth[key], True
            dict.__setitem__(self, key, values)
            dict.__setitem__(self, f"_{key}", mask)

    def __deepcopy__(self, memo: dict[int, Any]) -> StackedTruth:
        new = StackedTruth(self._n, copy.deepcopy(self._known(), memo))
        new._pending = {i: copy.deepcopy(t, memo) for i, t in self._pending.items()}
        return new

    def __reduce__(self) -> tuple[Any, ...]:
        """Pickled pending (each sub-env's ``life`` pickled, not called)."""
        return (_stacked_truth, (self._n, self._known(), self._pending))


def _stacked_truth(
    n: int, values: dict[str, Any], pending: dict[int, dict[str, Any]]
) -> StackedTruth:
    new = StackedTruth(n, values)
    new._pending = pending
    return new
