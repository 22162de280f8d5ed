"""Non-RL rules for BrakeWearFleet-v0, with SB3's ``predict`` signature.

One rule, :class:`FleetRule`, has a part for each decision, and each heuristic of issue 20 is
a setting of it (the constructors below), so that their best combination is the same rule
with every part free. All limits are RUL in shifts of hot duty (:mod:`.view`).

- **Service** (per vehicle): replace when the RUL is below ``must`` anywhere (an unscheduled
  visit between windows); below ``window_limit`` at a scheduled window (labour and pad
  only); below ``shop_limit`` while the vehicle is in the shop anyway (labour and pad only).
  The per-vehicle threshold is one limit for all three (it ignores windows); the
  time-to-window control limit sets ``window_limit`` to the shifts to the next window plus
  a margin; the (n, N) opportunistic limits (Wijnmalen and Hontelez, EJOR 1997) are
  ``must = N`` and ``window_limit = shop_limit = n``.
- **Capacity** (``greedy``): requests are served lowest RUL first within the spares in
  stock and, at a window, the crew's slots, or, for visits, the free bays; the others are
  not sent (so not deferred, and they drive last). Without it every request goes to the
  workshop, whose own rule serves by pad age and defers the rest (the vehicle then loses
  the shift).
- **Duty**: the vehicles able to drive fill the hot need, then the mild need, in vehicle
  order (``roster``), healthiest first (``rul``: the vehicles with the least RUL take
  the mild route, and the spare duty if any), or ``due-first``: a pad that will be
  replaced at the next window anyway (its RUL there, after hot shifts until then, below
  the window limit, but still above ``must``) takes the ramp first, since the life it
  would keep on the mild route is thrown away at the window, and the others are spared
  its wear; then healthiest first; a due pad filling the mild need is sent up the ramp
  too (a ramp truck covers a drift). The others take ``spare_duty``, the mild route or
  parked.
- **Reorder** (s, S): when the inventory position (stock + in transit - fits sent now)
  is below ``s``, order up to ``S`` (at most ``max_order``).

Every action respects the env's :meth:`action_masks` (rebuilt from the observation).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, Literal, Protocol

import numpy as np
from numpy.typing import NDArray

from agents.fleet.policies.base import FleetPolicy
from agents.fleet.policies.view import FleetLayout, FleetView
from brake_env.env.fleet.rules import fill_needs, room_for
from brake_env.env.fleet.shop import HOT, MILD, PARK, SERVICE
from brake_env.env.fleet.spares import reorder  # the rule's one home, re-exported here

I64 = NDArray[np.int64]
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


class FleetRule(FleetPolicy):
    """A fleet rule (module docstring): one observation or a batch in, actions out.

    Args:
        layout: Where the rule finds things in the observation.
        params: Its parts.
        name: Shown in tables.
    """

    def __init__(self, layout: FleetLayout, params: FleetRuleParams, name: str = "rule") -> None:
        self.layout, self.params, self.name = layout, params, name

    def action(self, observation: NDArray[Any]) -> I64:
        return self.act(FleetView.read(observation, self.layout))

    def act(self, view: FleetView) -> I64:
        """The action (duties, then the order) for one observation."""
        service, unserved = self._service(view)
        duty = self._duties(view, service, unserved)
        return np.append(duty, self._order(view, int(service.sum()))).astype(np.int64)

    def _service(self, view: FleetView) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
        """(vehicles sent to service, vehicles that wanted it but were not sent)."""
        allowed = view.mask(self.layout.max_order)[: 4 * len(view.rul)].reshape(-1, 4)
        want = (view.rul < self.params.limits(view)) & allowed[:, SERVICE]
        if not self.params.greedy:
            return want, np.zeros_like(want)
        send = np.zeros_like(want)
        config = self.layout.config
        stock, bays, slots = view.stock, view.free_bays, config.window_slots
        for v in np.flatnonzero(want)[np.argsort(view.rul[want], kind="stable")]:
            if stock > 0 and room_for(config, view.window, bool(view.down[v]), slots, bays):
                send[v], stock = True, stock - 1
                slots -= int(view.window)
                bays -= int(not (view.window or view.down[v]))
        return send, want & ~send

    def _duties(
        self, view: FleetView, service: NDArray[np.bool_], unserved: NDArray[np.bool_]
    ) -> I64:
        n = len(view.rul)
        duty = np.full(n, PARK, dtype=np.int64)
        duty[service] = SERVICE
        if view.window:
            return duty
        able = ~view.down & ~service
        # Sort key: hot goes to the first of the able (vehicle order or most RUL); vehicles
        # that wanted a service and were not sent go last.
        key = -view.rul if self.params.duty != "roster" else np.arange(n, dtype=np.float64)
        if self.params.duty == "due-first":
            key = np.where(self._due(view), key - 1e9, key)
        key = np.where(unserved, np.inf, key)
        order = np.flatnonzero(able)[np.argsort(key[able], kind="stable")]
        duty[order] = SPARE_DUTIES[self.params.spare_duty]
        _, drift = fill_needs(self.layout.config, order, duty)
        if self.params.duty == "due-first":  # a due pad covers a drift from the ramp
            duty[drift[self._due(view)[drift]]] = HOT
        return duty

    def _due(self, view: FleetView) -> NDArray[np.bool_]:
        """Pads that, driven on the ramp until the next window, are replaced there and
        still above ``must`` when they get there."""
        p = self.params
        at_window = view.rul - view.to_window
        win = p.must if p.window_limit is None else p.window_limit
        return (at_window < win) & (at_window > p.must)

    def _order(self, view: FleetView, fits: int) -> int:
        p = self.params
        return reorder(view.stock, view.transit, fits, p.s, p.S, self.layout.max_order)

    def __repr__(self) -> str:
        return f"FleetRule({self.name}, {self.params})"


# ---------------------------------------------------------------- the heuristics of issue 20
def threshold_rule(layout: FleetLayout, threshold: float, s: int = 2, S: int = 4) -> FleetRule:
    """Per-vehicle RUL threshold: replace below ``threshold`` wherever (ignores windows)."""
    p = FleetRuleParams(must=threshold, window_limit=threshold, shop_limit=threshold, s=s, S=S)
    return FleetRule(layout, p, "threshold")


def window_rule(
    layout: FleetLayout, window_period: int, margin: float, must: float = 1.0,
    s: int = 2, S: int = 4,
) -> FleetRule:  # fmt: skip
    """Time-to-window control limit: at a window replace a pad whose RUL will not last to
    the next window (``window_period - 1`` working shifts) plus ``margin``; between windows
    only below ``must`` (it would fail before the window)."""
    p = FleetRuleParams(must=must, window_limit=window_period - 1 + margin, s=s, S=S)
    return FleetRule(layout, p, "time-to-window")


def opportunistic_rule(
    layout: FleetLayout, n: float, N: float, s: int = 2, S: int = 4
) -> FleetRule:
    """(n, N) opportunistic control limits: must-do below N anywhere, can-do below n (>= N)
    when the vehicle is in the shop or at a window."""
    p = FleetRuleParams(must=N, window_limit=max(n, N), shop_limit=max(n, N), s=s, S=S)
    return FleetRule(layout, p, "(n, N)")


def with_parts(rule: FleetRule, name: str, **parts: Any) -> FleetRule:
    """``rule`` with some parts changed (greedy capacity, duty rule, (s, S)...)."""
    return FleetRule(rule.layout, dataclasses.replace(rule.params, **parts), name)
