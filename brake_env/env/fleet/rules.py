"""The fleet's rules on one state: what a shift's production needs and what falls short of
it, what the window's crew, the bays and the spares can take, and which actions a vehicle
may take. Each is :mod:`.model`'s (the rules over a batch of states) on a batch of one, for
the callers that hold one state (the reference, agents rebuilding the mask from the
observation); none retypes them.

- **Production**: ``hot_need`` vehicles on the hot route and ``mild_need`` on the mild one
  each working shift (none at a window); a vehicle on the hot route beyond its need covers
  a drift (a ramp truck can muck one), so it counts towards the mild need.
- **Capacity**: at a window the crew fits at most ``window_slots`` pad sets; between
  windows an unscheduled visit needs a free bay (a vehicle already down in the shop needs
  none); every fit needs a spare in stock.
- **Mask**: a vehicle down or at a window cannot drive; service needs a spare and, for a
  visit, a free bay; every reorder quantity is allowed. Limits across vehicles (two
  requests, one bay) are left to the workshop's deferral rule (:mod:`.shop`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from brake_env.env.fleet import model
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.shop import HOT, MILD, PARK, SERVICE

I64 = NDArray[np.int64]
B = NDArray[np.bool_]


def shortfall(config: FleetConfig, on_hot: int, on_mild: int, window: bool) -> tuple[int, int]:
    """Vehicles short of the hot need and of the mild need in a shift
    (:func:`.model.shortfall` on one state)."""
    hot, mild = model.shortfall(config, on_hot, on_mild, window)
    return int(hot), int(mild)


def shortfall_cost(config: FleetConfig, on_hot: int, on_mild: int, window: bool) -> float:
    """What the shift's shortfall costs (``shortfall`` and ``mild_shortfall`` terms)."""
    return float(model.shortfall_cost(config, on_hot, on_mild, window))


def fill_needs(config: FleetConfig, order: I64, duty: I64) -> tuple[I64, I64]:
    """Vehicles ``order`` (able to drive, most wanted on the ramp first) fill the hot need,
    then the mild need, in place in ``duty`` (the others keep theirs); returns the vehicles
    sent to each, in ``order`` (:func:`.model.fill_needs` on one state)."""
    able = np.zeros(len(duty), dtype=bool)
    able[order] = True
    ranked = np.concatenate([order, np.flatnonzero(~able)])
    hot, drift = model.fill_needs(config, ranked[None], able[None], duty[None])
    return order[hot[0][order]], order[drift[0][order]]


def fits_capacity(
    config: FleetConfig, window: bool, fits: B, down: B, stock: int, free_bays: int
) -> bool:
    """Whether the pad fits ``fits`` are within the spares, the window's crew (at a window)
    and the free bays (visits of vehicles not down, between windows)."""
    ok = model.within_capacity(config, np.asarray(fits)[None], down=down, window=window,
                               stock=stock, free=free_bays)  # fmt: skip
    return bool(ok[0])


def action_mask(
    down: B, window: bool, stock: int, free_bays: int, max_order: int
) -> NDArray[np.bool_]:
    """Flat mask of length ``4 * n_vehicles + max_order + 1`` (sb3-contrib MaskablePPO):
    the rule of the module docstring, from what the observation shows."""
    n = len(down)
    m = np.ones((n, 4), dtype=bool)
    m[:, [HOT, MILD]] = model.can_drive(down, window)[:, None]
    m[:, PARK] = True
    m[:, SERVICE] = model.service_allowed(down, window, stock, free_bays)
    return np.concatenate([m.ravel(), np.ones(max_order + 1, dtype=bool)])
