"""Checks of the numeric inputs of the bound, the planner and the price-directed policy,
where they enter (issue 44): one ValueError naming the argument and the value given, before
any work or large allocation (the numbers' checks, :func:`whole` and :func:`real`, are
:mod:`brake_env._validate`'s)."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from brake_env._validate import real, whole

GIB = 2**30
MAX_BYTES = 4 * GIB  # the largest array set a bound or a planner may allocate
__all__ = [
    "GIB", "MAX_BYTES", "bound_inputs", "finite_array", "fits_memory", "program_fits", "real",
    "same_config", "whole",
]  # fmt: skip


def finite_array(who: str, name: str, x: Any, shape: tuple[int, ...]) -> NDArray[np.float64]:
    """``x`` as a float array of ``shape``, every value finite."""
    a = np.asarray(x, dtype=np.float64)
    if a.shape != shape:
        raise ValueError(f"{who}: {name} has shape {a.shape}, expected {shape}")
    bad = np.flatnonzero(~np.isfinite(a.ravel()))
    if bad.size:
        i = np.unravel_index(int(bad[0]), shape)
        raise ValueError(f"{who}: {name} must be finite, got {a[i]} at index {tuple(map(int, i))}")
    return a


def fits_memory(who: str, nbytes: float, what: str, fix: str) -> None:
    """Refuse a computation that would allocate more than :data:`MAX_BYTES`."""
    if nbytes > MAX_BYTES:
        raise ValueError(
            f"{who}: {what} would allocate {nbytes / GIB:.1f} GiB (more than"
            f" {MAX_BYTES / GIB:.0f} GiB); {fix}"
        )


def same_config(who: str, built: Any, acting: Any) -> None:
    """Refuse a policy built for one fleet config driving an env of another."""
    if built != acting:
        n, m = getattr(built, "n_vehicles", "?"), getattr(acting, "n_vehicles", "?")
        raise ValueError(
            f"{who}: built for another fleet config ({n} vehicles) than the env it acts on"
            f" ({m} vehicles); build it from the env's config"
        )


def program_fits(config: Any, H: int, units: int) -> None:
    """Refuse a bound whose program (:func:`~.lagrangian.solve`: values and policy per
    shift, state and shop state, and one shift's actions) would not fit in memory, before
    it allocates."""
    D = max(config.failure_repair_shifts, config.breakdown_repair_shifts) + 1
    T = config.episode_shifts
    nbytes = (T + 1) * (H + 1) * D * 8 + T * (H + 1) * D + 4 * (H + 1) * D * 8
    fits_memory(
        "BoundModel", nbytes, f"the program of {T} shifts x {H + 1} states (units={units})",
        "use fewer units per hot shift (units) or shorter episodes",
    )  # fmt: skip


def bound_inputs(who: str, model: Any, prices: Any = None, start: Any = None) -> None:
    """Raise unless ``prices`` (per shift, finite) and ``start`` (counts per state, finite,
    >= 0) fit the :class:`~.lagrangian.BoundModel` ``model``, and its program fits in
    memory."""
    program_fits(model.config, model.H, model.units)
    T = model.config.episode_shifts
    for name in ("hot", "work", "bay", "crew") if prices is not None else ():
        finite_array(who, f"prices.{name}", getattr(prices, name), (T,))
    if start is not None:
        s = finite_array(who, "start", start, (model.H + 1,))
        if (s < 0).any():
            raise ValueError(f"{who}: start must be counts >= 0, got {s.min()}")
