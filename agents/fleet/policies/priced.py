"""The price-directed policy: services decided from price-free signals, the vehicles'
relaxed program (:mod:`.lagrangian`) at damped prices used only to rank them for duty; a
repair step keeps the fleet's limits.

Each shift every vehicle's state ``(h, d)`` is read from the env's truth (its pad's true
volume and K, as the bound knows them: a reference, never deployable); ``h / units`` is
the pad's expected hot life in shifts. The repair step:

1. **Services** (price-free, an (n, N)-like control limit on the hot life): a pad is
   replaced anywhere below ``must`` hot shifts (an unscheduled visit between windows);
   at a window below the working shifts to the next window (``window_period - 1``) plus
   ``margin`` (it would not last to the next window on the ramp); while its vehicle is
   down in the shop anyway below ``shop_limit``. Both limits are capped by the shifts
   left in the episode (a pad that outlasts the episode is not replaced). Requests are
   served least life first while a spare is in stock and there is room
   (:func:`brake_env.env.fleet.model.admit`: a crew slot at a window, a free bay for a
   visit, none for a vehicle down in the shop); the others are not sent.
2. **Duties** (between windows; vehicles not down and not serviced). The hot need is
   filled first (:func:`brake_env.env.fleet.rules.fill_needs`) by the vehicles of least
   program cost of the ramp over the drift (ties: healthiest first; pads below ``must``
   last), then the mild need; the rest park (beyond the needs a shift earns nothing). A
   pad below ``must`` is never sent up the ramp, nor on a drift below one hot shift of
   life. The program is solved at the searched prices times ``damping``.
3. **Spares** by (s, S) (:func:`~.rules.reorder`).

Every action is within the env's mask.

**Why not the program's own service decisions.** The first version served a vehicle when
its program (at the searched prices) preferred a service, and ranked duties by the
program's costs at those prices. Near the optimal prices the program values a pad's
remaining life highly, its "prefer a service" signal stops matching the real fleet, and
the policy cost 43.06 per vehicle-shift at the default fleet (2.14 on one episode at
8-iteration prices, 6.87 at 30): too many unscheduled visits.

**Measured** by ``benchmarks/analysis/fleet_bound.py --iterations 60 --only default`` (default
fleet, 365 shifts, evaluation seeds 0..9; ``margin``, ``shop_limit`` and ``damping`` chosen
on tuning seeds 10000..10019, never on the evaluation seeds; defaults ``margin = -2``,
``shop_limit = 20``, ``damping = 0.25``), 2026-11-27: **2.6773** per vehicle-shift against
the bound's 1.5713, a paired gap of 1.106 [0.959, 1.277] (ratio 1.70 [1.58, 1.87]); on the
same episodes the untuned (n, N) = (14, 3) rule on the oracle's expected RUL costs 5.5132
(the policy minus it: -2.836 [-4.995, -1.657]). With the same services but the ramp
ranked healthiest first (``rank="rul"``, price-free) it costs 2.9860 on those episodes
(one episode at 4.83, unscheduled visits): the program's ranking helps. Still far from
the bound (which is optimistic by design: a relaxation with the pads' K known). The
policy reads the env's truth: a reference, not a deployable policy.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from agents.fleet.policies.base import FleetPolicy
from agents.fleet.policies.checks import real, same_config, whole
from agents.fleet.policies.lagrangian import BoundModel, Prices, Program, q_values, solve
from agents.fleet.policies.rules import reorder
from brake_env.env.fleet import model as fleet
from brake_env.env.fleet.rules import fill_needs
from brake_env.env.fleet.shop import HOT, MILD, PARK, SERVICE

I64 = NDArray[np.int64]
F64 = NDArray[np.float64]
RANKS = ("program", "rul")


def damped(prices: Prices, factor: float) -> Prices:
    """``prices`` scaled by ``factor`` (in the boxes for any factor in [0, 1])."""
    return replace(prices, hot=prices.hot * factor, work=prices.work * factor,
                   bay=prices.bay * factor, crew=prices.crew * factor)  # fmt: skip


class PricedPolicy(FleetPolicy):
    """Price-free services, duties ranked by the program at damped prices (module
    docstring).

    Args:
        env: The BrakeWearFleet-v0 it acts on (any wrapper; its ``unwrapped`` is read).
        model: The relaxed model of that env's config and atlas.
        prices: The searched prices.
        program: ``solve(model, prices)`` (re-solved at the damped prices unless
            ``damping`` is 1).
        s, S: Reorder rule of the spares.
        must: Hot life [shifts] below which a pad is replaced anywhere (a visit between
            windows) and kept off the ramp.
        margin: At a window, a pad is replaced when its hot life is below the working
            shifts to the next window plus ``margin``.
        shop_limit: A vehicle down in the shop anyway has its pad replaced below this
            hot life.
        damping: Factor on the prices of the program that ranks the duties.
        rank: ``program`` (the damped program's cost of the ramp over the drift) or
            ``rul`` (healthiest on the ramp: the price-free comparison).
    """

    def __init__(
        self, env: Any, model: BoundModel, prices: Prices, program: Program, *, s: int = 2,
        S: int = 4, must: float = 2.0, margin: float = -2.0, shop_limit: float = 20.0,
        damping: float = 0.25, rank: Literal["program", "rul"] = "program",
    ) -> None:  # fmt: skip
        if rank not in RANKS:
            raise ValueError(f"PricedPolicy: rank must be one of {RANKS}, got {rank!r}")
        who = "PricedPolicy"
        damping = real(who, "damping", damping, 0.0, 1.0)
        s, S = whole(who, "s", s, 0), whole(who, "S", S, 0)
        if s > S:
            raise ValueError(f"{who}: s must be an integer <= S, got s={s}, S={S}")
        must, margin = real(who, "must", must, 0.0), real(who, "margin", margin)
        shop_limit = real(who, "shop_limit", shop_limit, 0.0)
        same_config(who, model.config, env.unwrapped.config)
        self.env, self.model, self.s, self.S = env, model, s, S
        self.must, self.margin, self.shop_limit, self.rank = must, margin, shop_limit, rank
        self.damping = damping
        self.prices = damped(prices, damping)
        needs_program = rank == "program" and damping != 1.0
        self.program = solve(model, self.prices) if needs_program else program

    def action(self, observation: NDArray[Any]) -> NDArray[np.int64]:
        """The decision on the env's truth (the observation is not read)."""
        base = self.env.unwrapped
        c, shop = base.config, base.shop
        truth = base.truth()
        h = self.model.state(truth["volume_frac"], truth["wear_coeff"])
        duty = self.decide(base.shift, h, shop.down.copy(), shop.stock, shop.free_bays())
        fits = int((duty == SERVICE).sum())
        order = reorder(shop.stock, shop.in_transit, fits, self.s, self.S, c.max_order)
        return np.append(duty, order).astype(np.int64)

    def costs(self, shift: int, h: I64, down: I64) -> F64:
        """The (damped) program's cost of each action (rows hot, mild, park, service) for
        each vehicle (columns) at ``shift``."""
        m = self.model
        t = min(shift, m.config.episode_shifts - 1)
        q = q_values(m, self.prices, t, self.program.values[t + 1])
        return q[:, h, np.clip(down, 0, m.D - 1)]

    def decide(self, shift: int, h: I64, down: I64, stock: int, bays: int) -> I64:
        """Each vehicle's action at ``shift`` (RUL states ``h``, shifts left in the shop
        ``down``, spares in ``stock``, free ``bays``): module docstring."""
        c = self.model.config
        window = c.is_window(shift)
        life = h / self.model.units  # hot shifts
        left = c.episode_shifts - 1 - shift  # shifts after this one
        limit = np.where(down > 0, max(self.must, min(self.shop_limit, left)), self.must)
        if window:
            limit = np.maximum(limit, min(c.window_period - 1, left) + self.margin)
        asks = life < limit
        order = np.argsort(np.where(asks, life, np.inf), kind="stable")
        send, _ = fleet.admit(c, asks[None], order[None], down=down > 0, window=window,
                              stock=stock, free=bays)  # fmt: skip
        duty = np.where(send[0], SERVICE, PARK).astype(np.int64)
        if not window:
            self._duties(shift, h, life, fleet.can_drive(down, window) & ~send[0], duty)
        return duty

    def _duties(self, shift: int, h: I64, life: F64, able: NDArray[np.bool_], duty: I64) -> None:
        """Fill the needs from the ``able`` vehicles, in place in ``duty``: the ramp by
        the rank, pads below ``must`` last; the rest park."""
        c = self.model.config
        cand = np.flatnonzero(able)
        if self.rank == "program":
            q = self.costs(shift, h, np.zeros_like(h))
            key = (q[HOT] - q[MILD])[cand]  # its hot price is the same for all: no matter
        else:
            key = np.zeros(len(cand))
        worn = life[cand] < self.must
        order = cand[np.lexsort((-life[cand], key, worn))]
        hot, drift = fill_needs(c, order, duty)
        duty[hot[life[hot] < self.must]] = PARK  # a worn pad is not sent up the ramp
        duty[drift[life[drift] < 1.0]] = PARK  # nor on a drift below a hot shift's life
