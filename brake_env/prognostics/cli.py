"""``brakewear evaluate``: the prognostics evaluation (paper 2.5, Table 4, Figures 10-13).

Reads the train / ID / OOD event logs of ``brakewear simulate``, fits the chosen predictors
on the training runs, scores them on the test runs (:mod:`brake_env.prognostics.evaluation`)
and writes ``metrics.json``, ``table.md``, the figures of paper Figures 10-13 and the MLP's
weights. The same evaluation is the demo stage ``30-evaluate``. With ``--seeds`` it is run
once per seed, each seed a unit of work (here or on Ray), and summarised over the seeds
(:mod:`brake_env.prognostics.seeds_cli`).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
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
)
from brake_env.cli.demo import DemoContext
from brake_env.data.datasets import DatasetSpec, find_logs
from brake_env.data.plausibility import warn_fitted, warn_implausible
from brake_env.data.schema import read_event_log
from brake_env.model.atlas import Atlas
from brake_env.model.regime import WearRegime
from brake_env.output import write_json, write_text
from brake_env.prognostics.evaluation import Evaluation, EvaluationConfig, evaluate
from brake_env.prognostics.persist import ARRAYS, HEADER, save_predictor
from brake_env.prognostics.protocol import Predictor
from brake_env.prognostics.registry import predictor_names
from brake_env.prognostics.seeds import fit_all, make_predictors

DEFAULT_PREDICTORS = ("physics", "data", "twin")
_SIMULATION = ("n_train", "n_id", "n_ood_slow", "n_ood_fast", "k_mean", "k_std", "ood_shift_sigma")


def _predictor_list(text: str) -> tuple[str, ...]:
    names = tuple(dict.fromkeys(n.strip() for n in text.split(",") if n.strip()))
    bad = [n for n in names if n not in predictor_names()]
    if bad or not names:
        raise argparse.ArgumentTypeError(
            f"--predictors takes a comma-separated subset of {','.join(predictor_names())},"
            f" got {text!r}"
        )
    return names


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
    """The multi-seed evaluation's options (:mod:`brake_env.prognostics.seeds_cli`)."""
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


def simulation_options(args: argparse.Namespace) -> list[str]:
    """The dataset options (``--n-*``, ``--k-*``) given other values than their defaults."""
    defaults = {**dataclasses.asdict(DatasetSpec()), **dataclasses.asdict(WearRegime())}
    return [k for k in _SIMULATION if getattr(args, k, None) not in (defaults.get(k), None)]


def _check_atlas(data_dir: Path, atlas_hash: str) -> None:
    """Warn when summary.json says the logs were simulated with another atlas."""
    summary = data_dir / "summary.json"
    if not summary.is_file():
        return
    try:
        data_hash = json.loads(summary.read_text()).get("atlas", {}).get("hash")
    except (json.JSONDecodeError, AttributeError):
        return
    if data_hash and data_hash != atlas_hash:
        print(
            f"evaluate: warning: {data_dir} was simulated with atlas {data_hash[:12]}, the"
            f" predictors use atlas {atlas_hash[:12]} (pass the data's atlas with --atlas)",
            file=sys.stderr,
        )


def cmd_evaluate(args: argparse.Namespace, skip_unfittable: bool = False) -> dict[str, Any]:
    """``brakewear evaluate``; ``skip_unfittable`` drops predictors that fail to fit (demo)."""
    if getattr(args, "seeds", None) is not None:
        from brake_env.prognostics.seeds_cli import cmd_evaluate_seeds  # it imports this

        return cmd_evaluate_seeds(args)
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
    t_start = time.perf_counter()
    out = Path(args.out)
    t0 = time.perf_counter()
    logs = {split: read_event_log(p) for split, p in find_logs(args.data).items()}
    read_s = time.perf_counter() - t0
    atlas = load_atlas(args)
    _check_atlas(Path(args.data), atlas.content_hash)
    strict = bool(getattr(args, "strict", False))  # the demo's namespace has no --strict
    for split, lg in logs.items():
        warn_implausible(lg, atlas, f"evaluate {split}", lives=split == "train", strict=strict)
    predictors = _make_predictors(args, atlas)
    skipped: dict[str, str] | None = {} if skip_unfittable else None
    fit_s = fit_all(predictors, logs["train"], args.quiet, skipped)
    if not predictors:
        raise ValueError(f"no predictor could be fitted: {skipped}")
    warn_fitted(
        {n: p.fitted_wear_coeff() for n, p in predictors.items()}, "evaluate", strict=strict
    )
    t0 = time.perf_counter()
    ev = _predict_and_score(predictors, logs, args)
    predict_s = time.perf_counter() - t0
    for name, s in fit_s.items():
        ev.metrics["models"][name]["fit_seconds"] = s
    timing = {"read_logs": read_s, "fit": fit_s, "predict_and_score": predict_s}
    saved = write_evaluation(
        ev,
        out,
        predictors,
        atlas,
        {"data_dir": str(Path(args.data)), "seed": args.seed},
        skipped or {},
        timing,
        t_start,
    )
    _print_results(ev, out, saved)
    return {"metrics": ev.metrics, "evaluation": ev, "out": out}


def write_evaluation(
    ev: Evaluation,
    out: Path,
    predictors: dict[str, Predictor],
    atlas: Atlas,
    data: dict[str, Any],
    skipped: dict[str, str],
    timing: dict[str, Any],
    t_start: float | None = None,
    figures: bool = True,
) -> dict[str, list[str]]:
    """Write ``metrics.json`` (the evaluation's metrics with ``data`` (the data and seed),
    the atlas hash, the saved models, ``skipped``, the figures and ``timing``, whose
    ``total`` runs from ``t_start`` when given), ``table.md``, the figures and the MLP's
    weights under ``out``; returns the saved models' files."""
    saved = _save_models(predictors, out, atlas, int(data["seed"]))
    figs: dict[str, Path] = {}
    if figures:
        from brake_env.prognostics.plots import plot_all  # matplotlib: only when plotting

        figs = plot_all(ev, out / "figures")
    if t_start is not None:
        timing = {**timing, "total": time.perf_counter() - t_start}
    ev.metrics.update(
        **data,
        atlas_hash=atlas.content_hash,
        saved_models=saved,
        skipped=skipped,
        figures={k: str(v.relative_to(out)) for k, v in figs.items()},
        timing_s=timing,
    )
    write_json(ev.metrics, out / "metrics.json")
    write_text(_markdown_tables(ev) + "\n", out / "table.md")
    return saved


def _make_predictors(args: argparse.Namespace, atlas: Atlas) -> dict[str, Predictor]:
    return make_predictors(args.predictors, atlas, args.seed, args.mlp_epochs)


def _predict_and_score(
    predictors: dict[str, Predictor], logs: dict[str, pd.DataFrame], args: argparse.Namespace
) -> Evaluation:
    n_events = sum(len(logs[s]) for s in ("id", "ood") if s in logs) * len(predictors)
    with tqdm(
        total=n_events, desc="predict", unit="event", unit_scale=True, disable=args.quiet
    ) as bar:
        return evaluate(
            predictors,
            logs,
            EvaluationConfig(batch_events=args.batch_events),
            fit=False,
            progress=lambda _name, n: bar.update(n),
        )


def _save_models(
    predictors: dict[str, Predictor], out: Path, atlas: Atlas, seed: int
) -> dict[str, list[str]]:
    """The MLP's weights as a model directory ``brakewear predict --model`` reads (no
    pickle), its files relative to ``out``."""
    saved = {}
    if "data" in predictors:
        path = save_predictor(predictors["data"], out / "models" / "data", atlas, seed=seed)
        saved["data"] = [str((path / f).relative_to(out)) for f in (HEADER, ARRAYS)]
    return saved


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


def _markdown_tables(ev: Evaluation) -> str:
    return (
        "RUL RMSE per run [braking events] (paper Table 4)\n\n"
        + ev.table(markdown=True)
        + "\n\nMeans over runs: RMSE [events], RMSE / life, convergence event for each"
        " tolerance as a fraction of life (1 = never), relative accuracy and alpha-lambda"
        " (alpha 0.2) at half life, prognostic horizon (PH, fraction of life, ProgPy's"
        " definition), cumulative relative accuracy (CRA), monotonicity (mono), PHM08 score"
        " (d in % of life), volume RMSE, mean relative K error, interval coverage\n\n"
        + ev.summary_table(markdown=True)
    )


def demo_stage(ctx: DemoContext) -> tuple[dict[str, Any], str]:
    """The evaluation of the demo's datasets, written under ``ctx.out / "evaluate"``."""
    args = argparse.Namespace(
        data=str(ctx.data_dir),
        out=str(ctx.out / "evaluate"),
        seed=ctx.args.seed,
        preset=ctx.args.preset,
        cache_dir=ctx.args.cache_dir,
        quiet=ctx.args.quiet,
        atlas=str(ctx.atlas_file),
        predictors=DEFAULT_PREDICTORS,
        batch_events=0,
        mlp_epochs=None,
    )
    res = cmd_evaluate(args, skip_unfittable=True)
    ev: Evaluation = res["evaluation"]
    rel = Path("evaluate")
    figs = "\n\n".join(f"![{k}]({(rel / v).as_posix()})" for k, v in ev.metrics["figures"].items())
    timing = ev.metrics["timing_s"]
    section = (
        "## Prognostics (paper Table 4, Figures 10-13)\n\n"
        + _markdown_tables(ev)
        + "".join(f"\n\n{k} skipped: {v}." for k, v in ev.metrics["skipped"].items())
        + f"\n\nFit: {', '.join(f'{k} {v:.1f} s' for k, v in timing['fit'].items())};"
        f" prediction and scoring {timing['predict_and_score']:.1f} s."
        " Full metrics: `evaluate/metrics.json`.\n\n" + figs + "\n"
    )
    summary = {
        "mean_rul_rmse": {m: {s: ev.mean(m, s, "rul_rmse") for s in ev.splits} for m in ev.models},
        "metrics_file": str(Path(args.out) / "metrics.json"),
    }
    return summary, section
