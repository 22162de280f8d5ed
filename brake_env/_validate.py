"""Small validators for frozen configuration dataclasses: one clear error per bad field."""

from __future__ import annotations

import dataclasses
import math
from typing import Any, TypeVar

T = TypeVar("T")


def _value(obj: object, name: str) -> float:
    value = getattr(obj, name)
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise TypeError(f"{type(obj).__name__}.{name} must be a number, got {value!r}")
    return float(value)


def check_finite(obj: object, *names: str) -> None:
    for name in names:
        if not math.isfinite(_value(obj, name)):
            raise ValueError(
                f"{type(obj).__name__}.{name} must be finite, got {getattr(obj, name)}"
            )


def check_positive(obj: object, *names: str) -> None:
    for name in names:
        v = _value(obj, name)
        if not (math.isfinite(v) and v > 0):
            raise ValueError(f"{type(obj).__name__}.{name} must be > 0, got {getattr(obj, name)}")


def check_nonnegative(obj: object, *names: str) -> None:
    for name in names:
        v = _value(obj, name)
        if not (math.isfinite(v) and v >= 0):
            raise ValueError(f"{type(obj).__name__}.{name} must be >= 0, got {getattr(obj, name)}")


def check_range(obj: object, name: str, lo: float, hi: float) -> None:
    v = _value(obj, name)
    if not (lo <= v <= hi):
        raise ValueError(f"{type(obj).__name__}.{name} must be in [{lo}, {hi}], got {v}")


def from_dict(cls: type[T], data: dict[str, Any]) -> T:
    """Build dataclass ``cls`` from ``data``, rejecting unknown keys by name."""
    fields = {f.name for f in dataclasses.fields(cls)}  # type: ignore[arg-type]
    unknown = sorted(set(data) - fields)
    if unknown:
        raise ValueError(
            f"{cls.__name__}: unknown parameter(s) {unknown}; valid are {sorted(fields)}"
        )
    return cls(**data)
