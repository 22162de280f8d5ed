"""The rollout planner distilled into a central policy (issue 32, item 1), as units on a
:class:`~brake_env.runner.Runner` on top of a finished fleet study (its settings, the
predictor's best tuned heuristic, the planner's horizon and samples).

**Labels, once for every seed** (:func:`label_unit`, ``label_chunk`` episodes a unit):
round 0, the planner (:class:`~agents.fleet.policies.rollout.RolloutPolicy` on the tuned
heuristic, the predictor's RUL with its interval) drives and labels its own shifts; in each
DAgger round after it, a clone of every label so far (fitted from
:data:`~agents.fleet.settings.LABEL_SEED0`, the same in every unit of the round) drives and
the planner labels the states the clone reaches, where a clone's mistakes take the fleet.
The planner's order is the base rule's (s, S) on its services, so the policy decides
duties and the order is that rule's (:class:`~agents.fleet.learning.agent.ReorderBy`):
the labels are exact. Each unit counts the labels that the policy's feasibility repair
(:func:`~agents.fleet.learning.dispatch.cover_needs`) would change: the repair's cost to the
planner's own decisions.

**Each training seed** (:func:`seed_unit`): MaskablePPO cloned from all the labels (masked
cross-entropy, the value head on their discounted returns), PPO for
``training.timesteps`` shifts if any (learning curve on the study's curve episodes), then
the study's evaluation episodes, each decision timed; the trained agent's weights and
observation statistics are kept (:func:`central_nets`: the run's ``nets.npz``).
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import replace
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents.fleet.evaluation.costs import run_episodes
from agents.fleet.learning.agent import FleetAgent, ReorderBy, train_on_labels
from agents.fleet.learning.agent_arrays import agent_arrays
from agents.fleet.learning.dispatch import cover_needs
from agents.fleet.learning.imitation import concat, record
from agents.fleet.policies.view import FleetView
from agents.fleet.settings import LABEL_SEED0, TRAIN_SEED0
from agents.fleet.study.build import Fitted, episodes_dict, single_thread
from agents.fleet.study.curve import LearningCurve, mean_cost
from agents.fleet.study.distil_job import Job, Timed, demo_dict, demo_of
from agents.fleet.study.distil_shared import shared_seed_unit
from brake_env.model.atlas import Atlas
from brake_env.runner import Later, Runner, Unit
from brake_env.units import open_store

UNITS = "units"


def label_unit(
    job: Job, atlas: Atlas, fitted: Fitted | None, round_: int, seeds: list[int],
    earlier: list[dict[str, Any]],
) -> dict[str, Any]:  # fmt: skip
    """The planner's labels on ``seeds``' episodes: it drives in round 0; later, a clone of
    the ``earlier`` labels drives (:func:`labelling_clone`)."""
    return single_thread(_labels, job, atlas, fitted, round_, seeds, earlier)


def _labels(
    job: Job, atlas: Atlas, fitted: Fitted | None, round_: int, seeds: list[int],
    earlier: list[dict[str, Any]],
) -> dict[str, Any]:  # fmt: skip
    t0 = time.perf_counter()
    planner = Timed(job.planner(atlas))
    env = ReorderBy(job.env(atlas, fitted), *job.training(0).reorder)
    actor = None
    if round_ > 0:
        clone = labelling_clone(job, atlas, fitted, earlier)

        def actor(obs: NDArray[Any], mask: NDArray[np.bool_]) -> NDArray[np.int64]:
            return np.asarray(clone.predict(obs)[0][:-1], dtype=np.int64)

    demo = record(env, planner, seeds, drop_order=True, actor=actor)
    lay, cfg = job.layout(), job.study.fleet
    repaired = sum(not np.array_equal(cover_needs(cfg, a, FleetView.read(o, lay)), a)
                   for o, a in zip(demo.obs, demo.actions, strict=True))  # fmt: skip
    return {
        **demo_dict(demo), "round": round_, "seeds": np.array(seeds),
        "planner_seconds": planner.seconds, "decisions": planner.calls,
        "repaired": int(repaired),
        "agreement": float((demo.taken == demo.actions).all(axis=1).mean()),
        "seconds": time.perf_counter() - t0,
    }  # fmt: skip


def labelling_clone(
    job: Job, atlas: Atlas, fitted: Fitted | None, earlier: list[dict[str, Any]]
) -> Any:
    """The clone that drives a DAgger round: every earlier label, no PPO, fitted from
    :data:`LABEL_SEED0` (the same clone in every unit of the round)."""
    st = replace(job.training(LABEL_SEED0), timesteps=0)
    labels = concat([demo_of(d) for d in earlier])
    return train_on_labels(lambda: job.env(atlas, fitted), job.layout(), st, labels,
                           base=job.base_input())  # fmt: skip


def seed_unit(
    job: Job, atlas: Atlas, fitted: Fitted | None, seed: int, labels: list[dict[str, Any]]
) -> dict[str, Any]:
    """One training seed: the clone of every label, PPO if ``training.timesteps``, then the
    study's evaluation episodes with each decision timed."""
    return single_thread(_seed, job, atlas, fitted, seed, labels)


def _seed(
    job: Job, atlas: Atlas, fitted: Fitted | None, seed: int, labels: list[dict[str, Any]]
) -> dict[str, Any]:
    t0 = time.perf_counter()
    st = job.training(TRAIN_SEED0 + 100 * seed)
    lay, study, base = job.layout(), job.study, job.base_input()
    curve_env = job.env(atlas, fitted)

    def agent_at(m: Any, mean: Any, var: Any) -> Any:
        return FleetAgent(m, lay, mean, var, reorder=st.reorder, cover=st.cover_needs, base=base)

    def cost_at(m: Any, mean: Any, var: Any) -> float:
        return mean_cost(curve_env, agent_at(m, mean, var), study)

    curve = LearningCurve(study.curve_every, cost_at)
    data = concat([demo_of(d) for d in labels])
    agent = train_on_labels(lambda: job.env(atlas, fitted), lay, st, data,
                            curve.callback() if st.timesteps else None, base=base)  # fmt: skip
    train_s = time.perf_counter() - t0
    timed = Timed(agent)
    eps = run_episodes(job.env(atlas, fitted), timed, study.eval_seeds(), check_masks=True)
    imitation = agent.imitation
    assert imitation is not None
    return {
        "predictor": job.distil.predictor, "seed": seed, "samples": len(data.rewards),
        "agreement": imitation.agreement, "nll": imitation.nll,
        "curve": {"timesteps": np.array([p[0] for p in curve.points], dtype=float),
                  "cost": np.array([p[1] for p in curve.points], dtype=float)},
        "episodes": episodes_dict(eps),
        "seconds": {"train": train_s, "evaluate": time.perf_counter() - t0 - train_s},
        "seconds_per_decision": timed.seconds / max(timed.calls, 1),
        "agent": agent_arrays(agent),
    }  # fmt: skip


def central_nets(job: Job, units: Mapping[str, Any]) -> dict[str, NDArray[Any]]:
    """Every central seed's trained agent (:func:`agent_arrays`), ``seedK/NAME``: the
    ``nets.npz`` of a run, from which a shipped baseline rebuilds the policies."""
    return {f"seed{s}/{k}": np.asarray(v)
            for kind, s in job.seed_runs() if kind == "central"
            for k, v in units[job.seed_key(s)]["agent"].items()}  # fmt: skip


def distil_graph(job: Job, atlas: Any, fitted: Any) -> list[Unit | Later]:
    """Round r's label units after every earlier round's; the seeds after every label."""
    d = job.distil
    per_shift = job.study.shifts

    def labels(r: Mapping[str, Any], round_: int, chunk: int, seeds: list[int]) -> Unit:
        earlier = [r[k] for k in job.label_keys(round_)]
        return Unit(job.label_key(round_, chunk), label_unit,
                    (job, atlas, fitted, round_, seeds, earlier),
                    100.0 * len(seeds) * per_shift)  # fmt: skip

    def trained(r: Mapping[str, Any], kind: str, seed: int) -> Unit:
        every = [r[k] for k in job.label_keys(d.label_rounds + 1)]
        w = 3.0 * d.training.timesteps + job.study.eval_episodes * per_shift
        fn = seed_unit if kind == "central" else shared_seed_unit
        return Unit(job.seed_key(seed, kind), fn, (job, atlas, fitted, seed, every), w)

    nodes: list[Unit | Later] = []
    for round_ in range(d.label_rounds + 1):
        for i, seeds in enumerate(d.label_chunks(round_)):
            nodes.append(Later(job.label_key(round_, i), tuple(job.label_keys(round_)),
                               partial(labels, round_=round_, chunk=i, seeds=seeds)))  # fmt: skip
    every = tuple(job.label_keys(d.label_rounds + 1))
    nodes += [Later(job.seed_key(s, kind), every, partial(trained, kind=kind, seed=s))
              for kind, s in job.seed_runs()]  # fmt: skip
    return nodes


def run_distil(
    job: Job, atlas: Atlas, fitted: Fitted | None, out: Path, runner: Runner,
    progress: Any = None,
) -> dict[str, Any]:  # fmt: skip
    """Every unit's result by key, kept in ``out/units`` (an interrupted run resumes)."""
    keys = job.keys()
    s = job.study
    settings = {**s.settings(), "atlas": atlas.content_hash, "base": list(job.base),
                "horizon": s.rollout_horizon, "samples": s.rollout_samples}  # fmt: skip
    store = open_store(out / UNITS, settings, keys, "fleet-distil")
    bar = progress("fleet-distil units", len(keys)) if progress else None
    try:
        return runner.run_graph(
            distil_graph(job, runner.share(atlas),
                         None if fitted is None else runner.share(fitted)),
            store, (lambda k, r: bar.update(1)) if bar else None,
        )  # fmt: skip
    finally:
        if bar is not None:
            bar.close()
