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
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from agents.fleet.policies.checks import bound_inputs, real, whole
from agents.fleet.policies.lagrangian import (
    BoundModel,
    Prices,
    Program,
    bound,
    occupation,
    solve,
    supergradient,
)

F64 = NDArray[np.float64]
GROW, SHRINK = 1.2, 0.5  # Rprop's factors (Riedmiller and Braun 1993)


def _flat(p: Prices) -> F64:
    return np.concatenate([p.hot, p.work, p.bay, p.crew])


def _prices(x: F64) -> Prices:
    hot, work, bay, crew = np.split(x, 4)
    return Prices(hot, work, bay, crew)


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
