"""A trained :class:`~agents.fleet.learning.agent.FleetAgent` as plain arrays, and back: its
policy's weights (every tensor of the torch module's ``state_dict``) and its frozen
observation statistics. Arrays, not SB3's zip: they go into a unit's ``.npz`` and a shipped
baseline's file, read without pickle (:func:`brake_env.output.read_arrays`), and the agent
rebuilt from them decides as the trained one did, bit for bit (tested)."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

from agents.fleet.learning.agent import FleetAgent, build_model
from agents.fleet.policies.view import FleetLayout
from agents.fleet.settings import FleetTraining

WEIGHT = "w:"  # a weight's array name: the prefix, then its state_dict key


def agent_arrays(agent: FleetAgent) -> dict[str, NDArray[Any]]:
    """The agent's policy weights (``w:KEY``), ``obs_mean``, ``obs_var`` and ``clip``."""
    state = agent.model.policy.state_dict()
    out = {f"{WEIGHT}{k}": v.detach().cpu().numpy().copy() for k, v in state.items()}
    out.update(obs_mean=np.asarray(agent.mean).copy(), obs_var=np.asarray(agent.var).copy(),
               clip=np.array(agent.clip, dtype=np.float64))  # fmt: skip
    return out


def agent_from_arrays(
    arrays: Mapping[str, NDArray[Any]], make_env: Callable[[], gym.Env[Any, Any]],
    settings: FleetTraining, layout: FleetLayout, base: Any = None,
) -> FleetAgent:  # fmt: skip
    """The agent :func:`agent_arrays` gave: the model ``settings`` build on ``make_env``'s
    env (:func:`~agents.fleet.learning.agent.build_model`), its weights loaded.

    Raises:
        ValueError: The arrays are not such an agent's, or not of the network ``settings``
            build (a weight missing, left over or of another shape, named).
    """
    import torch as th

    missing = [k for k in ("obs_mean", "obs_var", "clip") if k not in arrays]
    if missing:
        raise ValueError(f"not a saved agent: no {', '.join(missing)}")
    model, _ = build_model(make_env, settings, layout, base)
    want = model.policy.state_dict()
    got = {k.removeprefix(WEIGHT): v for k, v in arrays.items() if k.startswith(WEIGHT)}
    if set(got) != set(want):
        raise ValueError(f"saved agent: weights {sorted(set(want) - set(got))} missing,"
                         f" {sorted(set(got) - set(want))} not of this network")  # fmt: skip
    bad = [k for k, v in got.items() if tuple(v.shape) != tuple(want[k].shape)]
    if bad:
        raise ValueError(f"saved agent: weights {bad} are of another shape than the network's")
    model.policy.load_state_dict({k: th.as_tensor(np.asarray(v)) for k, v in got.items()})
    return FleetAgent(model, layout, np.asarray(arrays["obs_mean"]),
                      np.asarray(arrays["obs_var"]), float(arrays["clip"]),
                      reorder=settings.reorder, cover=settings.cover_needs,
                      base=base)  # fmt: skip
