"""``brakewear fleet-distil`` (its parser is :mod:`agents.fleet.commands.parser`): the
rollout planner of a finished fleet study distilled into a central policy over training
seeds (:mod:`agents.fleet.study.distil`), compared with the study's rows on its
evaluation episodes (:mod:`agents.fleet.study.distil_summary`)."""

from __future__ import annotations

import argparse
import json
from dataclasses import replace
from pathlib import Path
from typing import Any

from tqdm import tqdm

from agents.fleet.settings import DistilConfig, FleetStudyConfig
from agents.fleet.study.distil import run_distil
from agents.fleet.study.distil_job import Job
from agents.fleet.study.distil_summary import distil_report, study_row, summarise_distil
from agents.fleet.study.units import study_fit
from brake_env.cli.common import load_atlas, make_runner
from brake_env.output import write_json, write_text
from brake_env.prognostics.registry import ORACLE


def read_study(directory: str) -> tuple[FleetStudyConfig, dict[str, Any]]:
    """A finished study's settings and ``costs.json``; one error naming what is missing."""
    path = Path(directory) / "costs.json"
    try:
        summary = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ValueError(f"--study {directory}: no costs.json there; run `brakewear fleet-study"
                         f" --out {directory} ...` first") from None  # fmt: skip
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise ValueError(f"--study {directory}: cannot read {path}: {e}") from None
    if not isinstance(summary, dict) or not {"config", "rows", "best_heuristic"} <= set(summary):
        raise ValueError(f"--study {directory}: {path} is not a fleet study's costs.json")
    return FleetStudyConfig.from_dict(summary["config"]), summary


def job_from_args(args: argparse.Namespace) -> tuple[Job, dict[str, Any]]:
    study, summary = read_study(args.study)
    p = args.predictor
    if p not in summary["best_heuristic"]:
        known = ", ".join(summary["best_heuristic"])
        raise ValueError(f"--predictor {p}: the study at {args.study} tuned no heuristic with"
                         f" it (its predictors: {known})")  # fmt: skip
    best = summary["best_heuristic"][p]
    row = study_row(summary, p, best)
    assert row is not None, f"costs.json names {best!r} best for {p} but has no row of it"
    d = DistilConfig()
    training = replace(
        d.training, timesteps=args.timesteps, imitation_epochs=args.imitation_epochs,
        imitation_lr=args.imitation_lr, learning_rate=args.learning_rate,
        ent_coef=args.ent_coef, n_envs=args.n_envs,
    )  # fmt: skip
    distil = DistilConfig(
        predictor=p, seeds=args.seeds, shared_seeds=args.shared_seeds,
        label_episodes=args.label_episodes, label_rounds=args.label_rounds,
        label_chunk=args.label_chunk, training=training,
    )  # fmt: skip
    return Job(study, distil, (best, row["params"])), summary


def cmd_fleet_distil(args: argparse.Namespace) -> dict[str, Any]:
    job, study = job_from_args(args)
    if job.study.effects:
        raise ValueError(
            f"--study {args.study}: its fleet wears with the effects {list(job.study.effects)};"
            " fleet-distil takes only studies without effects"
        )
    atlas = load_atlas(args)
    p = job.distil.predictor
    fitted = None if p == ORACLE else study_fit(job.study, p, atlas, atlas)
    out = Path(args.out)

    def progress(label: str, total: int) -> Any:
        return tqdm(total=total, desc=label, unit="unit", disable=args.quiet)

    with make_runner(args) as runner:
        units = run_distil(job, atlas, fitted, out, runner, progress)
    summary = summarise_distil(job, study, units)
    from agents.fleet.study.plots import plot_distil

    figure = plot_distil(summary, out / "figures" / "distil.png")
    summary["figures"] = [str(figure.relative_to(out))]
    write_json(summary, out / "distil.json")
    write_text(distil_report(summary, markdown=True) + "\n", out / "report.md")
    print(distil_report(summary))
    return summary
