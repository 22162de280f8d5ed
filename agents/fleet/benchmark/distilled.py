"""A distilled policy as a shipped baseline (``PREDICTOR-distilled``): read from a finished
``brakewear fleet-distil`` of the suite's test-split study (:func:`distilled_baseline`), its
central seeds' agents shipped beside the baselines file (:func:`ship_nets`:
``<file stem>.<name>.npz``, its SHA-256 in the entry), and rebuilt from them to be re-scored
(:func:`rebuild_distilled`).

Its shipped figure on a test episode is the mean over its training seeds (the expected cost
of a policy distilled from one seed), so a re-score runs every seed's agent on each episode
and takes the same mean (:class:`SeedMean`): the same numbers, not one seed's.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from agents.fleet.evaluation.costs import run_episode
from agents.fleet.learning.agent_arrays import agent_from_arrays
from agents.fleet.settings import TRAIN_SEED0, DistilConfig, FleetStudyConfig
from agents.fleet.study.build import single_thread
from agents.fleet.study.distil_job import Job
from agents.fleet.study.units import study_fit
from brake_env.model.atlas import Atlas
from brake_env.output import read_arrays, write_arrays
from brake_env.prognostics.registry import ORACLE

DISTILLED = "-distilled"


def distilled_baseline(suite: Any, distil: dict[str, Any], kind: str = "central") -> dict[str, Any]:
    """``PREDICTOR-distilled`` from a finished ``fleet-distil`` of the suite's test-split
    study (its ``distil.json``): each test episode's figures averaged over the training
    seeds (:func:`seed_mean`), the seeds' own means kept, its base rule recorded; in the
    baselines file's format, as ``made`` for :func:`~agents.fleet.benchmark.baselines.merge`.

    Raises:
        ValueError: ``distil`` is not such a run (no per-episode figures of ``kind``, or
            seeds that differ between training seeds).
    """
    try:
        rows, p = distil[kind]["seeds"], distil["predictor"]
        eps = [r["episodes"] for r in rows]
        seeds = eps[0]["seed"]
        net, cost = (seed_mean([e[f] for e in eps]) for f in ("net", "cost"))
    except (KeyError, TypeError, IndexError, ValueError) as e:
        raise ValueError(
            f"--distil-from: not a fleet-distil distil.json with each seed's"
            f" episodes ({e!r}); rerun fleet-distil with this version"
        ) from None
    if any(e["seed"] != seeds for e in eps) or len(net) != len(seeds):
        raise ValueError("--distil-from: the training seeds ran different episodes")
    b = {"kind": "distilled", "predictor": p, "policy": f"distilled rollout on {distil['base']}",
         "net": float(np.mean(net)), "cost": float(np.mean(cost)),
         "episodes": {"seed": list(seeds), "net": net, "cost": cost},
         "training_seeds": [int(r["seed"]) for r in rows],
         "seed_nets": [float(r["net"]) for r in rows], "distil": distil.get("distil"),
         "base": {"policy": distil["base"], "params": distil.get("params")},
         "distil_command": distil.get("command")}  # fmt: skip
    seconds = float(distil["labels"]["seconds"]) + sum(
        float(r["train_seconds"]) + float(r["evaluate_seconds"]) for r in rows
    )
    return {"suite": suite.name, "suite_digest": suite.digest,
            "baselines": {f"{p}{DISTILLED}": b}, "seconds": seconds}  # fmt: skip


def seed_mean(per_seed: list[list[float]]) -> list[float]:
    """Each episode's figure averaged over the training seeds (``per_seed[seed][episode]``),
    summed in seed order: the shipped figure and the re-score's, the same arithmetic."""
    n = {len(x) for x in per_seed}
    if len(n) != 1:
        raise ValueError(f"training seeds of {sorted(n)} episodes")
    return [float(np.mean([x[i] for x in per_seed])) for i in range(n.pop())]


def ship_nets(
    entry: dict[str, Any], run: Path, distil: dict[str, Any], into: Path, name: str
) -> None:
    """The run's agents of ``entry``'s training seeds written beside ``into`` (the baselines
    file), ``<into's stem>.<name>.npz``; the entry records the file and its SHA-256. A run
    without agents (made before they were kept) leaves the entry read-only.

    Raises:
        ValueError: The run's ``nets.npz`` is unreadable, not the file ``distil.json``
            names, or lacks a training seed's agent.
    """
    nets = distil.get("nets")
    if nets is None:
        return
    arrays = read_arrays(run / nets["file"], nets["sha256"], f"--distil-from {run}")
    keep = {k: v for k, v in arrays.items()
            if k.split("/", 1)[0] in {f"seed{s}" for s in entry["training_seeds"]}}  # fmt: skip
    for s in entry["training_seeds"]:
        if f"seed{s}/obs_mean" not in keep:
            raise ValueError(f"--distil-from {run}: {nets['file']} holds no agent of seed {s}")
    file = f"{into.stem}.{name}.npz"
    entry["nets"] = {"file": file, "sha256": write_arrays(keep, into.parent / file)}


@dataclass(frozen=True)
class MeanEpisode:
    """An episode's figures averaged over a distilled baseline's training seeds."""

    seed: int
    net: float
    per_vehicle_shift: float


class SeedMean:
    """A distilled baseline's agents, one per training seed: each episode run by every one
    of them (torch on one thread, as the distillation ran them), its figures averaged."""

    def __init__(self, env: Any, agents: list[Any]) -> None:
        self.env, self.agents = env, agents

    def run(self, seed: int) -> MeanEpisode:
        eps = [single_thread(run_episode, self.env, a, seed, True) for a in self.agents]
        net = seed_mean([[e.net] for e in eps])[0]
        cost = seed_mean([[e.per_vehicle_shift] for e in eps])[0]
        return MeanEpisode(seed, net, cost)

    def __repr__(self) -> str:
        return f"SeedMean({len(self.agents)} agents)"


def rebuild_distilled(
    config: FleetStudyConfig, entry: dict[str, Any], atlas: Atlas, directory: Path
) -> tuple[Any, SeedMean]:
    """(the env, every training seed's agent) of a shipped distilled baseline: its base rule
    and distillation settings rebuild the env and the network, its nets file (in
    ``directory``, checked against its SHA-256) the weights.

    Raises:
        ValueError: A baseline made before its agents were shipped, or a nets file that is
            missing, altered or of another network.
    """
    if "nets" not in entry or "base" not in entry:
        raise ValueError(f"baseline {entry.get('predictor')}-distilled: made before its agents"
                         " were shipped; its shipped episodes are read")  # fmt: skip
    nets = entry["nets"]
    arrays = read_arrays(directory / nets["file"], nets["sha256"], "distilled baseline")
    p, base = str(entry["predictor"]), entry["base"]
    job = Job(config, DistilConfig.from_dict(entry["distil"]), (base["policy"], base["params"]))
    fitted = None if p == ORACLE else study_fit(config, p, atlas, atlas)
    agents = []
    for s in entry["training_seeds"]:
        mine = {k.split("/", 1)[1]: v for k, v in arrays.items() if k.startswith(f"seed{s}/")}
        agents.append(agent_from_arrays(mine, lambda: job.env(atlas, fitted),
                                        job.training(TRAIN_SEED0 + 100 * int(s)),
                                        job.layout(), job.base_input()))  # fmt: skip
    env = job.env(atlas, fitted)
    return env, SeedMean(env, agents)
