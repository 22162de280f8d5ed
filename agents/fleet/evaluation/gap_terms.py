"""The Lagrangian bound (:mod:`agents.fleet.policies.lagrangian`) split into the cost terms
an episode's bill has, so that a policy's gap to it can be read term by term
(``benchmarks/analysis/fleet_gap_terms.py``).

Under the program's policy from a start, the vehicles' expected counts
(:func:`agents.fleet.policies.lagrangian_search.occupation`) priced by the env's costs give
the bound's fits, orders, shop visits, failures' damage and downtime, and the credit of the
pad life left; the rest is the prices' terms: each relaxed constraint's price times its
expected slack (needs not met are paid at their price, capacities used beyond their size
too; at the best prices this is near 0 where the constraint binds). The terms add up to the bound
exactly (:func:`bound_terms` checks it), every one per vehicle-shift.

The policy's side (:func:`episode_terms`) groups an episode's bill the same way: pads
priced when fitted plus labour, order and holding, shop visits, damage, downtime, the
shortfalls (hot, mild, deferred), less the pad life left (:attr:`EpisodeCost.net`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from agents.fleet.evaluation.costs import EpisodeCost
from agents.fleet.policies.lagrangian import BoundModel, Prices, Program, bound
from agents.fleet.policies.lagrangian_search import occupation, supergradient

F64 = NDArray[np.float64]

TERMS = ("fits", "orders", "shop_visit", "damage", "downtime", "shortfall", "credit")
"""The groups of both sides, in the order they are printed."""


def bound_terms(
    model: BoundModel, program: Program, prices: Prices, start: F64, excess: float = 0.0
) -> dict[str, float]:
    """The bound from ``start`` (:func:`agents.fleet.policies.lagrangian.bound`) by term, per
    vehicle-shift: :data:`TERMS`, ``shortfall`` being the prices' terms.

    Raises:
        AssertionError: The terms do not add up to the bound (a term left out).
    """
    c = model.config
    occ = occupation(model, program, start)
    left = float(occ.end @ np.arange(model.H + 1)) + excess  # units left at the end
    services = occ.window_fits.sum() + occ.visits.sum() + occ.shop_fits.sum()
    t = np.arange(c.episode_shifts)
    out_shifts = np.minimum(c.failure_repair_shifts, c.episode_shifts - 1 - t)
    g = supergradient(model, occ)
    priced = sum(float(np.dot(getattr(prices, k), getattr(g, k)))
                 for k in ("hot", "work", "bay", "crew"))  # fmt: skip
    raw = {
        "fits": (services + occ.failures.sum()) * model.fit_cost,
        "orders": model.order_share * (services - c.initial_stock),
        "shop_visit": occ.visits.sum() * c.costs.shop_visit,
        "damage": occ.failures.sum() * c.costs.damage,
        "downtime": float(occ.failures @ out_shifts) * c.costs.downtime,
        "shortfall": priced,
        "credit": -model.credit * (left + model.new_tail * (services + occ.failures.sum())),
    }
    per = c.n_vehicles * c.episode_shifts
    whole = bound(model, program, prices, start, excess)
    if not np.isclose(sum(raw.values()), whole, rtol=1e-9, atol=1e-6 * per):
        raise AssertionError(f"bound_terms: terms add up to {sum(raw.values())}, bound {whole}")
    return {k: float(v) / per for k, v in raw.items()}


def episode_terms(ep: EpisodeCost) -> dict[str, float]:
    """An episode's net cost by :data:`TERMS`, per vehicle-shift (they add up to ``ep.net``)."""
    x, per = ep.terms, ep.vehicles * ep.shifts
    raw = {
        "fits": ep.pad_price * ep.fits + x.get("labour", 0.0),
        "orders": x.get("order", 0.0) + x.get("holding", 0.0),
        "shop_visit": x.get("shop_visit", 0.0),
        "damage": x.get("damage", 0.0),
        "downtime": x.get("downtime", 0.0),
        "shortfall": sum(x.get(k, 0.0) for k in ("shortfall", "mild_shortfall", "deferred")),
        "credit": -ep.life_value,
    }
    return {k: float(v) / per for k, v in raw.items()}
