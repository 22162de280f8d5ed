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

import numpy as np
from tqdm import tqdm

from agents.fleet.settings import DistilConfig, FleetStudyConfig
from agents.fleet.study.build import rebuild_rule
from agents.fleet.study.distil import central_nets, run_distil
from agents.fleet.study.distil_job import Job
from agents.fleet.study.distil_summary import (
    _episode_figure,
    distil_report,
    study_row,
    summarise_distil,
)
from agents.fleet.study.units import study_fit
from brake_env.cli.common import command_line, load_atlas, make_runner
from brake_env.output import write_arrays, write_json, write_text
from brake_env.prognostics.registry import ORACLE

NETS = "nets.npz"  # the central seeds' agents (agents.fleet.study.distil.central_nets)
# What a study's costs.json config must name: a missing one would be taken at its default
# and change what is compared (the objective) or fitted (the seed, the fleet, the episodes)
REQUIRED = ("objective", "seed", "size", "shifts", "eval_episodes", "n_train_runs")


def read_study(directory: str) -> tuple[FleetStudyConfig, dict[str, Any]]:
    """A finished study's settings and ``costs.json``; one error naming the file and what
    is missing or wrong in it."""
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
    d = summary["config"]
    if not isinstance(d, dict):
        raise ValueError(f"{path}: its config is a {type(d).__name__}, not a study's settings")
    if missing := [k for k in REQUIRED if k not in d]:
        raise ValueError(f"{path}: its config names no {', '.join(missing)} (a study writes"
                         " them): the study cannot be compared on its own terms")  # fmt: skip
    try:
        config = FleetStudyConfig.from_dict(d)
    except (TypeError, ValueError, KeyError, AttributeError) as e:
        raise ValueError(f"{path}: its config is not a fleet study's settings ({e})") from None
    if not isinstance(summary["rows"], list) or not all(isinstance(r, dict) for r in
                                                        summary["rows"]):  # fmt: skip
        raise ValueError(f"{path}: its rows are not a list of rows")
    best = summary["best_heuristic"]
    if not isinstance(best, dict) or not all(isinstance(v, str) for v in best.values()):
        raise ValueError(f"{path}: its best_heuristic is not a heuristic name by predictor")
    return config, summary


def check_rows(directory: str, job: Job, summary: dict[str, Any]) -> None:
    """The rows ``fleet-distil`` compares with (the base heuristic, its planner, the bound):
    each of the study's evaluation episodes, finite, so that nothing fails after the work."""
    path = Path(directory) / "costs.json"
    n = job.study.eval_episodes
    p, base = job.distil.predictor, job.base[0]
    for policy in (base, f"rollout on {base}"):
        row = study_row(summary, p, policy)
        if row is None:
            continue
        try:
            figure = _episode_figure(row, job.study.objective, job.study.eval_seeds())
        except (KeyError, TypeError, ValueError) as e:
            raise ValueError(
                f"{path}: row {p} / {policy}: its episodes do not read ({e})"
            ) from None
        if figure.shape != (n,) or not np.isfinite(figure).all():
            raise ValueError(f"{path}: row {p} / {policy}: its episodes' cost must be {n}"
                             f" finite numbers, got {figure.tolist()[:5]}")  # fmt: skip
    bound = summary.get("bound")
    if bound:
        got = bound.get("episodes") if isinstance(bound, dict) else bound
        try:
            bd = np.asarray(got, dtype=np.float64)
        except (TypeError, ValueError):
            bd = np.array([np.nan])
        if bd.shape != (n,) or not np.isfinite(bd).all():
            raise ValueError(f"{path}: its bound's episodes must be {n} finite numbers, got"
                             f" {str(got)[:60]}")  # fmt: skip


def job_from_args(args: argparse.Namespace) -> tuple[Job, dict[str, Any]]:
    study, summary = read_study(args.study)
    p = args.predictor
    if p not in summary["best_heuristic"]:
        known = ", ".join(summary["best_heuristic"])
        raise ValueError(f"--predictor {p}: the study at {args.study} tuned no heuristic with"
                         f" it (its predictors: {known})")  # fmt: skip
    best = summary["best_heuristic"][p]
    path = Path(args.study) / "costs.json"
    row = study_row(summary, p, best)
    if row is None:
        raise ValueError(f"{path} names {best!r} the best heuristic of {p} but has no row of it")
    params = row.get("params")
    try:
        if not isinstance(params, dict) or not all(
            isinstance(v, str | bool) or (isinstance(v, int | float) and np.isfinite(v))
            for v in params.values()
        ):
            raise ValueError(f"{params!r} are not finite numbers and names by parameter")
        rebuild_rule(study, best, params)
    except (ValueError, TypeError, KeyError) as e:
        raise ValueError(f"{path}: the parameters of {p}'s {best!r} build no rule ({e})") from None
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
    job = Job(study, distil, (best, params))
    check_rows(args.study, job, summary)
    return job, summary


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
    summary["command"] = command_line(args)
    if job.distil.seeds:  # the central policies, rebuilt by a shipped baseline
        nets = central_nets(job, units)
        summary["nets"] = {"file": NETS, "sha256": write_arrays(nets, out / NETS)}
    from agents.fleet.study.plots import plot_distil

    figure = plot_distil(summary, out / "figures" / "distil.png")
    summary["figures"] = [str(figure.relative_to(out))]
    write_json(summary, out / "distil.json")
    write_text(distil_report(summary, markdown=True) + "\n", out / "report.md")
    print(distil_report(summary))
    return summary
