"""The entry points of the registered fleet ids (``brake_env/__init__.py``): ``v0`` and
``BrakeWearFleetSmall-v0`` (the env as configured), ``v2`` (a fleet file with the episode's
cost in the last step's ``info``) and ``v1`` (``v2`` on ``id``-regime fleets only)."""

from __future__ import annotations

import os
from typing import Any

import gymnasium as gym

from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.episode_cost import EpisodeCostInfo
from brake_env.env.shared import make_registered


def make_fleet_env(**kwargs: Any) -> gym.Env[Any, Any]:
    """The registered entry point of the v0 fleet envs (:func:`make_registered`)."""
    return make_registered(BrakeWearFleetEnv, **kwargs)


def make_fleet_env_v2(
    fleet: str | os.PathLike[str] = "default", **kwargs: Any
) -> gym.Env[Any, Any]:
    """``BrakeWearFleet-v2``'s entry point: the benchmark's fleet (a fleet file or a shipped
    fleet's name; ``default``: 12 vehicles, 365 shifts) with the episode's headline and net
    cost in the last step's ``info["episode_cost"]`` (:class:`EpisodeCostInfo`)."""
    return EpisodeCostInfo(make_registered(BrakeWearFleetEnv, fleet=fleet, **kwargs))


def make_fleet_env_v1(
    fleet: str | os.PathLike[str] = "default", **kwargs: Any
) -> gym.Env[Any, Any]:
    """``BrakeWearFleet-v1``: ``v2`` on a fleet of the ``id`` wear regime, where the two
    give the same episodes; other regimes' net credit changed in ``v2``
    (:mod:`.episode_cost`), so ``v1`` refuses them rather than give another figure.

    Raises:
        ValueError: The fleet's regime is not ``id``.
    """
    env = make_fleet_env_v2(fleet, **kwargs)
    regime = env.unwrapped.config.regime  # type: ignore[attr-defined]
    if regime != "id":
        env.close()
        raise ValueError(
            f"BrakeWearFleet-v1 was replaced by BrakeWearFleet-v2 for fleets of the {regime!r}"
            " wear regime: v2 prices the net's credit for pad life left over the regime's"
            " labels, where v1 priced it over a mean-K pad's life and so credited a fresh pad"
            " well above its cost; use"
            ' gym.make("BrakeWearFleet-v2", ...)'
        )
    return env
