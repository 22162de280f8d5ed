"""The fleet's transition rules, each written once, over a batch of fleet states.

Per-vehicle arrays have shape ``(batch, n_vehicles)`` and fleet arrays ``(batch,)``; the env
calls every function on a batch of one (:mod:`.shop`, :mod:`.rules`), the planning model
(:mod:`agents.fleet.policies.planning`) on its sampled futures, the rules and the policies'
masks on one observation or many. A model that differs from the env on purpose (the bound's
relaxed capacity, the reference's and the planner's expected wear) says so in its own
docstring; what it shares, it takes from here. ``docs/fleet_model.md`` lists, per rule, who
calls what.

- **Needs**: ``hot_need`` vehicles on the ramp and ``mild_need`` on the drifts each working
  shift (none at a window); a ramp truck beyond its need covers a drift.
- **Driving ban**: a vehicle down in the shop or at a window cannot drive.
- **Capacity**: requests for new pads are admitted one by one in a given order. Each needs a
  spare in stock; at a window one of the crew's ``window_slots``; between windows a vehicle
  not already down needs a free bay (``bays`` less the vehicles down). One that finds no room
  is deferred, the reason ``crew`` or ``bay`` before ``spare``.
- **Shop time**: at a shift's end a vehicle that was down has one shift fewer to go; a failed
  vehicle waiting for a spare stays down. A failure sends the vehicle down for
  ``failure_repair_shifts`` and waits for a spare (the waiting get spares in vehicle order);
  a vehicle that drove and did not fail breaks down when its uniform is below
  ``breakdown_rate``, down ``breakdown_repair_shifts``.
- **Spares**: an order arrives at the start of the shift ``lead_time`` after it was placed;
  (s, S) orders up to ``S`` when stock + in transit - fits sent now is below ``s``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from brake_env.env.fleet.config import FleetConfig

HOT, MILD, PARK, SERVICE = 0, 1, 2, 3
ADMITTED, SPARE, CREW, BAY = 0, 1, 2, 3  # why a request was deferred (0: it was not)
REASONS = ("", "spare", "crew", "bay")
I64 = NDArray[np.int64]
F64 = NDArray[np.float64]
B = NDArray[np.bool_]


# ---------------------------------------------------------------- needs
def needs(config: FleetConfig, window: bool) -> tuple[int, int]:
    """(hot need, working need: hot + mild) of a shift; none at a window."""
    return (0, 0) if window else (config.hot_need, config.hot_need + config.mild_need)


def shortfall(config: FleetConfig, on_hot: ArrayLike, on_mild: ArrayLike, window: bool
              ) -> tuple[I64, I64]:  # fmt: skip
    """Vehicles short of the hot need and of the mild need, per state."""
    hot, mild = np.asarray(on_hot, dtype=np.int64), np.asarray(on_mild, dtype=np.int64)
    if window:
        return np.zeros_like(hot), np.zeros_like(mild)
    extra = np.maximum(hot - config.hot_need, 0)
    return (np.maximum(config.hot_need - hot, 0),
            np.maximum(config.mild_need - mild - extra, 0))  # fmt: skip


def shortfall_cost(config: FleetConfig, on_hot: ArrayLike, on_mild: ArrayLike, window: bool
                   ) -> F64:  # fmt: skip
    """What each state's shortfall costs (``shortfall`` and ``mild_shortfall`` terms)."""
    hot, mild = shortfall(config, on_hot, on_mild, window)
    return config.costs.shortfall * hot + config.costs.mild_shortfall * mild


def fill_needs(config: FleetConfig, order: I64, able: B, duty: I64) -> tuple[B, B]:
    """The ``able`` vehicles, in ``order`` (each row a permutation of the vehicles, most
    wanted on the ramp first), fill the hot need, then the mild need, in place in ``duty``
    (the others keep theirs); returns the vehicles sent to each."""
    rows = np.arange(order.shape[0])[:, None]
    rank = np.empty(order.shape, dtype=np.int64)
    rank[rows, order] = np.cumsum(able[rows, order], axis=-1) - 1  # place among the able
    hot_need, work = config.hot_need, config.hot_need + config.mild_need
    hot = able & (rank < hot_need)
    drift = able & (rank >= hot_need) & (rank < work)
    duty[drift] = MILD
    duty[hot] = HOT
    return hot, drift


# ---------------------------------------------------------------- driving and the workshop
def can_drive(down: ArrayLike, window: bool) -> B:
    """Vehicles that may take a route: not down in the shop, not at a window."""
    return ~np.asarray(down, dtype=bool) & (not window)


def free_bays(bays: int, down: ArrayLike) -> I64:
    """Of the workshop's ``bays``, those left for visits after the vehicles down (``down``:
    shifts left in the shop, or whether down)."""
    return np.maximum(bays - (np.asarray(down) > 0).sum(axis=-1), 0)


def service_allowed(down: ArrayLike, window: bool, stock: ArrayLike, free: ArrayLike) -> B:
    """Whether each vehicle's request would be admitted were it the only one (the mask's
    service column): a spare and, between windows, a free bay or the vehicle down."""
    d = np.asarray(down, dtype=bool)
    room = d | window | (np.asarray(free) > 0)[..., None]
    return (np.asarray(stock) > 0)[..., None] & room


def admit(
    config: FleetConfig, asks: B, order: I64, *, down: ArrayLike, window: bool,
    stock: ArrayLike, free: ArrayLike,
) -> tuple[B, I64]:  # fmt: skip
    """Serve the requests ``asks`` one by one in ``order`` (rows: permutations of the
    vehicles) within each state's ``stock``, crew slots (at a window) and ``free`` bays
    (module docstring). Returns (admitted, why each request was deferred: :data:`REASONS`
    index, 0 where admitted or not asked)."""
    asks = np.asarray(asks, dtype=bool)
    rows = np.arange(asks.shape[0])
    d_all = np.broadcast_to(np.asarray(down, dtype=bool), asks.shape)
    fit, why = np.zeros_like(asks), np.zeros(asks.shape, dtype=np.int64)
    left = np.broadcast_to(np.asarray(stock, dtype=np.int64), rows.shape).copy()
    room_left = np.full(rows.shape, config.window_slots, dtype=np.int64)
    if not window:
        room_left = np.broadcast_to(np.asarray(free, dtype=np.int64), rows.shape).copy()
    ranked = np.take_along_axis(asks, order, axis=-1)
    for k in np.flatnonzero(ranked.any(axis=0)):  # the places where someone asks
        v, ask = order[:, k], ranked[:, k]
        needs_room = ~d_all[rows, v] | window  # a vehicle down needs no bay
        room = ~needs_room | (room_left > 0)
        ok = ask & room & (left > 0)
        why[rows, v] = np.where(ask & ~room, CREW if window else BAY, np.where(ask & ~ok, SPARE, 0))
        fit[rows, v] = ok
        left -= ok
        room_left -= ok & needs_room
    return fit, why


def within_capacity(
    config: FleetConfig, fits: B, *, down: ArrayLike, window: bool, stock: ArrayLike,
    free: ArrayLike,
) -> B:  # fmt: skip
    """Whether every fit of ``fits`` is admitted (in any order), per state."""
    fits = np.asarray(fits, dtype=bool)
    order = np.broadcast_to(np.arange(fits.shape[-1]), fits.shape)
    got, _ = admit(config, fits, order, down=down, window=window, stock=stock, free=free)
    return np.asarray((got == fits).all(axis=-1))


def workshop_order(age: ArrayLike, down: ArrayLike, window: bool) -> I64:
    """The workshop's order of service: the requests that need no bay (down, or at a
    window) first, then the most events since installation, then the vehicle index."""
    a = np.atleast_2d(np.asarray(age))
    first = np.broadcast_to(np.asarray(down, dtype=bool) | window, a.shape)
    index = np.broadcast_to(np.arange(a.shape[-1]), a.shape)
    return np.lexsort((index, -a, ~first), axis=-1)


def fit_waiting(waiting: B, stock: ArrayLike) -> B:
    """The failed vehicles waiting for a spare that get one, in vehicle order."""
    return waiting & (np.cumsum(waiting, axis=-1) <= np.asarray(stock)[..., None])


def fail(config: FleetConfig, down: I64, failed_down: B, waiting: B, failed: B) -> None:
    """Brake failures, in place: down for ``failure_repair_shifts``, waiting for a spare."""
    down[failed] = config.failure_repair_shifts
    failed_down[failed] = True
    waiting |= failed


def breaks(config: FleetConfig, drove: B, failed: B, uniform: F64) -> B:
    """Vehicles that drove, did not fail and break down (``uniform`` below the rate)."""
    return drove & ~failed & (uniform < config.breakdown_rate)


def break_down(config: FleetConfig, down: I64, failed_down: B, broke: B) -> None:
    """Other breakdowns, in place: down for ``breakdown_repair_shifts``."""
    down[broke] = config.breakdown_repair_shifts
    failed_down[broke] = False


def end_shift(down: I64, waiting: B, new_down: B) -> I64:
    """Shifts left in the shop after the shift: one fewer for the vehicles that were down
    during it (not those sent down at its end); a failed vehicle waiting stays down."""
    was = (down > 0) & ~new_down
    left = np.where(was, down - 1, down)
    return np.where(was & waiting, np.maximum(left, 1), left)


# ---------------------------------------------------------------- spares
def place_order(transit: I64, quantity: int | I64) -> None:
    """An order placed this shift, in place: it arrives ``lead_time`` shifts on."""
    transit[..., -1] += quantity


def receive(transit: I64) -> tuple[I64, I64]:
    """The start of a shift: (pads arriving now, the arrivals of the next shifts)."""
    rest = np.concatenate([transit[..., 1:], np.zeros_like(transit[..., :1])], axis=-1)
    return transit[..., 0].copy(), rest


def reorder(stock: Any, transit: Any, fits: Any, s: Any, S: Any, max_order: int) -> Any:
    """(s, S): when stock + in transit - fits sent now is below ``s``, order up to ``S``
    (at most ``max_order``); else nothing. Elementwise over arrays."""
    position = np.asarray(stock) + np.asarray(transit) - np.asarray(fits)
    up_to = np.minimum(np.maximum(S - position, 0), max_order)
    return np.where(position >= s, 0, up_to).astype(np.int64)
