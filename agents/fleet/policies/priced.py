"""The price-directed policy: each vehicle acts on its own relaxed program (:mod:`.lagrangian`)
under the searched prices, and a repair step keeps the fleet's limits.

Each shift every vehicle's state ``(h, d)`` is read from the env's truth (its pad's true
volume and K, as the bound knows them: a reference, never deployable), less a safety
margin of ``safety`` hot shifts (the bound's clock is optimistic by design), and its program
gives the cost of each action (:func:`~.lagrangian.q_values`). The repair step:

1. **Services.** Vehicles whose program prefers a service ask for one; they are served in
   order of how much the program prefers it (the cost of their best other action minus
   the service's, largest first; a pad that would not last a hot shift first) while a
   spare is in stock and there is room
   (:func:`brake_env.env.fleet.rules.room_for`: a crew slot at a window, a free bay for a
   visit, none for a vehicle down in the shop). The others are not sent.
2. **Duties** (between windows; vehicles not down and not serviced). Their cost of a
   duty is the program's cost of it, prices taken out, minus the cost of parking. The
   hot need is filled first, by the vehicles of least extra cost of the ramp over the
   drift (ties: healthiest first; a pad that would not last a hot shift last); then the
   mild need by the least cost of the drift. The rest park: beyond the needs a shift
   earns nothing. (A threshold "send only if the duty costs less than the shortfall"
   was tried and dropped: the program's cost of a duty holds the life it uses at the
   relaxed prices, which can exceed the shortfall, and it left the needs unfilled.)
3. **Spares** by (s, S) (:func:`~.rules.reorder`).

Every action is within the env's mask.

**Unfinished** (issue 30, item 2): measured by ``benchmarks/fleet_bound.py`` at the default
fleet (365 shifts, 10 episodes) it costs 43.06 per vehicle-shift against the bound's 1.57,
and it gets worse as the prices converge (too many unscheduled visits). It is no baseline
yet; the repair step needs signals that do not depend on the relaxed prices.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents.fleet.policies.lagrangian import BoundModel, Prices, Program, q_values
from agents.fleet.policies.rules import reorder
from brake_env.env.fleet.rules import room_for
from brake_env.env.fleet.shop import HOT, MILD, PARK, SERVICE

I64 = NDArray[np.int64]
F64 = NDArray[np.float64]


class PricedPolicy:
    """Acts on the vehicles' programs under ``prices`` (module docstring).

    Args:
        env: The BrakeWearFleet-v0 it acts on (any wrapper; its ``unwrapped`` is read).
        model: The relaxed model of that env's config and atlas.
        prices: The searched prices.
        program: ``solve(model, prices)``.
        s, S: Reorder rule of the spares.
        safety: Hot shifts taken off each pad's state before it acts: the bound's state
            is rounded up and its wear is the expectation, so a pad on its last model
            shift may fail in the env.
    """

    def __init__(
        self, env: Any, model: BoundModel, prices: Prices, program: Program, *, s: int = 2,
        S: int = 4, safety: float = 1.0,
    ) -> None:  # fmt: skip
        self.env, self.model, self.prices, self.program = env, model, prices, program
        self.s, self.S, self.safety = s, S, safety

    def predict(
        self,
        observation: NDArray[Any],
        state: tuple[NDArray[Any], ...] | None = None,
        episode_start: NDArray[np.bool_] | None = None,
        deterministic: bool = False,
    ) -> tuple[NDArray[Any], tuple[NDArray[Any], ...] | None]:
        base = self.env.unwrapped
        c, shop = base.config, base.shop
        truth = base.truth()
        h = self.model.state(truth["volume_frac"], truth["wear_coeff"])
        h = np.maximum(h - int(np.ceil(self.safety * self.model.units)), 0)
        duty = self.decide(base.shift, h, shop.down.copy(), shop.stock, shop.free_bays())
        fits = int((duty == SERVICE).sum())
        order = reorder(shop.stock, shop.in_transit, fits, self.s, self.S, c.max_order)
        return np.append(duty, order).astype(np.int64), state

    def costs(self, shift: int, h: I64, down: I64) -> F64:
        """The program's cost of each action (rows hot, mild, park, service) for each
        vehicle (columns) at ``shift``."""
        m = self.model
        t = min(shift, m.config.episode_shifts - 1)
        q = q_values(m, self.prices, t, self.program.values[t + 1])
        return q[:, h, np.clip(down, 0, m.D - 1)]

    def decide(self, shift: int, h: I64, down: I64, stock: int, bays: int) -> I64:
        """Each vehicle's action at ``shift`` (RUL states ``h``, shifts left in the shop
        ``down``, spares in ``stock``, free ``bays``): the repair step of the module
        docstring."""
        c = self.model.config
        window = c.is_window(shift)
        q = self.costs(shift, h, down)
        duty = np.full(len(h), PARK, dtype=np.int64)
        others = np.min(np.delete(q, SERVICE, axis=0), axis=0)
        prefer = others - q[SERVICE]  # > 0: the program prefers the service
        prefer[h < self.model.units] = np.inf  # would not last a hot shift: must-do
        slots = c.window_slots
        for v in np.argsort(-prefer, kind="stable"):
            if prefer[v] <= 0 or stock == 0:
                break
            if room_for(c, window, bool(down[v] > 0), slots, bays):
                duty[v], stock = SERVICE, stock - 1
                slots -= int(window)
                bays -= int(not (window or down[v] > 0))
        if not window:
            self._duties(shift, q, h, (down == 0) & (duty != SERVICE), duty)
        return duty

    def _duties(self, shift: int, q: F64, h: I64, able: NDArray[np.bool_], duty: I64) -> None:
        """Fill the needs from the ``able`` vehicles, in place in ``duty``."""
        c, p = self.model.config, self.prices
        t = min(shift, c.episode_shifts - 1)
        cand = np.flatnonzero(able)
        hot, mild = np.full(len(h), np.inf), np.full(len(h), np.inf)
        hot[cand] = (q[HOT] + p.hot[t] + p.work[t] - q[PARK])[cand]  # the ramp's, prices out
        mild[cand] = (q[MILD] + p.work[t] - q[PARK])[cand]
        fails = h < self.model.units  # its pad would not last a hot shift
        rank = cand[np.lexsort((-h[cand], hot[cand] - mild[cand], fails[cand]))]
        sent = rank[: c.hot_need]
        duty[sent] = HOT
        worn = h < self.model.mild_units
        rest = [v for v in cand[np.lexsort((-h[cand], mild[cand], worn[cand]))] if v not in sent]
        duty[rest[: c.mild_need]] = MILD
