"""BrakeWearFleet-v0 as a PettingZoo Parallel env: one agent per vehicle, plus the store.

Each vehicle is an agent (``vehicle_0`` ... ``vehicle_{n-1}``) choosing its own duty
(``Discrete(4)``: hot, mild, park, service). The one decision the fleet shares, the spare
pads to reorder, belongs to a further agent, ``store`` (``Discrete(max_order + 1)``), who
sees the fleet state only. Every agent gets the fleet's reward (minus the shift's cost):
the game is fully cooperative, as the fleet's cost is one bill. Limits across vehicles
(bays, spares) are settled by the same deferral rule as the Gymnasium env
(:mod:`brake_env.env.fleet.shop`), so what the agents ask jointly is what the single env's
MultiDiscrete action asks.

Observations are dicts: ``observation`` (a vehicle: its own ``VEHICLE_FEATURES`` then the
``FLEET_FEATURES``; the store: the fleet features) and ``action_mask`` (int8, one entry per
action, the agent's slice of the single env's mask). ``reset(seed)`` seeds the whole
episode: the same seed gives the same episode in any process. Spaces are made once and
returned as the same objects every call.

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

from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.spaces import as_int, split_observation

STORE = "store"
NAME = "brakewear_fleet_v0"


class BrakeWearFleetParallelEnv(ParallelEnv[str, dict[str, NDArray[Any]], int]):
    """The fleet env for multi-agent RL (PettingZoo Parallel API).

    Args:
        config: The fleet's config (default :class:`FleetConfig`); or keyword arguments.
        render_mode: None, ``"ansi"`` or ``"rgb_array"`` (the single env's frames).
        **kwargs: Fields of :class:`FleetConfig`, and ``atlas``.
    """

    metadata = {"name": NAME, "render_modes": ["ansi", "rgb_array"]}  # noqa: RUF012

    def __init__(
        self, config: FleetConfig | None = None, render_mode: str | None = None, **kwargs: Any
    ) -> None:
        atlas = kwargs.pop("atlas", None)
        self.env = BrakeWearFleetEnv(config, atlas=atlas, render_mode=render_mode, **kwargs)
        self.render_mode = render_mode
        c = self.env.config
        self.n = c.n_vehicles
        self.possible_agents = [f"vehicle_{v}" for v in range(self.n)] + [STORE]
        self.agents: list[str] = []
        box = self.env.observation_space
        assert isinstance(box, spaces.Box)
        v_low, f_low = split_observation(box.low, self.n)
        v_high, f_high = split_observation(box.high, self.n)
        own = spaces.Box(
            np.concatenate([v_low[0], f_low]), np.concatenate([v_high[0], f_high]),
            dtype=np.float32,
        )  # fmt: skip
        fleet = spaces.Box(f_low, f_high, dtype=np.float32)
        n_order = c.max_order + 1
        self._obs_spaces: dict[str, spaces.Dict] = {
            a: spaces.Dict(
                {"observation": own, "action_mask": spaces.Box(0, 1, (4,), dtype=np.int8)}
            )
            for a in self.possible_agents[:-1]
        }
        self._obs_spaces[STORE] = spaces.Dict(
            {"observation": fleet, "action_mask": spaces.Box(0, 1, (n_order,), dtype=np.int8)}
        )
        self._act_spaces: dict[str, spaces.Discrete] = {
            a: spaces.Discrete(4) for a in self.possible_agents[:-1]
        }
        self._act_spaces[STORE] = spaces.Discrete(n_order)

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
            over = "" if self.env.pads is None else " (the episode is over)"
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
        return self.env.render()

    def close(self) -> None:
        self.env.close()

    @property
    def state_space(self) -> spaces.Box:
        """The space of :meth:`state`: the single env's observation space."""
        box = self.env.observation_space
        assert isinstance(box, spaces.Box)
        return box

    def state(self) -> NDArray[np.float32]:
        """The single env's whole observation (every vehicle and the fleet): the global
        state a centralised critic takes."""
        if self.env.pads is None:
            raise RuntimeError(f"{NAME}: call reset() first")
        return self.env._observation()

    def _observations(self, obs: NDArray[np.float32]) -> dict[str, dict[str, NDArray[Any]]]:
        veh, fleet = split_observation(obs, self.n)
        mask = self.env.action_masks().astype(np.int8)
        out = {
            a: {
                "observation": np.concatenate([veh[v], fleet]),
                "action_mask": mask[4 * v : 4 * v + 4],
            }
            for v, a in enumerate(self.possible_agents[:-1])
        }
        out[STORE] = {"observation": fleet.copy(), "action_mask": mask[4 * self.n :]}
        return out

    def _infos(self, info: dict[str, Any]) -> dict[str, dict[str, Any]]:
        """Each vehicle's own entries; the fleet's info under the store."""
        veh = info["vehicles"]
        out: dict[str, dict[str, Any]] = {
            a: {k: x[v] for k, x in veh.items()} for v, a in enumerate(self.possible_agents[:-1])
        }
        out[STORE] = info
        return out


def parallel_env(**kwargs: Any) -> BrakeWearFleetParallelEnv:
    """PettingZoo's factory convention (``module.parallel_env()``): the Parallel env."""
    return BrakeWearFleetParallelEnv(**kwargs)


def env(**kwargs: Any) -> AECEnv[str, dict[str, NDArray[Any]], int]:
    """PettingZoo's factory convention (``module.env()``): the AEC version, agents acting
    in turn (``pettingzoo.utils.parallel_to_aec``), the shift run once all have acted."""
    return parallel_to_aec(BrakeWearFleetParallelEnv(**kwargs))
