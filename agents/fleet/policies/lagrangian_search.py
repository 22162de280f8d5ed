"""The search for the prices of the highest Lagrangian bound (:mod:`.lagrangian`): projected
supergradient ascent.

Each iteration solves the vehicles' program under the current prices, takes the bound from
the starting states, propagates the vehicles' state counts forward under the program's
optimal policy (:func:`~.lagrangian.occupation`) for each constraint's slack (a
supergradient), and steps the prices along its sign, projected back onto their boxes.
Each price has its own step (Rprop, Riedmiller and Braun 1993): it starts at ``step``
times the hot shortfall cost, grows by 1.2 while its slack keeps its sign (the price is far
from its best) and halves when the sign flips (it overshot), so that prices spanning three
orders of magnitude (a bay's tens, a need's thousands) are found in tens of iterations,
where one diminishing step for all would take thousands. The bound at every prices is valid,
so the best one seen is returned; the zero prices are always tried first, so the result
is never below their bound.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from agents.fleet.policies.checks import bound_inputs, real, whole
from agents.fleet.policies.lagrangian import BoundModel, Prices, Program, bound, solve
from brake_env.env.fleet.model import needs
from brake_env.env.fleet.shop import HOT, MILD, PARK, SERVICE

F64 = NDArray[np.float64]
GROW, SHRINK = 1.2, 0.5  # Rprop's factors (Riedmiller and Braun 1993)


def _flat(p: Prices) -> F64:
    return np.concatenate([p.hot, p.work, p.bay, p.crew])


def _prices(x: F64) -> Prices:
    hot, work, bay, crew = np.split(x, 4)
    return Prices(hot, work, bay, crew)


@dataclass(frozen=True)
class Occupation:
    """Expected numbers over the vehicles per shift under their optimal policies.

    Attributes:
        hot, mild, visits, down, window_fits: Vehicles on each route, on an unscheduled
            visit, down in the shop (at the shift's start) and fitted at a window.
        failures, shop_fits: Pads failed, and vehicles down in the shop fitted (a shift
            between windows); what the bound's cost is made of (its terms, not its prices).
        end: Vehicles at each h after the last shift (for the credit of the life left).
    """

    hot: F64
    mild: F64
    visits: F64
    down: F64
    window_fits: F64
    failures: F64
    shop_fits: F64
    end: F64


def occupation(model: BoundModel, program: Program, start: F64) -> Occupation:
    """Propagate the vehicles' state counts forward under ``program``'s policy from
    ``start`` (expected vehicles at each h, nobody down)."""
    c = model.config
    T, H, D = c.episode_shifts, model.H, model.D
    p, R, F = c.breakdown_rate, c.breakdown_repair_shifts, c.failure_repair_shifts
    dec = np.maximum(np.arange(D) - 1, 0)
    x = np.zeros((H + 1, D))
    x[:, 0] = start
    keys = ("hot", "mild", "visits", "down", "window_fits", "failures", "shop_fits")
    out = {k: np.zeros(T) for k in keys}
    steps = [(HOT, np.arange(H + 1) - model.units), (MILD, np.arange(H + 1) - model.mild_step)]
    for t in range(T):
        a = program.policy[t]
        nxt = np.zeros_like(x)
        for d in range(D):
            nxt[:, dec[d]] += np.where(a[:, d] == PARK, x[:, d], 0.0)
        serviced = np.where(a == SERVICE, x, 0.0).sum(axis=0)  # (D,)
        nxt += np.outer(model.new_prob, np.bincount(dec, weights=serviced, minlength=D))
        failed = 0.0
        for action, left in steps:
            drv = np.where(a[:, 0] == action, x[:, 0], 0.0)
            out["hot" if action == HOT else "mild"][t] = drv.sum()
            failed += drv[left < 0].sum()
            moved = np.bincount(left[left >= 0], weights=drv[left >= 0], minlength=H + 1)
            nxt[:, 0] += (1 - p) * moved
            nxt[:, R] += p * moved
        nxt[:, F] += failed * model.new_prob
        out["failures"][t] = failed
        if c.is_window(t):
            out["window_fits"][t] = serviced.sum()
        else:
            out["visits"][t], out["shop_fits"][t] = serviced[0], serviced[1:].sum()
            out["down"][t] = x[:, 1:].sum()
        x = nxt
    return Occupation(**out, end=x.sum(axis=1))


def supergradient(model: BoundModel, occ: Occupation) -> Prices:
    """The slack of each relaxed constraint under the vehicles' optimal policies: a
    supergradient of the bound in the prices."""
    c = model.config
    w = np.array([c.is_window(t) for t in range(c.episode_shifts)])
    hot, work = needs(c, window=False)  # (a window's slacks are set to 0 below)
    g = Prices(
        hot - occ.hot,
        work - occ.hot - occ.mild,
        occ.visits + occ.down * c.bays / c.n_vehicles - c.bays,
        occ.window_fits - c.window_slots,
    )
    zero = np.zeros(c.episode_shifts)
    return replace(
        g, hot=np.where(w, zero, g.hot), work=np.where(w, zero, g.work),
        bay=np.where(w, zero, g.bay), crew=np.where(w, g.crew, zero),
    )  # fmt: skip


@dataclass(frozen=True)
class SearchResult:
    """The best bound found.

    Attributes:
        prices: Its prices.
        program: The vehicles' program under them.
        bound: The bound (from the search's starting counts).
        zero_bound: The bound at zero prices.
        history: The bound at each iteration's prices.
        seconds: Wall time of the search.
    """

    prices: Prices
    program: Program
    bound: float
    zero_bound: float
    history: F64
    seconds: float

    @property
    def iterations(self) -> int:
        return int(self.history.size)


def search(
    model: BoundModel, start: F64, iterations: int = 100, step: float = 0.02,
    prices: Prices | None = None,
) -> SearchResult:  # fmt: skip
    """Projected supergradient ascent on the prices (module docstring) from ``prices``
    (zero if None; else tried after the zero prices), for ``iterations`` steps.

    Args:
        model: The vehicles' model.
        start: Expected vehicles at each state h at shift 0 (:func:`~.start_counts`).
        iterations: Price vectors tried after the zero prices.
        step: First step of every price, as a share of the hot shortfall cost.
        prices: Where to start (e.g. an earlier search's best); None: zero.
    """
    t0 = time.perf_counter()
    iterations = whole("search", "iterations", iterations, 0)
    step = real("search", "step", step, 1e-12)
    bound_inputs("search", model, prices, start)
    c = model.config
    zero = Prices.zeros(c)
    best_p, best_prog = zero, solve(model, zero)
    best = zero_b = bound(model, best_prog, zero, start)
    history = [zero_b]
    p, prog = zero, best_prog
    if prices is not None:  # a warm start: tried too
        p = prices.project(c)
        prog = solve(model, p)
        history.append(bound(model, prog, p, start))
        if history[-1] > best:
            best, best_p, best_prog = history[-1], p, prog
    scale = max(c.costs.shortfall, c.costs.mild_shortfall, 1.0)
    x, sign = _flat(p), np.zeros(4 * c.episode_shifts)
    delta = np.full_like(x, step * scale)
    for _ in range(iterations):
        g = _flat(supergradient(model, occupation(model, prog, start)))
        s = np.sign(np.where(np.abs(g) > 1e-9, g, 0.0))
        same = s * sign
        delta = np.where(same > 0, np.minimum(delta * GROW, scale),
                         np.where(same < 0, delta * SHRINK, delta))  # fmt: skip
        p = _prices(x + s * delta).project(c)
        x, sign = _flat(p), np.where(same < 0, 0.0, s)
        prog = solve(model, p)
        history.append(bound(model, prog, p, start))
        if history[-1] > best:
            best, best_p, best_prog = history[-1], p, prog
    return SearchResult(best_p, best_prog, best, zero_b, np.array(history),
                        time.perf_counter() - t0)  # fmt: skip
