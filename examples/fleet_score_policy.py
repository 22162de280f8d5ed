"""A fleet policy of one's own, scored on a benchmark suite against the shipped baselines.

Run: ``brakewear fleet-score --suite small --policy examples/fleet_score_policy.py:factory
--out out/my-policy`` (about a minute: the suite's twin is fitted, then 20 test episodes).

``factory(env)`` gets the suite's fleet env (its observation: the fleet's features and each
vehicle's RUL on the hot and the mild route, in shifts, of the suite's ``observe``
predictor) and returns a callable from observation to action: a duty per vehicle (0 hot,
1 mild, 2 park, 3 service), then the reorder quantity. This one is a plain rule written
from the observation: service a pad with less than ``LIMIT`` hot shifts left (at a window
whatever the crew allows, between windows if a bay is free), the vehicles with the most
RUL on the ramp, the rest in the drifts, and one order when the stock runs low.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from agents.fleet.policies.view import FleetLayout, FleetView

LIMIT = 12.0  # hot shifts: a little under a window period of RUL left


def factory(env: Any) -> Any:
    config = env.unwrapped.config
    layout = FleetLayout.of(config)

    def act(obs: Any) -> np.ndarray:
        view = FleetView.read(obs, layout)
        allowed = view.mask(config.max_order)[: 4 * config.n_vehicles].reshape(-1, 4)
        duty = np.where(np.argsort(-view.rul).argsort() < config.hot_need, 0, 1)
        low = (view.rul < LIMIT) & allowed[:, 3]
        duty[low] = 3
        duty = np.where(allowed[np.arange(len(duty)), duty], duty, allowed.argmax(axis=1))
        order = 2 if view.stock + view.transit < 2 else 0
        return np.append(duty, min(order, config.max_order))

    return act
