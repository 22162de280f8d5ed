"""Small validators for frozen configuration dataclasses: one clear error per bad field."""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Iterable, Mapping
from typing import Any, TypeVar

import numpy as np

T = TypeVar("T")


def is_number(value: object) -> bool:
    """Whether ``value`` is a real number: a Python int or float or a numpy integer or
    floating scalar (``np.float32`` is no ``float`` subclass), never a bool of either kind."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool | np.bool_)


def plain_numbers(obj: object) -> None:
    """Store the numpy scalar fields of the frozen dataclass ``obj`` as the Python int,
    float or bool they hold, so a config takes ``np.float32(600)`` wherever it takes
    ``600.0`` and still compares, hashes and saves to JSON as one made of Python numbers.
    Called first in ``__post_init__``; the checks then see Python values only."""
    for f in dataclasses.fields(obj):  # type: ignore[arg-type]
        value = getattr(obj, f.name)
        if isinstance(value, np.integer | np.floating | np.bool_):
            object.__setattr__(obj, f.name, value.item())


def _value(obj: object, name: str) -> float:
    value = getattr(obj, name)
    if not is_number(value):
        raise TypeError(f"{type(obj).__name__}.{name} must be a number, got {value!r}")
    return float(value)


def whole(who: str, name: str, value: Any, lo: int, hi: int | None = None) -> int:
    """Argument ``name`` of ``who`` as an int in [``lo``, ``hi``]: a Python or numpy
    integer (never a bool, a float such as 1.5 or NaN); else one ValueError naming both."""
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Integral):
        raise ValueError(f"{who}: {name} must be an integer, got {value!r}")
    n = int(value)
    if n < lo or (hi is not None and n > hi):
        span = f">= {lo}" if hi is None else f"in [{lo}, {hi}]"
        raise ValueError(f"{who}: {name} must be an integer {span}, got {n}")
    return n


def real(
    who: str, name: str, value: Any, lo: float | None = None, hi: float | None = None,
    *, infinite: bool = False,
) -> float:  # fmt: skip
    """Argument ``name`` of ``who`` as a float, never NaN, finite unless ``infinite``, in
    [``lo``, ``hi``]; else one ValueError naming both."""
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real):
        raise ValueError(f"{who}: {name} must be a number, got {value!r}")
    x = float(value)
    if math.isnan(x) or (not infinite and math.isinf(x)):
        raise ValueError(f"{who}: {name} must be a finite number, got {value}")
    if (lo is not None and x < lo) or (hi is not None and x > hi):
        span = " and ".join(s for s in (f">= {lo}" * (lo is not None),
                                         f"<= {hi}" * (hi is not None)) if s)  # fmt: skip
        raise ValueError(f"{who}: {name} must be {span}, got {value}")
    return x


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


def check_state(
    who: str,
    meta: Mapping[str, Any],
    arrays: Mapping[str, Any],
    *,
    meta_keys: Iterable[str] = (),
    optional_meta: Iterable[str] = (),
    array_keys: Iterable[str] = (),
    optional_arrays: Iterable[str] = (),
    finite: Iterable[str] = (),
) -> None:
    """A saved predictor state (``get_state``'s settings and arrays) against the
    predictor's own schema, before anything is restored: one ``ValueError`` naming the field.

    Args:
        who: The predictor's name, for the message.
        meta, arrays: The saved settings and arrays.
        meta_keys, optional_meta: Settings that must / may be there; any other is refused.
        array_keys, optional_arrays: The same for arrays.
        finite: Settings or arrays that must hold finite numbers where present (a number,
            a list of numbers or a numeric array; None passes for an optional setting).
    """
    _check_keys(who, "setting", meta, set(meta_keys), set(optional_meta))
    _check_keys(who, "array", arrays, set(array_keys), set(optional_arrays))
    for name in finite:
        where = arrays if name in arrays else meta
        if name not in where or where[name] is None:
            continue
        try:
            x = np.asarray(where[name], dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError(
                f"{who}: saved {'array' if where is arrays else 'setting'} {name!r} is not"
                f" numeric ({type(where[name]).__name__}); the model is damaged: refit it"
            ) from None
        bad = int(np.size(x) - np.isfinite(x).sum())
        if bad:
            raise ValueError(
                f"{who}: saved {'array' if where is arrays else 'setting'} {name!r} holds"
                f" {bad} non-finite value(s) of {np.size(x)}; the model is damaged: refit it"
            )


def _check_keys(
    who: str, kind: str, got: Mapping[str, Any], required: set[str], optional: set[str]
) -> None:
    missing = sorted(required - set(got))
    unknown = sorted(set(got) - required - optional)
    if missing or unknown:
        parts = ([f"lacks {missing}"] if missing else []) + (
            [f"has unknown {unknown}"] if unknown else []
        )
        raise ValueError(
            f"{who}: saved {kind}s: the state {' and '.join(parts)}; a {who} state has {kind}s"
            f" {sorted(required | optional)} (a model of another predictor, or an edited one?)"
        )


class UnknownArgumentError(TypeError, ValueError):
    """An env keyword that does not exist. A ``TypeError``, as Python raises for an
    unexpected keyword, so clients that probe optional keywords and retry without them on a
    ``TypeError`` (TorchRL's ``GymEnv`` passes ``frameskip``) work; a ``ValueError`` as
    before, for callers that catch bad arguments as one kind."""


def check_keywords(env_id: str, kwargs: Mapping[str, Any], names: Iterable[str]) -> None:
    """Refuse keyword arguments of ``env_id`` that are not among ``names``, naming them."""
    valid = sorted(names)
    unknown = sorted(set(kwargs) - set(valid))
    if unknown:
        raise UnknownArgumentError(
            f"{env_id}: got an unexpected keyword argument {unknown[0]!r} (unknown"
            f" argument(s) {unknown}; valid are {valid})"
        )
