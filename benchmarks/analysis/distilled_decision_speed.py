"""How fast the distilled policies decide against the rollout planner they imitate, on the
same states in the same run (issue 32's target: at least 100x faster).

A study's planner (its predictor's best tuned heuristic, horizon and samples) labels
``--episodes`` episodes; the central policy and the policy shared by the vehicles are
cloned from them as ``fleet-distil`` clones them (a few passes: speed does not depend on
how well they learned), each reading the base rule's duties as it does (``base_input``:
the rule decides too, every time); then each decides every recorded state, timed alone
(the env's step and the RUL wrapper are not counted), one thread.

Run: ``.venv/bin/python benchmarks/analysis/distilled_decision_speed.py out/default-net-twin
--predictor twin``
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np
import torch

from agents.fleet.commands.distil import read_study
from agents.fleet.learning.agent import ReorderBy, train_on_labels
from agents.fleet.learning.imitation import record
from agents.fleet.settings import DistilConfig
from agents.fleet.study.distil_job import Job
from agents.fleet.study.distil_shared import shared_clone
from agents.fleet.study.distil_summary import study_row
from agents.fleet.study.units import fit_unit
from brake_env.env.atlases import default_atlas
from brake_env.output import table
from brake_env.prognostics.registry import ORACLE


def timed(policy: object, states: np.ndarray) -> float:
    """Seconds per decision over ``states`` (the median of three passes)."""
    runs = []
    for _ in range(3):
        t0 = time.perf_counter()
        for o in states:
            policy.predict(o)  # type: ignore[attr-defined]
        runs.append((time.perf_counter() - t0) / len(states))
    return float(np.median(runs))


def main(argv: list[str] | None = None) -> dict[str, float]:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("study", help="a finished fleet-study's --out")
    p.add_argument("--predictor", default="twin")
    p.add_argument("--episodes", type=int, default=1, help="episodes labelled and timed")
    p.add_argument("--epochs", type=int, default=2, help="passes of the cloning")
    args = p.parse_args(argv)
    torch.set_num_threads(1)
    study, summary = read_study(args.study)
    best = summary["best_heuristic"][args.predictor]
    row = study_row(summary, args.predictor, best)
    assert row is not None
    d = DistilConfig(predictor=args.predictor)
    d = dataclasses.replace(
        d, training=dataclasses.replace(d.training, imitation_epochs=args.epochs)
    )
    job = Job(study, d, (best, row["params"]))
    atlas = default_atlas()
    fitted = (
        None
        if args.predictor == ORACLE
        else fit_unit(args.predictor, atlas, study.seed, study.n_train_runs)
    )
    planner = job.planner(atlas)
    env = ReorderBy(job.env(atlas, fitted), *job.training(0).reorder)
    labels = record(env, planner, job.distil.label_seeds(0)[: args.episodes], drop_order=True)
    agent = train_on_labels(lambda: job.env(atlas, fitted), job.layout(), job.training(0), labels,
                            base=job.base_input())  # fmt: skip
    shared = shared_clone(job, atlas, fitted, 0, labels)[0]
    states = labels.obs
    t = {"planner": timed(planner, states), "agent": timed(agent, states),
         "shared": timed(shared, states)}  # fmt: skip
    rows = [["policy", "ms a decision", "decisions / s", "times faster than the planner"]]
    for key, name in (("planner", "rollout planner"), ("agent", "distilled central policy"),
                      ("shared", "distilled shared policy")):  # fmt: skip
        rows.append([name, f"{t[key] * 1e3:.3f}", f"{1 / t[key]:,.0f}",
                     f"{t['planner'] / t[key]:.0f}"])  # fmt: skip
    print(f"{study.size} fleet, {args.predictor}'s RUL, {len(states)} states, base rule's"
          f" duties in the input: {job.distil.base_input}")  # fmt: skip
    print(table(rows))
    return {"states": len(states), **t}


if __name__ == "__main__":
    main()
