"""The rollout planner distilled into a policy shared by every vehicle (issue 32, items 2-3):
the same labels as the central policy (:mod:`.distil`), read as the PettingZoo env's
per-vehicle views, cloned by TorchRL's networks (:mod:`agents.fleet.learning.marl_torch`).

A label is the fleet's observation (every vehicle's hot- and mild-route RUL with its
interval) and the planner's duty for each vehicle. The shared policy sees what
:func:`~brake_env.env.fleet.agent_view.vehicle_views` gives a vehicle of the
:class:`~brake_env.env.fleet.parallel.BrakeWearFleetParallelEnv`: its own state, the
fleet's, the shift's needs and slots, the vehicles able to drive, its hot-route RUL and its
rank by it; with ``base_input`` (the default, as for the central policy) also the base
rule's duty for it, one-hot: the dispatcher's default, which the planner leaves on a few
shifts a vehicle (:func:`~agents.fleet.learning.marl.shared_views`). So each label gives
one sample per vehicle. Spares follow the base rule's (s, S), as the planner's do. The
policy runs on the env with the study's RUL fields (the base rule reads the interval; the
views take the hot-route mean) on the study's evaluation episodes, each decision timed;
with the training's ``cover_needs`` (the default) the vehicles' duties, decided apart, go
through the central policy's dispatch repair
(:func:`~agents.fleet.learning.dispatch.cover_needs`).
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from agents.fleet.evaluation.costs import run_episodes
from agents.fleet.learning.imitation import Demonstrations, concat
from agents.fleet.learning.marl import (
    MarlFleetPolicy,
    MarlTraining,
    shared_views,
    standardise_stats,
)
from agents.fleet.settings import TRAIN_SEED0
from agents.fleet.study.build import Fitted, episodes_dict, single_thread
from agents.fleet.study.distil_job import Job, Timed, demo_of
from brake_env.model.atlas import Atlas


def recorded(job: Job, demo: Demonstrations) -> Any:
    """The labels as per-vehicle samples (:class:`~agents.fleet.learning.marl_torch.Recorded`):
    each vehicle's view, with the base rule's duty for it with ``base_input``."""
    from agents.fleet.learning.marl_torch import Recorded  # loads torch and TorchRL

    cfg, lay, base = job.study.fleet, job.layout(), job.base_input()
    views = np.stack([shared_views(o, cfg, lay, base) for o in demo.obs])
    masks = demo.masks.reshape(len(demo.obs), cfg.n_vehicles, 4)
    return Recorded(views, masks, demo.actions, demo.rewards, [int(s) for s in demo.starts])


def shared_seed_unit(
    job: Job, atlas: Atlas, fitted: Fitted | None, seed: int, labels: list[dict[str, Any]]
) -> dict[str, Any]:
    """One training seed of the shared policy: the clone of every label (TorchRL's networks,
    masked cross-entropy), then the study's evaluation episodes with each decision timed."""
    return single_thread(_shared, job, atlas, fitted, seed, labels)


def shared_clone(
    job: Job, atlas: Atlas, fitted: Fitted | None, seed: int, demo: Demonstrations
) -> tuple[Any, float, int]:
    """The shared policy cloned from ``demo`` (TorchRL's networks, masked cross-entropy):
    (its :class:`~agents.fleet.learning.marl.MarlFleetPolicy`, its agreement with the
    labels, the per-vehicle samples)."""
    # Here, not at the top: marl_torch loads torch and TorchRL, parallel loads PettingZoo.
    from agents.fleet.learning.marl_torch import fit_clone, make_networks
    from brake_env.env.fleet.parallel import BrakeWearFleetParallelEnv

    tr = job.distil.training
    st = MarlTraining(frames=0, imitation_episodes=1, imitation_epochs=tr.imitation_epochs,
                      imitation_lr=tr.imitation_lr, hidden=tr.net_arch[-1],
                      depth=len(tr.net_arch), seed=TRAIN_SEED0 + 100 * seed)  # fmt: skip
    data = recorded(job, demo)
    predictor = fitted.predictor if fitted is not None else job.distil.predictor
    par = BrakeWearFleetParallelEnv(job.study.fleet, predictor=predictor,
                                    spares=job.training(0).reorder, infos="none",
                                    atlas=atlas)  # fmt: skip
    nets = make_networks(par, st, *standardise_stats(data.views))
    agreement = fit_clone(nets, data, st)
    assert par.spares is not None
    policy = MarlFleetPolicy(nets.actor_net, job.study.fleet, par.spares, tr.cover_needs,
                             job.base_input(), job.layout())  # fmt: skip
    return policy, agreement, int(data.actions.size)


def _shared(
    job: Job, atlas: Atlas, fitted: Fitted | None, seed: int, labels: list[dict[str, Any]]
) -> dict[str, Any]:
    t0 = time.perf_counter()
    demo = concat([demo_of(d) for d in labels])
    clone, agreement, samples = shared_clone(job, atlas, fitted, seed, demo)
    policy = Timed(clone)
    train_s = time.perf_counter() - t0
    env = job.env(atlas, fitted)  # the RUL the base rule reads; the views take the hot mean
    eps = run_episodes(env, policy, job.study.eval_seeds(), check_masks=True)
    return {
        "predictor": job.distil.predictor, "seed": seed, "samples": samples,
        "agreement": agreement, "nll": float("nan"),
        "curve": {"timesteps": np.zeros(0), "cost": np.zeros(0)},
        "episodes": episodes_dict(eps),
        "seconds": {"train": train_s, "evaluate": time.perf_counter() - t0 - train_s},
        "seconds_per_decision": policy.seconds / max(policy.calls, 1),
    }  # fmt: skip
