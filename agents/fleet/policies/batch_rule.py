""":class:`~agents.fleet.policies.rules.FleetRule` over a batch of fleet states at once: the
same decisions (tested equal to ``FleetRule.act`` on every state), vectorised over the
batch with a loop over the vehicles only where the rule is sequential (serving requests
within stock, slots and bays). A look-ahead planner runs the rule in thousands of sampled
futures a shift; one ``act`` per state would cost ~100x more.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from agents.fleet.policies.rules import SPARE_DUTIES, FleetRuleParams
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.shop import HOT, MILD, PARK, SERVICE

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]
B = NDArray[np.bool_]


@dataclass(frozen=True)
class BatchView:
    """What the rule reads, for a batch of states (:class:`~.view.FleetView`'s fields).

    Attributes:
        rul: RUL in shifts of hot duty, shape (batch, n).
        down: Whether each vehicle is in the shop, shape (batch, n).
        stock, transit, free_bays: Shape (batch,).
        to_window: Shifts to the next window (0: this shift is one); common to the batch.
    """

    rul: F64
    down: B
    stock: I64
    transit: I64
    free_bays: I64
    to_window: int

    @property
    def window(self) -> bool:
        return self.to_window == 0


def act(p: FleetRuleParams, config: FleetConfig, v: BatchView) -> tuple[I64, I64]:
    """The rule's duties (batch, n) and orders (batch,) (``FleetRule.act``)."""
    allowed = (v.stock > 0)[:, None] & (v.down | v.window | (v.free_bays > 0)[:, None])
    want = (v.rul < p.limits(v)) & allowed
    send, unserved = _greedy(config, v, want) if p.greedy else (want, np.zeros_like(want))
    duty = _duties(p, config, v, send, unserved)
    position = v.stock + v.transit - send.sum(axis=1)
    order = np.where(position >= p.s, 0, np.clip(p.S - position, 0, config.max_order))
    return duty, order.astype(np.int64)


def _greedy(config: FleetConfig, v: BatchView, want: B) -> tuple[B, B]:
    """Lowest RUL first within stock, crew slots (window) and bays (visits)."""
    rows = np.arange(len(v.stock))
    order = np.argsort(np.where(want, v.rul, np.inf), axis=1, kind="stable")
    send = np.zeros_like(want)
    stock, bays = v.stock.copy(), v.free_bays.copy()
    slots = np.full(len(stock), config.window_slots)
    for k in np.flatnonzero(np.take_along_axis(want, order, axis=1).any(axis=0)):
        u = order[:, k]
        down = v.down[rows, u]
        room = slots > 0 if v.window else down | (bays > 0)
        ok = want[rows, u] & (stock > 0) & room
        send[rows, u] = ok
        stock -= ok
        if v.window:
            slots -= ok
        else:
            bays -= ok & ~down
    return send, want & ~send


def due(p: FleetRuleParams, v: BatchView) -> B:
    """``FleetRule._due`` over the batch."""
    at_window = v.rul - v.to_window
    win = p.must if p.window_limit is None else p.window_limit
    return (at_window < win) & (at_window > p.must)


def _duties(p: FleetRuleParams, config: FleetConfig, v: BatchView, send: B, unserved: B) -> I64:
    n = v.rul.shape[1]
    duty = np.where(send, SERVICE, PARK).astype(np.int64)
    if v.window:
        return duty
    able = ~v.down & ~send
    key = -v.rul if p.duty != "roster" else np.broadcast_to(np.arange(n, dtype=float), v.rul.shape)
    is_due = due(p, v) if p.duty == "due-first" else None
    if is_due is not None:
        key = np.where(is_due, key - 1e9, key)
    key = np.where(unserved, np.inf, key)
    order = np.argsort(np.where(able, key, np.nan), axis=1, kind="stable")  # nan: last
    rank = np.empty_like(order)
    np.put_along_axis(rank, order, np.arange(n)[None, :].repeat(len(order), 0), axis=1)
    hot, mild = config.hot_need, config.hot_need + config.mild_need
    duty = np.where(able, SPARE_DUTIES[p.spare_duty], duty)
    drift = able & (rank >= hot) & (rank < mild)
    duty = np.where(drift, MILD, duty)
    duty = np.where(able & (rank < hot), HOT, duty)
    if is_due is not None:  # a due pad covers a drift from the ramp
        duty = np.where(drift & is_due, HOT, duty)
    return duty
