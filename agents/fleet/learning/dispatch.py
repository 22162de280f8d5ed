"""What the central fleet policy's network is wrapped in (``fleet-distil``'s policy): a
repair that makes its duties feasible for the fleet as a whole (:func:`cover_needs`), and
the base rule's duties as part of its input (:func:`with_base_duties`), each as a function
for the trained agent and a Gymnasium wrapper for its training envs."""

from __future__ import annotations

from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

from agents.fleet.policies.view import FleetLayout, FleetView
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.rules import fits_capacity, shortfall
from brake_env.env.fleet.shop import HOT, MILD, PARK, SERVICE

I64 = NDArray[np.int64]
DUTIES = 4  # a vehicle's duties (hot, mild, park, service): the one-hot width of BaseDuties


def cover_needs(config: FleetConfig, duty: I64, view: FleetView, min_rul: float = 1.0) -> I64:
    """The duties made feasible for the fleet as a whole, in two steps that a policy deciding
    each vehicle's duty on its own cannot take (it does not count what the others do):

    1. **Services within capacity** between windows: the requests that the spares or the
       free bays cannot take (the workshop would defer them and the vehicle lose a working
       shift) are parked, the least urgent (most hot-route life) first; when only the bays
       are short, among the vehicles that need one (a vehicle down in the shop needs none).
       At a window nobody drives, and the workshop's deferral rule picks among requests.
    2. **Needs covered**: while the hot route is short of ``hot_need``, a vehicle able to
       drive it (at least ``min_rul`` shifts of hot-route life) joins it, the healthiest
       first from, in turn, the drifts beyond their need (the number at work unchanged),
       the parked vehicles, and the drifts' own (a drift short costs half a ramp shift);
       then the mild route is filled from the parked vehicles likewise (a vehicle on the
       ramp beyond its need covers a drift).

    Nothing else changes, so a policy whose duties are feasible and cover the needs, as
    every tuned rule and the rollout planner's are, acts unchanged (checked on the planner's
    labels). A shift short of a ramp truck costs 2,000."""
    duty = np.array(duty, dtype=np.int64)
    if view.window:  # nobody drives: the workshop's own deferral rule picks the fits
        return duty
    fits = duty == SERVICE
    while not fits_capacity(config, False, fits, view.down, view.stock, view.free_bays):
        short_of_pads = int(fits.sum()) > view.stock
        pool = np.flatnonzero(fits if short_of_pads else fits & ~view.down)  # else: bays
        v = pool[np.argmax(view.rul[pool])]  # the least urgent (first of equals)
        fits[v], duty[v] = False, PARK
    counts = np.bincount(duty, minlength=4)
    hot, mild = int(counts[HOT]), int(counts[MILD])
    short_hot, short_mild = shortfall(config, hot, mild, window=False)
    if short_hot == short_mild == 0:
        return duty  # covered already (most shifts)
    able = ~view.down & (view.rul >= min_rul)

    def healthiest(of: NDArray[np.bool_]) -> I64:
        i = np.flatnonzero(of & able)
        return i[np.argsort(-view.rul[i], kind="stable")]

    drifts, idle = healthiest(duty == MILD), healthiest(duty == PARK)
    spare = max(mild - config.mild_need, 0)
    to_hot = np.concatenate([drifts[:spare], idle, drifts[spare:]])[:short_hot]
    duty[to_hot] = HOT
    hot += len(to_hot)
    idle = idle[~np.isin(idle, to_hot)]
    _, k = shortfall(config, hot, int((duty == MILD).sum()), window=False)
    duty[idle[:k]] = MILD
    return duty


class CoverNeeds(gym.ActionWrapper[Any, NDArray[np.int64], NDArray[np.int64]]):
    """The agent's duties made feasible for the fleet (:func:`cover_needs`), read from the
    last observation as ``layout`` says.

    Args:
        env: BrakeWearFleet-v0 with the RUL ``layout`` describes.
        layout: Where the RUL is in the observation.
    """

    def __init__(self, env: gym.Env[Any, NDArray[np.int64]], layout: FleetLayout) -> None:
        super().__init__(env)
        self.layout = layout
        self._view: FleetView | None = None

    def reset(self, **kwargs: Any) -> tuple[Any, dict[str, Any]]:
        obs, info = self.env.reset(**kwargs)
        self._view = FleetView.read(obs, self.layout)
        return obs, info

    def step(
        self, action: NDArray[np.int64]
    ) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        obs, reward, terminated, truncated, info = super().step(action)
        self._view = FleetView.read(obs, self.layout)
        return obs, reward, terminated, truncated, info

    def action(self, action: NDArray[np.int64]) -> NDArray[np.int64]:
        if self._view is None:
            raise RuntimeError("CoverNeeds: step before reset")
        a = np.array(action, dtype=np.int64)
        n = self.layout.n_vehicles
        a[:n] = cover_needs(self.layout.config, a[:n], self._view)
        return a


def with_base_duties(
    obs: NDArray[Any], rule: Any, n: int, view: FleetView | None = None
) -> NDArray[np.float64]:
    """``obs`` with ``rule``'s duty for each vehicle appended, one-hot (n x 4) at the end:
    the input of a policy that learns where to depart from that rule (residual learning).
    ``view``: the observation read already (the rule then acts on it directly)."""
    action = rule.predict(obs)[0] if view is None else rule.act(view)
    duty = np.asarray(action[:n], dtype=np.int64)
    return np.concatenate([np.asarray(obs, dtype=np.float64), np.eye(DUTIES)[duty].ravel()])


class BaseDuties(gym.ObservationWrapper[Any, Any, Any]):
    """The observation with ``rule``'s duties appended (:func:`with_base_duties`).

    Args:
        env: BrakeWearFleet-v0 with the RUL the rule reads.
        rule: A fleet rule (SB3's ``predict`` on the env's observation).
    """

    def __init__(self, env: gym.Env[Any, Any], rule: Any) -> None:
        super().__init__(env)
        self.rule = rule
        self.n = rule.layout.n_vehicles
        space: Any = env.observation_space
        low = np.concatenate([space.low, np.zeros(DUTIES * self.n)]).astype(np.float32)
        high = np.concatenate([space.high, np.ones(DUTIES * self.n)]).astype(np.float32)
        self.observation_space = gym.spaces.Box(low, high, dtype=np.float32)

    def observation(self, observation: Any) -> Any:
        return with_base_duties(observation, self.rule, self.n).astype(np.float32)
