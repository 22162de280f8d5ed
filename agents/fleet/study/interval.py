"""The fixed-interval baseline of the fleet study: replacement by a pad's age alone.

A fleet without condition monitoring changes pads at a fixed interval of use. Here that
interval is read as a RUL the rules already act on: each vehicle's "RUL" on a route is a
nominal pad's life on that route (the fleet's mean K, a new pad) times the share of a
nominal life on the base mix its pad has not yet braked (``1 - pad_age / life``; the
``pad_age`` the env observes, events since fitting, whatever the duty). It knows nothing of
the pad's own wear, so a tuned ``threshold`` on it is replacement at a fixed age, and the
other rule families tuned on it are fixed intervals moved to a window, a visit or a duty.
Tuned on the same episodes and budget as every predictor's RUL, it is the baseline each
predictor's value is counted from (:mod:`agents.fleet.study.money`).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from brake_env.env.fleet.route_rul import ROUTE_NAMES, duty_clocks
from brake_env.env.fleet.spaces import N_VF, VEHICLE_FEATURES
from brake_env.env.fleet.wrappers import ESTIMATE_FIELDS, RUL_HIGH_SHIFTS

AGE = VEHICLE_FEATURES.index("pad_age")


class AgeRULObservation(
    gym.ObservationWrapper[NDArray[np.float32], NDArray[np.int64], NDArray[np.float32]]
):
    """Append each vehicle's age-only RUL on each route, in the layout of
    :class:`~brake_env.env.fleet.wrappers.FleetRULObservation` (every field the same: a
    point estimate), in shifts of that route.

    Args:
        env: BrakeWearFleet-v0 (unwrapped, or wrapped without appended columns).
        fields: Fields to append (all equal).
        routes: Routes whose RUL is appended.
    """

    def __init__(
        self,
        env: gym.Env[NDArray[np.float32], NDArray[np.int64]],
        fields: tuple[str, ...] = ("rul_mean",),
        routes: tuple[str, ...] = ROUTE_NAMES,
    ) -> None:
        super().__init__(env)
        if not fields or any(f not in ESTIMATE_FIELDS for f in fields):
            raise ValueError(f"AgeRULObservation: fields must be among {ESTIMATE_FIELDS}")
        base: Any = env.unwrapped
        c = base.config
        self.fields, self.routes, self.n = tuple(fields), tuple(routes), int(c.n_vehicles)
        clocks = duty_clocks(base.atlas, self.routes)
        # A nominal pad's life: on the base mix (the unit of pad_age for the first pads) in
        # events, on each route in shifts of that route.
        self.life = float(clocks.base.life(c.k_mean))
        self.route_life = np.array([float(r.life(c.k_mean)) for r in clocks.routes])
        self.route_life /= c.events_per_shift
        k = len(self.fields) * len(self.routes) * self.n
        box = env.observation_space
        assert isinstance(box, spaces.Box)
        self.observation_space = spaces.Box(
            np.concatenate([box.low, np.zeros(k, dtype=np.float32)]),
            np.concatenate([box.high, np.full(k, RUL_HIGH_SHIFTS, dtype=np.float32)]),
            dtype=np.float32,
        )

    def rul(self, observation: NDArray[np.float32]) -> NDArray[np.float64]:
        """Each vehicle's age-only RUL on each route [shifts], (vehicles, routes)."""
        vehicles = np.asarray(observation[: self.n * N_VF], dtype=np.float64)
        age = vehicles.reshape(self.n, N_VF)[:, AGE]
        left = np.clip(1.0 - age / self.life, 0.0, 1.0)
        return left[:, None] * self.route_life[None, :]

    def observation(self, observation: NDArray[np.float32]) -> NDArray[np.float32]:
        est = np.repeat(self.rul(observation), len(self.fields), axis=1)
        return np.concatenate([observation, est.ravel()]).astype(np.float32)
