"""What one vehicle sees in the PettingZoo version of BrakeWearFleet-v0, and the RUL it reads.

A vehicle's view (:func:`vehicle_views`) is what a dispatcher uses to give it a duty, from
the fleet's flat observation alone (so a policy trained on the PettingZoo env runs on the
Gymnasium env's observation too):

- its own ``VEHICLE_FEATURES`` and the ``FLEET_FEATURES`` (shift, shifts to the window,
  stock, pads on order, free bays);
- ``DISPATCH_FEATURES``: the vehicles needed on the hot route and on the mild one this shift
  (0 at a window), the window crew's slots this shift (0 between windows) and how many
  vehicles may drive this shift (the mask's count);
- with a predictor, ``RUL_FEATURES``: its RUL estimate (events, as the predictor gives it:
  the oracle's on the hot route, the paper's predictors' on the envelope's uniform mix) and
  its rank by RUL in the fleet: 0 for the vehicle with the most RUL among those that may
  drive this shift, then down (ties by vehicle index); vehicles that may not drive
  (in the shop, or every vehicle at a window) rank after them, by RUL too. With the rank a
  shared policy can tell whether it is among the ``hot_need`` healthiest.

:func:`rul_env` wraps the env with a predictor's RUL (``rul_mean`` per vehicle): a fitted
predictor (:class:`~brake_env.env.fleet.wrappers.FleetRULObservation`), a registry name
(fitted here on simulated run-to-failure pads of the env's wear regime), or ``"oracle"``
(the closed-form expected hot-route RUL, :class:`~.wrappers.ExpectedRULObservation`, as the
fleet study uses it).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.model import needs
from brake_env.env.fleet.rules import action_mask
from brake_env.env.fleet.shop import HOT
from brake_env.env.fleet.spaces import FLEET_FEATURES, VEHICLE_FEATURES, read_observation
from brake_env.env.fleet.wrappers import ExpectedRULObservation, FleetRULObservation
from brake_env.prognostics.events import RULPredictor
from brake_env.prognostics.registry import ORACLE, fit_predictors, predictor_names

DISPATCH_FEATURES = ("hot_need", "mild_need", "window_slots", "able")
RUL_FEATURES = ("rul", "rul_rank")
RUL_HIGH = 1e7  # events, the RUL wrappers' bound
N_TRAIN_RUNS = 10  # run-to-failure pads a predictor named by the registry is fitted on


def view_features(with_rul: bool) -> tuple[str, ...]:
    """The names of a vehicle's view, in order."""
    return (*VEHICLE_FEATURES, *FLEET_FEATURES, *DISPATCH_FEATURES,
            *(RUL_FEATURES if with_rul else ()))  # fmt: skip


def view_space(config: FleetConfig, box: spaces.Box, with_rul: bool) -> spaces.Box:
    """The Box of a vehicle's view; ``box`` is the fleet env's own observation space."""
    c, n, nv = config, config.n_vehicles, len(VEHICLE_FEATURES)
    nf = len(FLEET_FEATURES)
    fleet = slice(n * nv, n * nv + nf)
    dispatch = np.array([c.hot_need, c.mild_need, c.window_slots, n], dtype=np.float64)
    low = [box.low[:nv], box.low[fleet], np.zeros(len(DISPATCH_FEATURES))]
    high = [box.high[:nv], box.high[fleet], dispatch]
    if with_rul:
        low.append(np.zeros(2))
        high.append(np.array([RUL_HIGH, n - 1]))
    return spaces.Box(
        np.concatenate(low).astype(np.float32), np.concatenate(high).astype(np.float32),
        dtype=np.float32,
    )  # fmt: skip


def vehicle_views(obs: NDArray[Any], config: FleetConfig, with_rul: bool) -> NDArray[np.float32]:
    """(n_vehicles, len(view_features(with_rul))): every vehicle's view (module docstring)
    from the fleet's flat observation (with one RUL field appended per vehicle when
    ``with_rul``)."""
    n = config.n_vehicles
    o = read_observation(obs, n, int(with_rul))
    f = o.fleet
    window = o.window
    drive = action_mask(o.down, window, f["stock"], f["free_bays"], config.max_order)
    able = drive[: 4 * n].reshape(n, 4)[:, HOT]
    fleet = np.array([f[k] for k in FLEET_FEATURES], dtype=np.float64)
    hot_need, work = needs(config, window)
    dispatch = np.array([
        hot_need,
        work - hot_need,
        config.window_slots if window else 0,
        int(able.sum()),
    ], dtype=np.float64)  # fmt: skip
    parts = [o.vehicles, np.broadcast_to(fleet, (n, fleet.size)),
             np.broadcast_to(dispatch, (n, dispatch.size))]  # fmt: skip
    if with_rul:
        rul = o.appended[:, 0]
        parts.append(np.stack([rul, rul_rank(rul, able)], axis=1))
    return np.concatenate(parts, axis=1).astype(np.float32)


def rul_rank(rul: NDArray[np.float64], able: NDArray[np.bool_]) -> NDArray[np.float64]:
    """Each vehicle's place when the vehicles that may drive come first, each group by RUL
    from the most, ties by vehicle index (0: the healthiest that may drive)."""
    order = np.lexsort((np.arange(len(rul)), -rul, ~able))
    rank = np.empty(len(rul))
    rank[order] = np.arange(len(rul))
    return rank


def rul_env(env: BrakeWearFleetEnv, predictor: Any, seed: int = 0) -> gym.Env[Any, Any]:
    """``env`` with ``predictor``'s hot-route RUL appended per vehicle (``rul_mean``, in hot
    shifts): a fitted
    predictor, a registry name (fitted with ``seed`` on ``N_TRAIN_RUNS`` simulated pads of
    the env's wear regime) or ``"oracle"`` (the closed-form expected hot-route RUL).

    Raises:
        ValueError: An unknown name or something that is not a predictor.
    """
    if isinstance(predictor, str):
        if predictor == ORACLE:
            return ExpectedRULObservation(env, routes=("hot",))
        if predictor not in predictor_names():
            raise ValueError(
                f"predictor {predictor!r} is not a registered name; valid are"
                f" {list(predictor_names())}, or a fitted predictor"
            )
        fitted, _ = fit_predictors((predictor,), env.atlas, seed, N_TRAIN_RUNS, env.config.wear)
        predictor = fitted[predictor]
    if not isinstance(predictor, RULPredictor) or isinstance(predictor, type):
        raise ValueError(
            f"predictor must be None, a registered name {list(predictor_names())} or a fitted"
            f" RUL predictor (an instance), got {predictor!r}"
        )
    return FleetRULObservation(env, predictor, fields=("rul_mean",), routes=("hot",))
