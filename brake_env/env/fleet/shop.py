"""The workshop and the spares of BrakeWearFleet-v0: who gets pads this shift, who waits.

Limits across vehicles (bays, spares) cannot be expressed by per-vehicle masks, so requests
beyond them follow one documented rule, and every request not served is reported:

1. At the start of a shift the orders due arrive. Vehicles down after a brake failure that
   are still waiting for a spare get one first (in vehicle order).
2. Service requests are then served in this order: at a window a replacement needs a
   spare and one of the crew's ``window_slots``; by a vehicle already in the shop between
   windows, only a spare; otherwise it is an unscheduled visit and needs a spare and a
   free bay (bays left after the vehicles down). Within each group the pads that have
   braked the most events since installation go first (the workshop sees the odometer;
   ties by vehicle index). A request that finds no spare, no slot or no bay is
   **deferred** (reason ``spare``, ``crew`` or ``bay``): the vehicle waits at the shop,
   parked for the shift, and must ask again.
3. A duty (hot or mild) given to a vehicle that cannot drive (down, or during a window) is
   **refused**: the vehicle is parked. Masks exclude these actions; the rule is for
   policies that do not honour masks (random exploration, ``check_env``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from brake_env.env.fleet import model
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.model import HOT, MILD, PARK, SERVICE

__all__ = ["ACTIONS", "HOT", "MILD", "PARK", "SERVICE", "Plan", "Workshop"]
ACTIONS = ("hot", "mild", "park", "service")
I64 = NDArray[np.int64]
B = NDArray[np.bool_]


@dataclass
class Plan:
    """The outcome of a shift's requests (vehicle masks and lists in the stated order).

    Attributes:
        route: Route each vehicle brakes on (0 hot, 1 mild), -1 if it does not drive.
        window_fit, shop_fit, visit: Replacements at the window, by a vehicle already in
            the shop, and on an unscheduled visit.
        deferred: (vehicle, reason) of each service request not served, reason ``spare``,
            ``crew`` or ``bay``.
        refused: (vehicle, action name, reason) of each duty refused.
    """

    route: I64
    window_fit: B
    shop_fit: B
    visit: B
    deferred: list[tuple[int, str]] = field(default_factory=list)
    refused: list[tuple[int, str, str]] = field(default_factory=list)

    @classmethod
    def idle(cls, n: int) -> Plan:
        """Nobody drives, nothing fitted."""
        no = np.zeros(n, dtype=bool)
        return cls(np.full(n, -1, dtype=np.int64), no, no.copy(), no.copy())

    @property
    def replaced(self) -> B:
        return self.window_fit | self.shop_fit | self.visit


class Workshop:
    """Bays, spare stock, orders in transit and the vehicles down.

    Args:
        config: The fleet's config.
    """

    def __init__(self, config: FleetConfig) -> None:
        self.config = config
        n = config.n_vehicles
        self.stock = config.initial_stock
        self.transit = np.zeros(config.lead_time, dtype=np.int64)  # arrivals in 1..L shifts
        self.down = np.zeros(n, dtype=np.int64)  # shifts left in the shop
        self.failed_down = np.zeros(n, dtype=bool)  # down because of a brake failure
        self.waiting = np.zeros(n, dtype=bool)  # failed, waiting for a spare

    @property
    def in_transit(self) -> int:
        return int(self.transit.sum())

    def free_bays(self) -> int:
        """Bays left for service visits after the vehicles down."""
        return int(model.free_bays(self.config.bays, self.down))

    def receive(self) -> int:
        """Orders due this shift go into stock; returns how many pads arrived."""
        got, self.transit[:] = model.receive(self.transit)
        self.stock += int(got)
        return int(got)

    def fit_waiting(self) -> B:
        """Failed vehicles waiting for a spare get one, in vehicle order."""
        fit = model.fit_waiting(self.waiting, self.stock)
        self.stock -= int(fit.sum())
        self.waiting &= ~fit
        return fit

    def plan(self, duty: I64, window: bool, pad_age: I64) -> Plan:
        """Serve the shift's actions by the rule of the module docstring."""
        n = self.config.n_vehicles
        down = self.down > 0
        plan = Plan.idle(n)
        asks = duty == SERVICE
        order = model.workshop_order(pad_age, down, window)
        admitted, reason = model.admit(self.config, asks[None], order, down=down, window=window,
                                       stock=self.stock, free=self.free_bays())  # fmt: skip
        fit, why = admitted[0], reason[0]
        plan.deferred = [(int(v), model.REASONS[why[v]]) for v in order[0] if why[v]]
        if window:
            plan.window_fit = fit
        else:
            plan.shop_fit, plan.visit = fit & down, fit & ~down
        self.stock -= int(fit.sum())
        self.waiting &= ~fit  # (a failed vehicle still waiting gets this spare)
        drives, able = (duty == HOT) | (duty == MILD), model.can_drive(down, window)
        for v in np.flatnonzero(drives & ~able):
            plan.refused.append((int(v), ACTIONS[int(duty[v])], "window" if window else "down"))
        ok = drives & able
        plan.route[ok] = duty[ok]
        return plan

    def fail(self, failed: B) -> B:
        """Brake failures at the end of a shift: the vehicles go down; each gets a spare
        now if there is one, else waits. Returns the vehicles fitted now."""
        model.fail(self.config, self.down, self.failed_down, self.waiting, failed)
        return self.fit_waiting()

    def break_down(self, broken: B) -> None:
        """Other breakdowns at the end of a shift: the vehicles go to the shop."""
        model.break_down(self.config, self.down, self.failed_down, broken)

    def order(self, quantity: int) -> None:
        """An order placed this shift arrives at the start of shift + lead time."""
        model.place_order(self.transit, quantity)

    def end_shift(self, new_down: B) -> None:
        """A shift in the shop is done for the vehicles that were down during it; a failed
        vehicle waiting for a spare stays down."""
        self.down[:] = model.end_shift(self.down, self.waiting, new_down)
        self.failed_down &= self.down > 0
