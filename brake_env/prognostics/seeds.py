"""The prognostics evaluation over several seeds (``brakewear evaluate --seeds``;
docs/cluster.md).

Each seed is one :class:`~brake_env.runner.Unit`: make the predictors with that seed, fit
them, run them over the test runs and score them (:func:`evaluate_seed`). Given logs, every
seed fits on the same data, so only what a predictor draws from its seed changes (the MLP's
initialisation and minibatches; physics and twin fit deterministically); without logs, each
seed also simulates its own dataset (``make_dataset(atlas, spec, seed)``), so the data
change too. A unit returns the metrics tree, the thinned traces of the figures and the
MLP's weights, as plain arrays and JSON (saved per seed, resumed without pickle).

:func:`aggregate` then gives, per predictor, split and headline metric, the mean over seeds
with its spread: the minimum and maximum (a few seeds support no finer interval) and the
sample standard deviation.
"""

from __future__ import annotations

import dataclasses
import sys
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
from tqdm import tqdm

from brake_env.data.datasets import DatasetSpec, make_dataset
from brake_env.model.atlas import Atlas
from brake_env.output import table
from brake_env.prognostics.evaluation import Evaluation, EvaluationConfig, evaluate
from brake_env.prognostics.protocol import Predictor
from brake_env.prognostics.registry import make_predictor

SAVED = ("data",)  # predictors whose weights a seed keeps (``brakewear predict --model``)
# Headline metrics (means over runs) summarised over seeds; ``convergence_frac`` expands to
# one entry per tolerance, ``k_rel_error`` is its mean over life.
HEADLINE = (
    "rul_rmse",
    "rul_rmse_frac",
    "convergence_frac",
    "relative_accuracy",
    "alpha_lambda",
    "prognostic_horizon_frac",
    "cumulative_relative_accuracy",
    "monotonicity",
    "phm08",
    "volume_rmse",
    "k_rel_error",
    "interval_coverage",
)


@dataclass(frozen=True)
class SeedPlan:
    """What each seed's unit does.

    Attributes:
        predictors: Registry names of the predictors, in table order.
        batch_events: Events per predictor update (0: each run in one batch).
        mlp_epochs: MLP epochs (None: its config's).
        spec: The dataset each seed simulates; None when the logs are given.
    """

    predictors: tuple[str, ...]
    batch_events: int = 0
    mlp_epochs: int | None = None
    spec: DatasetSpec | None = None


def check_seeds(seeds: Sequence[int]) -> list[int]:
    """The seeds, each an int >= 0 given once.

    Raises:
        ValueError: None, a negative one, or one given twice (named).
    """
    seeds = list(seeds)
    twice = sorted({s for s in seeds if seeds.count(s) > 1})
    bad = [s for s in seeds if not isinstance(s, int) or isinstance(s, bool) or s < 0]
    if not seeds or bad or twice:
        what = f"negative or not an integer: {bad}" if bad else f"given twice: {twice}"
        raise ValueError(f"--seeds takes distinct integers >= 0, got {seeds} ({what})")
    return seeds


def make_predictors(
    names: Sequence[str], atlas: Atlas, seed: int, mlp_epochs: int | None = None
) -> dict[str, Predictor]:
    """Unfitted predictors by name, made with ``seed``; ``mlp_epochs`` (when given) for
    every predictor trained in epochs (its ``config`` has ``epochs``: the MLP)."""
    predictors = {n: make_predictor(n, atlas, seed) for n in names}
    for pred in predictors.values():
        config = getattr(pred, "config", None)
        if not (mlp_epochs and hasattr(config, "epochs")):
            continue
        if dataclasses.is_dataclass(config) and not isinstance(config, type):
            pred.config = dataclasses.replace(config, epochs=mlp_epochs)  # type: ignore[attr-defined]
    return predictors


def fit_all(
    predictors: dict[str, Predictor],
    train: pd.DataFrame,
    quiet: bool,
    skipped: dict[str, str] | None = None,
) -> dict[str, float]:
    """Fit every predictor [s each]; with ``skipped`` given, one that cannot be fitted on
    these training runs (ValueError) is dropped and its reason recorded instead of raising."""
    seconds = {}
    for name, pred in list(predictors.items()):
        t0 = time.perf_counter()
        epochs = getattr(getattr(pred, "config", None), "epochs", None)
        if hasattr(pred, "progress") and epochs:
            with tqdm(total=epochs, desc=f"fit {name}", unit="epoch", disable=quiet) as bar:
                setattr(pred, "progress", bar.update)  # noqa: B010 - MLP epoch callback
                pred.fit(train)
                setattr(pred, "progress", None)  # noqa: B010
        else:
            if not quiet:
                print(f"fit {name} ...", file=sys.stderr)
            try:
                pred.fit(train)
            except ValueError as e:
                if skipped is None:
                    raise ValueError(f"fitting {name}: {e}") from e
                print(f"evaluate: skipping {name}: {e}", file=sys.stderr)
                skipped[name] = str(e)
                del predictors[name]
                continue
        seconds[name] = time.perf_counter() - t0
    return seconds


# ---------------------------------------------------------------------- the unit
def evaluate_seed(
    atlas: Atlas, logs: Mapping[str, pd.DataFrame] | None, seed: int, plan: SeedPlan
) -> dict[str, Any]:
    """One seed: (simulate,) fit, predict and score.

    Args:
        atlas: The atlas of the predictors (and of the simulation).
        logs: The train / ID / OOD logs every seed shares, or None to simulate
            ``plan.spec`` with ``seed``.
        seed: The seed of the predictors (and of the data when simulated).
        plan: What to run.

    Returns:
        ``metrics`` (the evaluation's tree, fit times in), ``traces`` (model -> split ->
        run -> column -> array), ``samples``, ``models`` (name -> ``meta``/``arrays`` of
        the predictors in ``SAVED``) and ``timing_s``.
    """
    t_start = time.perf_counter()
    timing: dict[str, Any] = {}
    if logs is None:
        if plan.spec is None:
            raise ValueError("evaluate_seed: give the logs or a dataset spec to simulate")
        ds = make_dataset(atlas, plan.spec, seed)
        logs = {split: log for split, log in ds.logs.items() if len(log)}
        timing["simulate"] = time.perf_counter() - t_start
    predictors = make_predictors(plan.predictors, atlas, seed, plan.mlp_epochs)
    timing["fit"] = fit_all(predictors, logs["train"], quiet=True)
    t0 = time.perf_counter()
    ev = evaluate(predictors, logs, EvaluationConfig(batch_events=plan.batch_events), fit=False)
    timing["predict_and_score"] = time.perf_counter() - t0
    for name, s in timing["fit"].items():
        ev.metrics["models"][name]["fit_seconds"] = s
    models = {}
    for name in (n for n in SAVED if n in predictors):
        meta, arrays = predictors[name].get_state()
        models[name] = {"meta": meta, "arrays": arrays}
    timing["total"] = time.perf_counter() - t_start
    traces = {
        m: {
            s: {r: {c: f[c].to_numpy() for c in f} for r, f in runs.items()}
            for s, runs in sp.items()
        }
        for m, sp in ev.traces.items()
    }
    return {
        "metrics": ev.metrics,
        "traces": traces,
        "samples": ev.samples,
        "models": models,
        "timing_s": timing,
    }


def evaluation_of(result: Mapping[str, Any]) -> Evaluation:
    """The :class:`Evaluation` of a unit's result (for the tables and figures)."""
    traces = {
        m: {s: {r: pd.DataFrame(cols) for r, cols in runs.items()} for s, runs in sp.items()}
        for m, sp in result["traces"].items()
    }
    return Evaluation(dict(result["metrics"]), traces, dict(result["samples"]))


def saved_predictor(result: Mapping[str, Any], name: str, atlas: Atlas, seed: int) -> Predictor:
    """A predictor of ``SAVED`` rebuilt from a unit's result (to save as a model)."""
    pred = make_predictor(name, atlas, seed)
    state = result["models"][name]
    pred.set_state(state["meta"], state["arrays"])
    return pred


# ---------------------------------------------------------------------- over seeds
def headline(mean: Mapping[str, Any]) -> dict[str, float | None]:
    """The headline metrics of one model and split (its means over runs), flat."""
    out: dict[str, float | None] = {}
    for key in HEADLINE:
        v = mean.get(key)
        if key == "convergence_frac" and isinstance(v, Mapping):
            out.update((f"{key}.{t}", x) for t, x in v.items())
        elif key == "k_rel_error":
            out[key] = v.get("mean") if isinstance(v, Mapping) else None
        elif key in mean:
            out[key] = v
    return out


def spread(values: Sequence[float | None]) -> dict[str, Any]:
    """Mean, sample standard deviation (None for one value), min and max over the seeds with
    a value (None: a metric undefined for that seed), and the values per seed."""
    x = np.array([v for v in values if v is not None], dtype=np.float64)
    stats: dict[str, Any] = dict.fromkeys(("mean", "std", "min", "max"))
    if x.size:
        stats.update(mean=float(x.mean()), min=float(x.min()), max=float(x.max()))
        stats["std"] = float(x.std(ddof=1)) if x.size > 1 else None
    return {**stats, "n": int(x.size), "per_seed": list(values)}


def aggregate(metrics: Mapping[int, Mapping[str, Any]]) -> dict[str, Any]:
    """Model -> split -> headline metric -> :func:`spread` over the seeds' metrics trees
    (models and splits in the first seed's order)."""
    first = next(iter(metrics.values()))
    out: dict[str, Any] = {}
    for model, info in first["models"].items():
        out[model] = {}
        for split in info["splits"]:
            flat = [headline(m["models"][model]["splits"][split]["mean"]) for m in metrics.values()]
            keys = list(dict.fromkeys(k for f in flat for k in f))
            out[model][split] = {k: spread([f.get(k) for f in flat]) for k in keys}
    return out


def _cell(s: Mapping[str, Any], fmt: str) -> str:
    if s.get("mean") is None:
        return "-"
    return f"{s['mean']:{fmt}} [{s['min']:{fmt}}, {s['max']:{fmt}}]"


def rmse_seeds_table(doc: Mapping[str, Any], markdown: bool = False) -> str:
    """RUL RMSE [events] per predictor and split: mean, sd, min, max and each seed's."""
    seeds = doc["seeds"]
    rows = [["model", "split", "mean", "sd", "min", "max", *(f"seed {s}" for s in seeds)]]
    for model, splits in doc["metrics"].items():
        for split, ms in splits.items():
            s = ms["rul_rmse"]
            vals = [s["mean"], s["std"], s["min"], s["max"], *s["per_seed"]]
            rows.append([model, split, *("-" if v is None else f"{v:,.0f}" for v in vals)])
    return table(rows, markdown)


_OTHER = (
    ("RMSE/life", "rul_rmse_frac", ".3f"),
    ("conv 10%", "convergence_frac.0.1", ".2f"),
    ("RA", "relative_accuracy", ".2f"),
    ("a-l", "alpha_lambda", ".2f"),
    ("PH", "prognostic_horizon_frac", ".2f"),
    ("PHM08", "phm08", ".3g"),
    ("K err", "k_rel_error", ".3f"),
    ("coverage", "interval_coverage", ".2f"),
)


def other_seeds_table(doc: Mapping[str, Any], markdown: bool = False) -> str:
    """Other headline metrics per predictor and split: mean [min, max] over seeds."""
    rows = [["model", "split", *(h for h, _, _ in _OTHER)]]
    for model, splits in doc["metrics"].items():
        for split, ms in splits.items():
            rows.append([model, split, *(_cell(ms.get(k, {}), f) for _, k, f in _OTHER)])
    return table(rows, markdown)
