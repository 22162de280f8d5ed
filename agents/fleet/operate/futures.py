"""The futures a plan is judged on: the fleet from today's state over the horizon, many
times, each on one possible truth of the pads (their RUL drawn from the estimates'
lognormals) and its own streams (conditions, sensor noise, breakdowns), the policy acting
on the planner's belief (:mod:`agents.fleet.operate.belief`).

The first shift's decision is the policy's on today's belief, the same in every future;
what follows differs with the truth. A future's cost is the sum of the env's cost terms
over the horizon, in the fleet's currency.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents.fleet.operate.belief import BeliefRULObservation
from agents.fleet.operate.estimates import VehicleEstimates, sampled_truth
from brake_env.env.fleet.config import COST_TERMS, FleetConfig
from brake_env.env.fleet.family import make_env
from brake_env.env.fleet.route_rul import duty_clocks
from brake_env.env.fleet.state import FleetState
from brake_env.model.atlas import Atlas

F64 = NDArray[np.float64]
B = NDArray[np.bool_]
COMING = ("refused", "deferred", "shortfall", "mild_shortfall", "on_hot", "on_mild")


@dataclass(frozen=True, eq=False)
class Futures:
    """What the futures did (one row per future).

    Attributes:
        cost: Money over the horizon.
        terms: The cost by term.
        first_action: The policy's action for the coming shift (duties, then the order).
        fitted: (futures, vehicles) a new pad fitted by a service (window, shop or visit)
            within the horizon.
        window_fit: (futures, vehicles) fitted at the window.
        failed: (futures, vehicles) its brakes failed within the horizon.
        ordered: Pads ordered over the horizon.
        coming: The coming shift's counts in the first future (``refused``, ``deferred``,
            ``shortfall``, ``mild_shortfall``, ``on_hot``, ``on_mild``): whether the decision
            fits the fleet's needs, bays, crew and stock.
        seconds: Wall time of the simulation.
    """

    cost: F64
    terms: dict[str, F64]
    first_action: NDArray[np.int64]
    fitted: B
    window_fit: B
    failed: B
    ordered: F64
    coming: dict[str, int] = field(default_factory=dict)
    seconds: float = field(default=0.0)


def simulate(
    config: FleetConfig, atlas: Atlas, est: VehicleEstimates, state: FleetState, *,
    policy: Any, horizon: int, futures: int, seed: int,
) -> Futures:  # fmt: skip
    """``futures`` runs of ``horizon`` shifts from ``state``; ``policy(env)`` gives the
    adapted policy (SB3's ``predict``) acting on the belief-wrapped env."""
    t0 = time.perf_counter()
    env = BeliefRULObservation(make_env(config, atlas), est)
    act = policy(env)
    base = duty_clocks(atlas).base
    rng = np.random.default_rng(np.random.SeedSequence([seed, 0x9A7]))
    n = config.n_vehicles
    cost, ordered = np.zeros(futures), np.zeros(futures)
    terms = {t: np.zeros(futures) for t in COST_TERMS}
    fitted, window_fit, failed = (np.zeros((futures, n), dtype=bool) for _ in range(3))
    first, coming = np.zeros(n + 1, dtype=np.int64), {}
    for i in range(futures):
        truth = sampled_truth(state, est, base, rng)
        obs, _ = env.reset(seed=seed * 1_000_003 + i, options={"state": truth})
        for t in range(horizon):
            action, _ = act.predict(obs, deterministic=True)
            if t == 0 and i == 0:
                first = np.asarray(action, dtype=np.int64).copy()
            obs, _, _, trunc, info = env.step(action)
            v, c = info["vehicles"], info["counts"]
            if t == 0 and i == 0:
                coming = {k: int(c[k]) for k in COMING}
            fitted[i] |= v["replaced"]
            window_fit[i] |= v["replaced"] & bool(info["window"])
            failed[i] |= v["failed"]
            ordered[i] += c["ordered"]
            for k, x in info["costs"].items():
                terms[k][i] += x
            if trunc:
                break
        cost[i] = sum(terms[k][i] for k in terms)
    return Futures(cost, terms, first, fitted, window_fit, failed, ordered, coming,
                   time.perf_counter() - t0)  # fmt: skip
