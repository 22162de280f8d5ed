"""BrakeWearFleet-v0 as a PettingZoo Parallel env: one agent per vehicle, plus the store.

Each vehicle is an agent (``vehicle_0`` ... ``vehicle_{n-1}``) choosing its own duty
(``Discrete(4)``: hot, mild, park, service). The one decision the fleet shares, the spare
pads to reorder, belongs to a further agent, ``store`` (``Discrete(max_order + 1)``), who
sees the fleet state only; or, with ``spares=(s, S)``, to an (s, S) rule
(:class:`~brake_env.env.fleet.spares.SparesRule`), and then every agent is a vehicle with
the same spaces (what SuperSuit-style vectorisation and parameter sharing need). Every
agent gets the fleet's reward (minus the shift's cost): the game is fully cooperative, as
the fleet's cost is one bill. Limits across vehicles (bays, spares) are settled by the same
deferral rule as the Gymnasium env (:mod:`brake_env.env.fleet.shop`), so what the agents
ask jointly is what the single env's MultiDiscrete action asks.

Observations are dicts: ``observation`` (a vehicle: its view,
:func:`~brake_env.env.fleet.agent_view.vehicle_views`: its own ``VEHICLE_FEATURES``, the
``FLEET_FEATURES``, the needs, window slots and vehicles able to drive this shift, and with
``predictor=`` its RUL and its rank by RUL in the fleet; names in ``env.view_features``;
the store: the fleet features) and ``action_mask`` (int8, one entry per action, the agent's
slice of the single env's mask). ``reset(seed)`` seeds the whole episode: the same seed
gives the same episode in any process. Spaces are made once and returned as the same
objects every call.

Infos (``infos="flat"``, the default) are flat dicts of numbers with the same keys every
step, which clients stack into arrays (TorchRL's ``PettingZooWrapper``): a vehicle's own
entries (route, events, replaced, failed, ...), whether it was deferred or refused, its
RUL with a predictor, and the fleet's shift, cost terms (``cost_*``) and counts
(``count_*``). The detailed breakdown (``deferred`` and ``refused`` with reasons, the truth,
the predictor's estimates) is :meth:`BrakeWearFleetParallelEnv.detailed_info`, or the
infos themselves with ``infos="nested"`` (each vehicle its own entries, the store the
single env's whole info).

Needs ``pettingzoo`` (the ``fleet`` extra).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray
from pettingzoo import AECEnv, ParallelEnv
from pettingzoo.utils.conversions import parallel_to_aec

from brake_env.env.fleet.agent_view import rul_env, vehicle_views, view_features, view_space
from brake_env.env.fleet.config import COST_TERMS, FleetConfig
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.shop import SERVICE
from brake_env.env.fleet.spaces import FLEET_FEATURES, N_VF, as_int
from brake_env.env.fleet.spares import SparesRule

STORE = "store"
NAME = "brakewear_fleet_v0"
INFO_MODES = ("flat", "nested", "none")
# info["counts"] of a step, in the env's order (tested equal): the flat infos' count_* keys.
COUNT_KEYS = ("window_fits", "shop_fits", "visits", "corrective_fits", "failures",
              "breakdowns", "deferred", "refused", "ordered", "arrived", "on_hot", "on_mild",
              "shortfall", "mild_shortfall", "stock", "events", "downtime")  # fmt: skip


class BrakeWearFleetParallelEnv(ParallelEnv[str, dict[str, NDArray[Any]], int]):
    """The fleet env for multi-agent RL (PettingZoo Parallel API).

    Args:
        config: The fleet's config (default :class:`FleetConfig`); or keyword arguments.
        render_mode: None, ``"ansi"`` or ``"rgb_array"`` (the single env's frames).
        predictor: None (no RUL in the view), a fitted RUL predictor, a registered
            predictor's name (fitted on simulated pads with ``predictor_seed``) or
            ``"oracle"`` (the closed-form expected hot-route RUL; it reads the truth):
            each vehicle's view gains its RUL and its rank by RUL
            (:func:`~brake_env.env.fleet.agent_view.rul_env`).
        spares: None (the ``store`` agent reorders) or an (s, S) pair or
            :class:`~brake_env.env.fleet.spares.SparesRule`: spares by that rule, no
            ``store`` agent, every agent with the same spaces.
        infos: ``"flat"`` (numbers, the same keys every step), ``"nested"`` (the
            detailed layout; module docstring) or ``"none"`` (empty dicts: the fastest
            through TorchRL, which turns every info entry of every agent into a tensor
            each step; :meth:`detailed_info` still has the whole info).
        predictor_seed: Seed of the fit of a predictor given by name.
        **kwargs: Fields of :class:`FleetConfig`, and ``atlas``.
    """

    metadata = {"name": NAME, "render_modes": ["ansi", "rgb_array"]}  # noqa: RUF012

    def __init__(
        self, config: FleetConfig | None = None, render_mode: str | None = None, *,
        predictor: Any = None, spares: Any = None, infos: str = "flat",
        predictor_seed: int = 0, **kwargs: Any,
    ) -> None:  # fmt: skip
        if infos not in INFO_MODES:
            raise ValueError(f"{NAME}: infos must be one of {INFO_MODES}, got {infos!r}")
        atlas = kwargs.pop("atlas", None)
        self.base = BrakeWearFleetEnv(config, atlas=atlas, render_mode=render_mode, **kwargs)
        self.env = self.base if predictor is None else rul_env(self.base, predictor, predictor_seed)
        self.spares = None if spares is None else SparesRule.of(spares)
        self.render_mode, self.infos, self.with_rul = render_mode, infos, predictor is not None
        c = self.base.config
        self.n = c.n_vehicles
        self.vehicles = [f"vehicle_{v}" for v in range(self.n)]
        self.possible_agents = self.vehicles + ([] if self.spares else [STORE])
        self.agents: list[str] = []
        self.view_features = view_features(self.with_rul)
        box = self.base.observation_space
        assert isinstance(box, spaces.Box)
        own = view_space(c, box, self.with_rul)
        self._obs_spaces: dict[str, spaces.Dict] = {
            a: spaces.Dict(
                {"observation": own, "action_mask": spaces.Box(0, 1, (4,), dtype=np.int8)}
            )
            for a in self.vehicles
        }
        self._act_spaces: dict[str, spaces.Discrete] = {
            a: spaces.Discrete(4) for a in self.vehicles
        }
        if self.spares is None:
            nf, n_order = slice(self.n * N_VF, self.n * N_VF + len(FLEET_FEATURES)), c.max_order + 1
            fleet = spaces.Box(box.low[nf], box.high[nf], dtype=np.float32)
            mask = spaces.Box(0, 1, (n_order,), dtype=np.int8)
            self._obs_spaces[STORE] = spaces.Dict({"observation": fleet, "action_mask": mask})
            self._act_spaces[STORE] = spaces.Discrete(n_order)
        self._state: NDArray[np.float32] | None = None
        self._info: dict[str, Any] = {}

    def observation_space(self, agent: str) -> spaces.Dict:
        return self._obs_spaces[agent]

    def action_space(self, agent: str) -> spaces.Discrete:
        return self._act_spaces[agent]

    def reset(
        self, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, dict[str, NDArray[Any]]], dict[str, dict[str, Any]]]:
        obs, info = self.env.reset(seed=seed, options=options)
        self.agents = list(self.possible_agents)
        return self._observations(obs), self._infos(info)

    def step(self, actions: dict[str, int]) -> tuple[
        dict[str, dict[str, NDArray[Any]]],
        dict[str, float],
        dict[str, bool],
        dict[str, bool],
        dict[str, dict[str, Any]],
    ]:  # fmt: skip
        """Agents missing from ``actions`` park (a vehicle) or order nothing (the store).

        An action is an integer (a Python int, a numpy integer scalar or a 0-d integer
        array) in the agent's ``Discrete`` space; anything else (``2.9``, ``"1"``,
        ``True``, NaN, None, an array) raises one ``ValueError`` naming the agent and the
        value, never truncated to a neighbouring action."""
        if not self.agents:
            over = "" if self.base.pads is None else " (the episode is over)"
            raise RuntimeError(f"{NAME}: call reset() first{over}")
        if not isinstance(actions, Mapping):
            raise ValueError(f"{NAME}: actions must be a dict of agent to action, got {actions!r}")
        unknown = sorted(set(actions) - set(self.agents), key=str)
        if unknown:
            raise ValueError(
                f"{NAME}: actions for unknown or done agents {unknown} (live agents: {self.agents})"
            )
        joint = np.full(self.n + 1, 2, dtype=np.int64)  # park...
        joint[-1] = 0  # ...and order nothing
        for i, agent in enumerate(self.possible_agents):
            if agent in actions:
                joint[i] = self._action(agent, actions[agent])
        if self.spares is not None:
            shop, fits = self.base.shop, int((joint[:-1] == SERVICE).sum())
            joint[-1] = self.spares.order(
                shop.stock, shop.in_transit, fits, self.base.config.max_order
            )
        obs, reward, terminated, truncated, info = self.env.step(joint)
        observations, infos = self._observations(obs), self._infos(info)
        rewards = dict.fromkeys(self.agents, float(reward))
        terms = dict.fromkeys(self.agents, bool(terminated))
        truncs = dict.fromkeys(self.agents, bool(truncated))
        if terminated or truncated:
            self.agents = []
        return observations, rewards, terms, truncs, infos

    def _action(self, agent: str, value: object) -> int:
        n = self._act_spaces[agent].n
        x = as_int(value)
        if x is None:
            shape = getattr(value, "shape", None)
            what = f"an array of shape {shape}" if shape else "not an integer"
            raise ValueError(
                f"{NAME}: {agent}'s action {value!r} is {what}; it must be one int"
                f" in 0-{n - 1} (Discrete({n}))"
            )
        if not 0 <= x < n:
            raise ValueError(f"{NAME}: {agent}'s action {x} is outside 0-{n - 1} (Discrete({n}))")
        return x

    def render(self) -> Any:
        return self.base.render()

    def close(self) -> None:
        self.env.close()

    @property
    def state_space(self) -> spaces.Box:
        """The space of :meth:`state`: the single env's observation space (with the
        predictor's RUL appended per vehicle when there is one)."""
        box = self.env.observation_space
        assert isinstance(box, spaces.Box)
        return box

    def state(self) -> NDArray[np.float32]:
        """The single env's whole observation (every vehicle and the fleet, and each
        vehicle's RUL with a predictor): the global state a centralised critic takes."""
        if self._state is None:
            raise RuntimeError(f"{NAME}: call reset() first")
        return self._state.copy()

    def detailed_info(self) -> dict[str, Any]:
        """The single env's whole info of the last reset or step (nested: costs, counts,
        ``deferred`` and ``refused`` with reasons, every vehicle's entries, the truth, and
        the predictor's ``rul_estimate``)."""
        if self._state is None:
            raise RuntimeError(f"{NAME}: call reset() first")
        return self._info

    def _observations(self, obs: NDArray[np.float32]) -> dict[str, dict[str, NDArray[Any]]]:
        self._state = np.asarray(obs, dtype=np.float32)
        views = vehicle_views(obs, self.base.config, self.with_rul)
        mask = self.base.action_masks().astype(np.int8)
        out = {
            a: {"observation": views[v], "action_mask": mask[4 * v : 4 * v + 4]}
            for v, a in enumerate(self.vehicles)
        }
        if self.spares is None:
            fleet = self._state[self.n * N_VF : self.n * N_VF + len(FLEET_FEATURES)].copy()
            out[STORE] = {"observation": fleet, "action_mask": mask[4 * self.n :]}
        return out

    def _infos(self, info: dict[str, Any]) -> dict[str, dict[str, Any]]:
        """Flat: module docstring. Nested: each vehicle's own entries; the fleet's whole
        info under the store."""
        self._info = info
        veh = info["vehicles"]
        if self.infos == "none":
            return {a: {} for a in self.possible_agents}
        if self.infos == "nested":
            out: dict[str, dict[str, Any]] = {
                a: {k: x[v] for k, x in veh.items()} for v, a in enumerate(self.vehicles)
            }
            if self.spares is None:
                out[STORE] = info
            return out
        shared = flat_fleet_info(info)
        deferred = {v for v, *_ in info["deferred"]}
        refused = {v for v, *_ in info["refused"]}
        rul = info.get("rul_estimate", {}).get("rul_mean")
        out = {}
        for v, a in enumerate(self.vehicles):
            own = {k: float(x[v]) for k, x in veh.items()}
            own["deferred"], own["refused"] = float(v in deferred), float(v in refused)
            if self.with_rul:
                own["rul"] = float(rul[v]) if rul is not None else float(self._rul(v))
            out[a] = own | shared
        if self.spares is None:
            out[STORE] = dict(shared)
        return out

    def _rul(self, v: int) -> float:
        """Vehicle ``v``'s RUL as its view shows it (the closed-form oracle puts none in the
        info)."""
        assert self._state is not None
        return float(self._state[self.base.observation_space.shape[0] + v])  # type: ignore[index]


def flat_fleet_info(info: dict[str, Any]) -> dict[str, float]:
    """The fleet's part of a flat info: shift, window, ``cost_<term>`` of every cost term
    and ``count_<name>`` of every count (0 where the step has none, as after a reset)."""
    out = {"shift": float(info["shift"]), "window": float(info["window"])}
    out |= {f"cost_{k}": float(info["costs"].get(k, 0.0)) for k in COST_TERMS}
    out |= {f"count_{k}": float(info["counts"].get(k, 0)) for k in COUNT_KEYS}
    return out


def parallel_env(**kwargs: Any) -> BrakeWearFleetParallelEnv:
    """PettingZoo's factory convention (``module.parallel_env()``): the Parallel env."""
    return BrakeWearFleetParallelEnv(**kwargs)


def env(**kwargs: Any) -> AECEnv[str, dict[str, NDArray[Any]], int]:
    """PettingZoo's factory convention (``module.env()``): the AEC version, agents acting
    in turn (``pettingzoo.utils.parallel_to_aec``), the shift run once all have acted."""
    return parallel_to_aec(BrakeWearFleetParallelEnv(**kwargs))
