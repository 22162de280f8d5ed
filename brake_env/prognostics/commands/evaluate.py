"""``brakewear evaluate``: the prognostics evaluation (paper 2.5, Table 4, Figures 10-13).

Reads the train / ID / OOD event logs of ``brakewear simulate``, fits the chosen predictors
on the training runs, scores them on the test runs (:mod:`brake_env.prognostics.evaluation`)
and writes ``metrics.json``, ``table.md``, the figures of paper Figures 10-13 and the MLP's
weights. The same evaluation is the demo stage ``30-evaluate``. With ``--seeds`` it is run
once per seed, each seed a unit of work (here or on Ray), and summarised over the seeds
(:mod:`.evaluate_seeds`).
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

import pandas as pd
from tqdm import tqdm

from brake_env.cli.common import (
    add_common_args,
    add_runner_args,
    add_strict_arg,
    add_wear_args,
    int_at_least,
    load_atlas,
    name_list,
)
from brake_env.cli.demo import DemoContext
from brake_env.data.datasets import DatasetSpec, find_logs
from brake_env.data.plausibility import warn_fitted, warn_implausible
from brake_env.data.schema import read_event_log
from brake_env.model.atlas import Atlas
from brake_env.prognostics.commands.evaluate_seeds import cmd_evaluate_seeds
from brake_env.prognostics.commands.outputs import (
    check_data_atlas,
    markdown_tables,
    simulation_options,
    write_evaluation,
)
from brake_env.prognostics.evaluation import Evaluation, EvaluationConfig, evaluate
from brake_env.prognostics.protocol import Predictor
from brake_env.prognostics.registry import predictor_names
from brake_env.prognostics.seeds import fit_all, make_predictors

DEFAULT_PREDICTORS = ("physics", "data", "twin")


_predictor_list = name_list(predictor_names)


def register(sub: argparse._SubParsersAction[Any]) -> None:
    """Add ``evaluate`` to the ``brakewear`` parser."""
    e = sub.add_parser(
        "evaluate",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
        help="fit RUL predictors on the training runs and score them on ID and OOD runs",
    )
    add_common_args(e, "out/evaluate")
    e.add_argument(
        "--data",
        default=None,
        help="directory holding {train,id,ood}.parquet (or .csv), as brakewear simulate"
        " writes (needed without --seeds)",
    )
    e.add_argument(
        "--predictors",
        type=_predictor_list,
        default=DEFAULT_PREDICTORS,
        help=f"comma-separated predictors among {','.join(predictor_names())}",
    )
    e.add_argument("--atlas", default=None, help="atlas .npz to use instead of the cache")
    e.add_argument(
        "--batch-events",
        type=int_at_least(0),
        default=0,
        help="events per predictor update (0: each run in one batch; same numbers, faster)",
    )
    e.add_argument(
        "--mlp-epochs", type=int_at_least(1), default=None, help="MLP epochs (default: its config)"
    )
    add_strict_arg(e)
    _add_seeds_args(e)
    e.set_defaults(func=cmd_evaluate)


def _add_seeds_args(e: argparse.ArgumentParser) -> None:
    """The multi-seed evaluation's options (:mod:`.evaluate_seeds`)."""
    g = e.add_argument_group(
        "several seeds",
        "--seeds and the options of what each seed runs; --n-* and --k-* set the dataset each"
        " seed simulates when --data is not given",
    )
    group = cast(argparse.ArgumentParser, g)  # the helpers only call add_argument
    g.add_argument(
        "--seeds",
        nargs="+",
        type=int,
        default=None,
        metavar="S",
        help="evaluate each of these seeds (instead of --seed), one unit of work each, and"
        " give the mean and the min-max over them per predictor (OUT/seeds.json, seeds.md;"
        " OUT/seed-S/ as one --seed writes). With --data every seed fits on the same logs:"
        " only the MLP changes (its initialisation and minibatches; physics and twin fit"
        " deterministically). Without --data each seed simulates its own dataset, the"
        " paper's 30 runs unless the --n-* and --k-* options say otherwise, and fits and"
        " scores on it",
    )
    for name in ("train", "id", "ood-slow", "ood-fast"):
        g.add_argument(
            f"--n-{name}",
            type=int_at_least(0),
            default=getattr(DatasetSpec, "n_" + name.replace("-", "_")),
            help=f"{name} runs each seed simulates (without --data)",
        )
    add_wear_args(group)
    g.add_argument(
        "--seed-figures", action="store_true", help="the figures of every seed under OUT/seed-S/"
    )
    add_runner_args(group)


@dataclass(frozen=True)
class OneSeed:
    """What a one-seed ``brakewear evaluate`` runs (built from its options, or by the demo).

    Attributes:
        data: A ``brakewear simulate`` directory ({train,id,ood}.parquet).
        out: Where the evaluation's files go.
        seed: Seeds the predictors (the MLP's initialisation and minibatches).
        predictors: Registry names to fit and score.
        batch_events: Events per predictor update (0: each run in one batch).
        mlp_epochs: The MLP's epochs (None: its config's).
        quiet: No progress bars.
        skip_unfittable: Drop a predictor that fails to fit, saying why (the demo).
        strict: Implausible data is an error, not a warning.
    """

    data: Path
    out: Path
    seed: int
    predictors: tuple[str, ...] = DEFAULT_PREDICTORS
    batch_events: int = 0
    mlp_epochs: int | None = None
    quiet: bool = False
    skip_unfittable: bool = False
    strict: bool = False

    def __post_init__(self) -> None:
        if not self.predictors:
            raise ValueError("evaluate: no predictors given")
        if self.batch_events < 0:
            raise ValueError(f"evaluate: batch_events must be >= 0, got {self.batch_events}")
        if self.mlp_epochs is not None and self.mlp_epochs < 1:
            raise ValueError(f"evaluate: mlp_epochs must be >= 1, got {self.mlp_epochs}")

    @classmethod
    def from_args(cls, args: argparse.Namespace) -> OneSeed:
        """The one-seed run ``args`` ask for (options of ``--seeds`` refused by name)."""
        if not args.data:
            raise ValueError(
                "evaluate needs --data (a brakewear simulate directory), or --seeds to simulate"
                " a dataset per seed"
            )
        seeds_only = [
            *(o for o in ("workers", "ray", "seed_figures") if getattr(args, o, None)),
            *simulation_options(args),
        ]
        if seeds_only:
            opts = ", ".join("--" + o.replace("_", "-") for o in seeds_only)
            raise ValueError(f"{opts}: options of --seeds (one --seed runs here, on --data)")
        return cls(
            Path(args.data),
            Path(args.out),
            args.seed,
            tuple(args.predictors),
            args.batch_events,
            args.mlp_epochs,
            args.quiet,
            strict=bool(getattr(args, "strict", False)),
        )


def cmd_evaluate(args: argparse.Namespace) -> dict[str, Any]:
    """``brakewear evaluate``: several seeds (:mod:`.evaluate_seeds`) or one."""
    if getattr(args, "seeds", None) is not None:
        return cmd_evaluate_seeds(args)
    run = OneSeed.from_args(args)
    return evaluate_one(run, lambda: load_atlas(args))


def evaluate_one(run: OneSeed, atlas_of: Callable[[], Atlas]) -> dict[str, Any]:
    """Fit, score and write ``run`` (the atlas from ``atlas_of``, after the logs are read);
    ``metrics``, ``evaluation`` and ``out``."""
    t_start = time.perf_counter()
    t0 = time.perf_counter()
    logs = {split: read_event_log(p) for split, p in find_logs(run.data).items()}
    read_s = time.perf_counter() - t0
    atlas = atlas_of()
    check_data_atlas(run.data, atlas.content_hash)
    for split, lg in logs.items():
        warn_implausible(lg, atlas, f"evaluate {split}", lives=split == "train", strict=run.strict)
    predictors = make_predictors(run.predictors, atlas, run.seed, run.mlp_epochs)
    skipped: dict[str, str] | None = {} if run.skip_unfittable else None
    fit_s = fit_all(predictors, logs["train"], run.quiet, skipped)
    if not predictors:
        raise ValueError(f"no predictor could be fitted: {skipped}")
    warn_fitted(
        {n: p.fitted_wear_coeff() for n, p in predictors.items()}, "evaluate", strict=run.strict
    )
    t0 = time.perf_counter()
    ev = _predict_and_score(predictors, logs, run)
    predict_s = time.perf_counter() - t0
    for name, s in fit_s.items():
        ev.metrics["models"][name]["fit_seconds"] = s
    timing = {"read_logs": read_s, "fit": fit_s, "predict_and_score": predict_s}
    saved = write_evaluation(
        ev,
        run.out,
        predictors,
        atlas,
        {"data_dir": str(run.data), "seed": run.seed},
        skipped=skipped or {},
        timing=timing,
        t_start=t_start,
    )
    _print_results(ev, run.out, saved)
    return {"metrics": ev.metrics, "evaluation": ev, "out": run.out}


def _predict_and_score(
    predictors: dict[str, Predictor], logs: dict[str, pd.DataFrame], run: OneSeed
) -> Evaluation:
    n_events = sum(len(logs[s]) for s in ("id", "ood") if s in logs) * len(predictors)
    with tqdm(
        total=n_events, desc="predict", unit="event", unit_scale=True, disable=run.quiet
    ) as bar:
        return evaluate(
            predictors,
            logs,
            EvaluationConfig(batch_events=run.batch_events),
            fit=False,
            progress=lambda _name, n: bar.update(n),
        )


def _print_results(ev: Evaluation, out: Path, saved: dict[str, list[str]]) -> None:
    print(ev.table())
    print()
    print(ev.summary_table())
    timing = ev.metrics["timing_s"]
    fits = "  ".join(f"{k} {v:.1f} s" for k, v in timing["fit"].items())
    print(
        f"\nfit: {fits}  predict+score: {timing['predict_and_score']:.1f} s"
        f"  total: {timing['total']:.1f} s"
    )
    print(f"wrote {out}/metrics.json, table.md, figures/" + (", models/" if saved else ""))


def demo_stage(ctx: DemoContext) -> tuple[dict[str, Any], str]:
    """The evaluation of the demo's datasets, written under ``ctx.out / "evaluate"``."""
    run = OneSeed(
        ctx.data_dir,
        ctx.out / "evaluate",
        ctx.args.seed,
        quiet=ctx.args.quiet,
        skip_unfittable=True,
    )
    res = evaluate_one(run, lambda: Atlas.load(ctx.atlas_file))
    ev: Evaluation = res["evaluation"]
    rel = Path("evaluate")
    figs = "\n\n".join(f"![{k}]({(rel / v).as_posix()})" for k, v in ev.metrics["figures"].items())
    timing = ev.metrics["timing_s"]
    section = (
        "## Prognostics (paper Table 4, Figures 10-13)\n\n"
        + markdown_tables(ev)
        + "".join(f"\n\n{k} skipped: {v}." for k, v in ev.metrics["skipped"].items())
        + f"\n\nFit: {', '.join(f'{k} {v:.1f} s' for k, v in timing['fit'].items())};"
        f" prediction and scoring {timing['predict_and_score']:.1f} s."
        " Full metrics: `evaluate/metrics.json`.\n\n" + figs + "\n"
    )
    summary = {
        "mean_rul_rmse": {m: {s: ev.mean(m, s, "rul_rmse") for s in ev.splits} for m in ev.models},
        "metrics_file": str(run.out / "metrics.json"),
    }
    return summary, section
