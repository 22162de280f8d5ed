"""The fixed-interval baseline of the fleet study: replacement by a pad's use alone.

A fleet without condition monitoring changes pads at a fixed interval of use, counted from
its dispatch log and the maker's nominal lives: a pad has used ``events / life[route]`` of
itself in each shift, ``life[route]`` the events a nominal pad (the fleet's mean K, new)
lasts on that route. The first pads were aged on the base mix (the env ages them there), so
they start at ``pad_age / life[base mix]``. That share is read as a RUL the rules already
act on: on each route, ``(1 - used) x life[route]`` in shifts of that route. It knows which
route each vehicle drove (the dispatch, not truth) but nothing of the pad's own wear, so a
tuned ``threshold`` on it is replacement at a fixed use, and the other rule families tuned
on it are fixed intervals moved to a window, a visit or a duty. Tuned on the same episodes
and budget as every predictor's RUL, it is the baseline each predictor's value is counted
from (:mod:`agents.fleet.study.money`).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

from brake_env.env.fleet.route_rul import ROUTE_NAMES, duty_clocks
from brake_env.env.fleet.routes import ROUTE_INDEX, ROUTES
from brake_env.env.fleet.spaces import N_VF, VEHICLE_FEATURES
from brake_env.env.fleet.wrappers import _appended_space, _check_layout

AGE = VEHICLE_FEATURES.index("pad_age")


class AgeRULObservation(
    gym.ObservationWrapper[NDArray[np.float32], NDArray[np.int64], NDArray[np.float32]]
):
    """Append each vehicle's use-only RUL on each route, in the layout of
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
        self.fields, self.routes = _check_layout("AgeRULObservation", fields, routes)
        base: Any = env.unwrapped
        c = base.config
        self.n = int(c.n_vehicles)
        # A nominal pad's life in events on every route of the env (info's route indices)
        every = duty_clocks(base.atlas, tuple(r.name for r in ROUTES))
        self.life = np.array([float(r.life(c.k_mean)) for r in every.routes])
        self.base_life = float(every.base.life(c.k_mean))
        self.route_life = self.life[[ROUTE_INDEX[r] for r in self.routes]] / c.events_per_shift
        self.used = np.zeros(self.n)
        self.serial = np.zeros(self.n, dtype=np.int64)
        per = len(self.fields) * len(self.routes)
        self.observation_space = _appended_space(env, per)  # type: ignore[assignment]

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[NDArray[np.float32], dict[str, Any]]:
        obs, info = self.env.reset(seed=seed, options=options)
        self.used = self._ages(obs) / self.base_life  # the first pads: aged on the base mix
        self.serial = np.asarray(info["vehicles"]["serial"], dtype=np.int64).copy()
        return self.observation(obs), info

    def step(self, action: Any) -> tuple[NDArray[np.float32], float, bool, bool, dict[str, Any]]:
        obs, reward, terminated, truncated, info = self.env.step(action)
        v = info["vehicles"]
        route, serial = np.asarray(v["route"]), np.asarray(v["serial"], dtype=np.int64)
        new = serial != self.serial
        self.used[new], self.serial = 0.0, serial.copy()  # a new pad: its use from its fitting
        # Its events since fitting (all this shift's, on this shift's route) or the shift's
        done = np.where(new, self._ages(obs), np.asarray(v["events"], dtype=np.float64))
        drove = (route >= 0) & (done > 0)
        self.used[drove] += done[drove] / self.life[route[drove]]
        return self.observation(obs), float(reward), terminated, truncated, info

    def _ages(self, observation: NDArray[np.float32]) -> NDArray[np.float64]:
        vehicles = np.asarray(observation[: self.n * N_VF], dtype=np.float64)
        return vehicles.reshape(self.n, N_VF)[:, AGE]

    def rul(self) -> NDArray[np.float64]:
        """Each vehicle's use-only RUL on each route [shifts], (vehicles, routes)."""
        return np.clip(1.0 - self.used, 0.0, 1.0)[:, None] * self.route_life[None, :]

    def observation(self, observation: NDArray[np.float32]) -> NDArray[np.float32]:
        est = np.repeat(self.rul(), len(self.fields), axis=1)
        return np.concatenate([observation, est.ravel()]).astype(np.float32)
