"""The planner's belief about each pad in the futures a plan simulates: the estimate of today,
carried forward by the expected wear of the duties the vehicle runs.

A plan looks a few shifts ahead, to the next window and through it. In its simulated
futures the policy must act on what the planner would know then, not on the simulated
truth (that would be clairvoyant) and not on a predictor refitted in every future (seconds
a future). What it would know is today's estimate plus the duties since: each shift on a
route advances the pad's volume by the route's expected wear at the estimated K
(:class:`~brake_env.model.wear.WearModel`'s clocks), and a pad fitted in the future starts
new at the fleet's mean K. Over two weeks the predictor would learn little more than that:
the twin's K settles within the first tenth of a life.
"""

from __future__ import annotations

from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

from agents.fleet.operate.estimates import VehicleEstimates
from brake_env.env.fleet.route_rul import ROUTE_NAMES, duty_clocks
from brake_env.env.fleet.wrappers import RUL_HIGH_SHIFTS, _appended_space

F64 = NDArray[np.float64]


class BeliefRULObservation(
    gym.ObservationWrapper[NDArray[np.float32], NDArray[np.int64], NDArray[np.float32]]
):
    """Append each vehicle's believed RUL on the hot and the mild route (mean, in shifts),
    the layout of :class:`~brake_env.env.fleet.wrappers.FleetRULObservation` with
    ``fields=("rul_mean",)``, from ``estimates`` carried forward (module docstring).

    Args:
        env: A fleet env (reset from the state the estimates describe).
        estimates: Today's estimate of each vehicle's pad.
    """

    def __init__(self, env: gym.Env[Any, Any], estimates: VehicleEstimates) -> None:
        super().__init__(env)
        base: Any = env.unwrapped
        self.est = estimates
        self.n = int(base.config.n_vehicles)
        self.per_shift = float(base.config.events_per_shift)
        self.k_new = float(base.config.wear.k_mean)
        self.clocks = duty_clocks(base.atlas, ROUTE_NAMES)
        self.observation_space = _appended_space(env, len(ROUTE_NAMES))  # type: ignore[assignment]
        self.volume, self.k = estimates.volume.copy(), estimates.wear_coeff.copy()
        self._serial = np.zeros(self.n, dtype=np.int64)

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[NDArray[np.float32], dict[str, Any]]:
        obs, info = self.env.reset(seed=seed, options=options)
        self.volume, self.k = self.est.volume.copy(), self.est.wear_coeff.copy()
        self._serial = info["vehicles"]["serial"].copy()
        return self.observation(obs), info

    def step(
        self, action: NDArray[np.int64]
    ) -> tuple[NDArray[np.float32], SupportsFloat, bool, bool, dict[str, Any]]:
        obs, reward, terminated, truncated, info = self.env.step(action)
        v = info["vehicles"]
        for r, clock in enumerate(self.clocks.routes):
            on = v["route"] == r
            work = clock.work_at_volume(self.volume[on]) + self.k[on] * v["events"][on]
            self.volume[on] = clock.volume_at_work(np.minimum(work, clock.life_work))
        new = v["serial"] != self._serial  # a pad fitted this shift (and braked on it)
        self.volume[new], self.k[new] = 1.0, self.k_new
        self._serial = v["serial"].copy()
        return self.observation(obs), reward, terminated, truncated, info

    def rul_events(self) -> F64:
        """(vehicles, routes): the believed events to failure on each route."""
        v = np.clip(self.volume, self.clocks.base.lower_edges[-1], 1.0)
        return np.stack([c.rul(v, self.k) for c in self.clocks.routes], axis=1)

    def observation(self, observation: NDArray[np.float32]) -> NDArray[np.float32]:
        est = np.clip(self.rul_events() / self.per_shift, 0.0, RUL_HIGH_SHIFTS).ravel()
        return np.concatenate([observation, est]).astype(np.float32, copy=False)
