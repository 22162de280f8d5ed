"""TorchRL MAPPO from scratch on a suite's fleet (:func:`~agents.fleet.learning.marl.train_marl`
with no teacher), saved as the shared actor's weights, loaded for ``fleet-score`` as a flat
policy (:class:`~agents.fleet.learning.marl.MarlFleetPolicy`: every vehicle's view read from
the suite's observation, its duty from the shared actor, spares by the config's (s, S) rule).

The PettingZoo env carries the hot route's RUL of the suite's ``observe`` predictor, fitted
as the suite fits it (the policy reads that column of the scored observation). Episode seeds
are moved to :data:`~agents.fleet.benchmark.training.config.TRAIN_SEED0` on (TorchRL seeds
the env with the settings' seed, a dev seed).
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np

from agents.fleet.benchmark.training.config import TRAIN_SEED0, TrainingConfig, suite_env
from agents.fleet.learning.marl import MarlFleetPolicy, MarlTraining, train_marl
from agents.fleet.policies.view import FleetLayout
from brake_env.env.fleet.parallel import BrakeWearFleetParallelEnv
from brake_env.env.fleet.spares import SparesRule
from brake_env.model.atlas import Atlas
from brake_env.prognostics.registry import ORACLE

SHIPPED = Path(__file__).parents[1] / "entries" / "default" / "mappo.pt"


class TrainingEpisodes(BrakeWearFleetParallelEnv):
    """The PettingZoo fleet env with its episode seeds moved by :data:`TRAIN_SEED0`."""

    def reset(self, seed: int | None = None, options: dict[str, Any] | None = None) -> Any:
        return super().reset(seed=None if seed is None else TRAIN_SEED0 + seed, options=options)


def train(
    config: TrainingConfig, atlas: Atlas, log: Any = None
) -> tuple[MarlFleetPolicy, dict[str, Any]]:
    """MAPPO on ``config``'s suite: (the policy, ``training_steps`` in shifts and
    ``cpu_seconds``)."""
    if config.algorithm != "mappo" or config.spares is None:
        raise ValueError(f"mappo.train: config {config.path} is not a mappo config")
    t0 = time.process_time()
    make, fitted = suite_env(config.suite, atlas)
    fleet = make().unwrapped.config
    predictor = ORACLE if fitted is None else fitted.predictor

    def make_par() -> TrainingEpisodes:
        return TrainingEpisodes(fleet, predictor=predictor, spares=config.spares, infos="none",
                                atlas=atlas)  # fmt: skip

    result = train_marl(make_par, config.settings, log=log)
    policy = flat(result.policy.actor, fleet, config.spares)
    return policy, {"training_steps": int(config.settings.frames),
                    "cpu_seconds": time.process_time() - t0}  # fmt: skip


def flat(actor: Any, fleet: Any, spares: Any) -> MarlFleetPolicy:
    """The shared actor as a policy on the suite's observation (every route's RUL)."""
    return MarlFleetPolicy(actor, fleet, SparesRule.of(spares), layout=FleetLayout.of(fleet))


def save(
    policy: MarlFleetPolicy, path: str | Path, meta: dict[str, Any], config: TrainingConfig
) -> Path:
    """The actor's weights, the settings and spares rule, and ``meta`` (torch's format)."""
    import torch

    doc = {"state": policy.actor.state_dict(), "n_vehicles": policy.config.n_vehicles,
           "spares": list(config.spares or ()), "meta": meta,
           "settings": dataclasses.asdict(config.settings)}  # fmt: skip
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    torch.save(doc, out)
    return out


def load(path: str | Path, env: Any) -> MarlFleetPolicy:
    """The policy saved at ``path`` acting on ``env`` (the suite's env).

    Raises:
        ValueError: Not such a file, or saved for another number of vehicles.
    """
    import torch

    from agents.fleet.learning.marl_torch import make_networks

    try:
        doc = torch.load(path, weights_only=True)
        st = MarlTraining(**doc["settings"])
    except (OSError, KeyError, TypeError, RuntimeError) as e:
        raise ValueError(f"{path}: not a saved MAPPO policy ({e})") from None
    fleet = env.unwrapped.config
    if doc["n_vehicles"] != fleet.n_vehicles:
        raise ValueError(f"{path}: trained for {doc['n_vehicles']} vehicles, the env has"
                         f" {fleet.n_vehicles}")  # fmt: skip
    d = len(doc["state"]["0.loc"])
    nets = make_networks(SimpleNamespace(n=fleet.n_vehicles), st, np.zeros(d), np.ones(d))
    nets.actor_net.load_state_dict(doc["state"])
    return flat(nets.actor_net, fleet, tuple(doc["spares"]))


def factory(env: Any) -> MarlFleetPolicy:
    """``fleet-score``'s factory: the shipped policy (trained on the default suite)."""
    return load(SHIPPED, env)
