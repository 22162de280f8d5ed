"""PettingZoo per-agent policies in ``fleet-score``: driven through the fleet's Parallel env.

A per-agent policy is what PettingZoo's own docs write, ``actions = {agent:
policy(observations[agent], agent) for agent in env.agents}``: a callable taking an agent's
observation and the agent's name (two positional parameters), or a mapping from each agent
to a callable of its observation. The agents are the fleet's PettingZoo agents
(:mod:`brake_env.env.fleet.parallel`): ``vehicle_0`` ... ``vehicle_{n-1}`` (``Discrete(4)``:
hot, mild, park, service) and ``store`` (``Discrete(max_order + 1)``: pads to reorder). An
agent's observation is a dict of ``observation`` (a vehicle: its view, the Parallel env's
``view_features``, followed by its RUL on each route from the suite's ``observe``
predictor, the flat env's appended values; the store: the fleet features) and
``action_mask``; ``env.state()`` is the flat observation a centralised policy reads.

The Parallel env runs on the suite's scored env itself (:class:`SuiteParallelEnv`), so the
episodes, the RUL and the costs are those a flat policy is scored on; every agent's action is
checked against its mask, and one outside it is named with the agent and the shift. A
factory reaches that Parallel env (for its agents, spaces or ``state()``) with
:func:`parallel_env_of` on the env it is given.
"""

from __future__ import annotations

import inspect
import weakref
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
from gymnasium import spaces

from agents.fleet.evaluation.costs import EpisodeCost
from brake_env.env.fleet.config import COST_TERMS
from brake_env.env.fleet.episode_cost import life_value
from brake_env.env.fleet.parallel import BrakeWearFleetParallelEnv
from brake_env.env.fleet.route_rul import ROUTE_NAMES
from brake_env.env.fleet.spaces import FLEET_FEATURES, N_VF


def is_per_agent(policy: Any) -> bool:
    """A mapping of agents to callables, or a callable of (observation, agent)."""
    if isinstance(policy, Mapping):
        return True
    if hasattr(policy, "predict") or not callable(policy):
        return False
    try:
        params = inspect.signature(policy).parameters.values()
    except (TypeError, ValueError):  # a builtin without a signature: a flat callable
        return False
    positional = [p for p in params if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
    return len([p for p in positional if p.default is p.empty]) == 2


class SuiteParallelEnv(BrakeWearFleetParallelEnv):
    """The fleet's PettingZoo Parallel env over a suite's scored env (its wrappers and
    RUL): each vehicle's view gains that env's appended RUL (``rul_hot``, ``rul_mild``)."""

    def __init__(self, scored: Any) -> None:
        base = scored.unwrapped
        super().__init__(base.config, atlas=base.atlas, infos="none")
        self.base, self.env = base, scored
        self._cut = self.n * N_VF + len(FLEET_FEATURES)
        box = scored.observation_space
        k = (box.shape[0] - self._cut) // self.n
        self.view_features = (*self.view_features, *(f"rul_{r}" for r in ROUTE_NAMES[:k]))
        rul = slice(self._cut, None)
        lo, hi = box.low[rul].reshape(self.n, k), box.high[rul].reshape(self.n, k)
        for v, a in enumerate(self.vehicles):
            own = self._obs_spaces[a]["observation"]
            assert isinstance(own, spaces.Box)
            low, high = np.append(own.low, lo[v]), np.append(own.high, hi[v])
            view = spaces.Box(low, high, dtype=np.float32)
            mask = self._obs_spaces[a]["action_mask"]
            self._obs_spaces[a] = spaces.Dict({"observation": view, "action_mask": mask})

    def _observations(self, obs: Any) -> dict[str, dict[str, Any]]:
        full = np.asarray(obs, dtype=np.float32)
        out = super()._observations(full[: self._cut])
        rul = full[self._cut :].reshape(self.n, -1)
        for v, a in enumerate(self.vehicles):
            own = out[a]["observation"]
            out[a]["observation"] = np.append(own, rul[v]).astype(np.float32)
        self._state = full  # state(): the flat observation, RUL included
        return out


_PARALLEL: weakref.WeakKeyDictionary[Any, SuiteParallelEnv] = weakref.WeakKeyDictionary()


def parallel_env_of(scored: Any) -> SuiteParallelEnv:
    """The Parallel env that drives a per-agent policy on ``scored`` (the env its factory
    is given): made once per env, so the factory and ``fleet-score`` share it."""
    if scored not in _PARALLEL:
        _PARALLEL[scored] = SuiteParallelEnv(scored)
    return _PARALLEL[scored]


class PerAgent:
    """A per-agent policy scored through :class:`SuiteParallelEnv` on ``scored``'s episodes."""

    kind = "per-agent (PettingZoo)"

    def __init__(self, policy: Any, scored: Any) -> None:
        self.policy, self.penv = policy, parallel_env_of(scored)
        self.name = getattr(policy, "name", type(policy).__name__)
        if isinstance(policy, Mapping):
            missing = [a for a in self.penv.possible_agents if not callable(policy.get(a))]
            if missing:
                raise ValueError(f"the factory's per-agent mapping has no callable for"
                                 f" {missing} (agents: {self.penv.possible_agents})")  # fmt: skip

    def act(self, agent: str, observation: dict[str, Any]) -> Any:
        if isinstance(self.policy, Mapping):
            fn: Callable[..., Any] = self.policy[agent]
            return fn(observation)
        return self.policy(observation, agent)

    def run(self, seed: int) -> EpisodeCost:
        """One episode from ``seed``, every agent's action checked against its mask.

        Raises:
            ValueError: An action outside the agent's mask or space (the agent, the shift).
        """
        env, base = self.penv, self.penv.base
        obs, _ = env.reset(seed=seed)
        terms = dict.fromkeys(COST_TERMS, 0.0)
        counts: dict[str, float] = {}
        shifts = 0
        while env.agents:
            actions = {}
            for a in env.agents:
                x = self.act(a, obs[a])
                mask = obs[a]["action_mask"]
                if not _allowed(x, mask):
                    ok = np.flatnonzero(mask).tolist()
                    raise ValueError(f"{self.name} broke {a}'s mask at shift {shifts}: action"
                                     f" {x!r}, allowed {ok}")  # fmt: skip
                actions[a] = x
            obs, *_ = env.step(actions)
            info = env.detailed_info()
            for k, v in info["costs"].items():
                terms[k] += v
            for k, v in info["counts"].items():
                counts[k] = counts.get(k, 0) + v
            shifts += 1
        n = base.config.n_vehicles
        return EpisodeCost(seed, n, shifts, terms, counts, base.config.costs.pad, life_value(base))


def _allowed(x: Any, mask: Any) -> bool:
    a = np.asarray(x)
    if a.shape != () or not np.issubdtype(a.dtype, np.integer):
        return False
    return 0 <= int(a) < len(mask) and bool(mask[int(a)])
