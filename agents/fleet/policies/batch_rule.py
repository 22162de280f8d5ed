""":class:`~agents.fleet.policies.rules.FleetRule`'s decisions, written once, over a batch of
fleet states: its parts (:class:`FleetRuleParams`) and :func:`act`. ``FleetRule.act`` is
:func:`act` on a batch of one; a look-ahead planner runs it in thousands of sampled futures a
shift at once. The fleet's limits are the env's (:mod:`brake_env.env.fleet.model`): the
mask's service column, the admission of requests within stock, crew and bays, the filling of
the needs and the (s, S) reorder; the loop over the vehicles is the admission's only.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, Protocol

import numpy as np
from numpy.typing import NDArray

from brake_env.env.fleet import model
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.model import HOT, MILD, PARK, SERVICE

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]
B = NDArray[np.bool_]
DUTIES = ("roster", "rul", "due-first")
SPARE_DUTIES = {"mild": MILD, "park": PARK}


class ShopState(Protocol):
    """What the replacement limits read: who is in the shop, and whether it is a window."""

    @property
    def down(self) -> NDArray[np.bool_]: ...

    @property
    def window(self) -> bool: ...


@dataclass(frozen=True)
class FleetRuleParams:
    """The parts of :class:`FleetRule` (limits in shifts of hot duty).

    Attributes:
        must: Replace anywhere (an unscheduled visit between windows) below this RUL.
        window_limit: Replace at a window below this RUL (None: ``must``).
        shop_limit: Replace while in the shop below this RUL (None: ``must``).
        greedy: Capacity-aware: serve lowest RUL first within stock and bays.
        duty: ``roster`` (vehicle order), ``rul`` (healthiest on the hot route) or
            ``due-first`` (pads due at the next window on the hot route first).
        spare_duty: Duty of the able vehicles not needed on the hot route.
        s: Reorder point: order when the inventory position is below it.
        S: Order-up-to level (>= s).
    """

    must: float = 2.0
    window_limit: float | None = None
    shop_limit: float | None = None
    greedy: bool = False
    duty: Literal["roster", "rul"] = "roster"
    spare_duty: Literal["mild", "park"] = "mild"
    s: int = 2
    S: int = 4

    def __post_init__(self) -> None:
        for name in ("must", "window_limit", "shop_limit"):
            v = getattr(self, name)
            if v is not None and not np.isfinite(v):
                raise ValueError(f"FleetRuleParams: {name} must be finite, got {v}")
        if self.duty not in DUTIES:
            raise ValueError(f"FleetRuleParams: duty must be one of {DUTIES}, got {self.duty!r}")
        if self.spare_duty not in SPARE_DUTIES:
            raise ValueError(
                f"FleetRuleParams: spare_duty must be one of {list(SPARE_DUTIES)},"
                f" got {self.spare_duty!r}"
            )
        if not 0 <= self.s <= self.S:
            raise ValueError(f"FleetRuleParams: need 0 <= s <= S, got s={self.s}, S={self.S}")

    def limits(self, view: ShopState) -> NDArray[np.float64]:
        """Each vehicle's replacement limit this shift (one state, or a batch of them:
        ``view.down`` of any shape)."""
        shop = self.must if self.shop_limit is None else max(self.must, self.shop_limit)
        limit = np.where(view.down, shop, self.must)
        if view.window:
            win = self.must if self.window_limit is None else self.window_limit
            limit = np.maximum(limit, win)
        return limit


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
    """The rule's duties (batch, n) and orders (batch,) (``FleetRule``'s module docstring)."""
    allowed = model.service_allowed(v.down, v.window, v.stock, v.free_bays)
    want = (v.rul < p.limits(v)) & allowed
    send, unserved = _greedy(config, v, want) if p.greedy else (want, np.zeros_like(want))
    duty = _duties(p, config, v, send, unserved)
    order = model.reorder(v.stock, v.transit, send.sum(axis=1), p.s, p.S, config.max_order)
    return duty, order


def _greedy(config: FleetConfig, v: BatchView, want: B) -> tuple[B, B]:
    """Lowest RUL first within stock, crew slots (window) and bays (visits)."""
    order = np.argsort(np.where(want, v.rul, np.inf), axis=1, kind="stable")
    send, _ = model.admit(config, want, order, down=v.down, window=v.window, stock=v.stock,
                          free=v.free_bays)  # fmt: skip
    return send, want & ~send


def due(p: FleetRuleParams, v: BatchView) -> B:
    """Pads that, driven on the ramp until the next window, are replaced there and still
    above ``must`` when they get there."""
    at_window = v.rul - v.to_window
    win = p.must if p.window_limit is None else p.window_limit
    return (at_window < win) & (at_window > p.must)


def _duties(p: FleetRuleParams, config: FleetConfig, v: BatchView, send: B, unserved: B) -> I64:
    n = v.rul.shape[1]
    duty = np.where(send, SERVICE, PARK).astype(np.int64)
    if v.window:
        return duty
    able = model.can_drive(v.down, v.window) & ~send
    # Sort key: hot goes to the first of the able (vehicle order or most RUL); vehicles
    # that wanted a service and were not sent go last.
    key = -v.rul if p.duty != "roster" else np.broadcast_to(np.arange(n, dtype=float), v.rul.shape)
    is_due = due(p, v) if p.duty == "due-first" else None
    if is_due is not None:
        key = np.where(is_due, key - 1e9, key)
    key = np.where(unserved, np.inf, key)
    order = np.argsort(np.where(able, key, np.nan), axis=1, kind="stable")  # nan: last
    duty = np.where(able, SPARE_DUTIES[p.spare_duty], duty)
    _, drift = model.fill_needs(config, order, able, duty)
    if is_due is not None:  # a due pad covers a drift from the ramp
        duty = np.where(drift & is_due, HOT, duty)
    return duty
