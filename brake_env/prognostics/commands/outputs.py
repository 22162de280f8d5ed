"""The files of an evaluation (``metrics.json``, ``table.md``, figures, kept models) and
the checks the one-seed and the multi-seed ``brakewear evaluate`` share."""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from pathlib import Path
from typing import Any

from brake_env.data.datasets import DatasetSpec
from brake_env.model.atlas import Atlas
from brake_env.model.regime import WearRegime
from brake_env.output import write_json, write_text
from brake_env.prognostics.evaluation import Evaluation
from brake_env.prognostics.persist import ARRAYS, HEADER, save_predictor
from brake_env.prognostics.protocol import Predictor

SIMULATION = ("n_train", "n_id", "n_ood_slow", "n_ood_fast", "k_mean", "k_std", "ood_shift_sigma")


def simulation_options(args: argparse.Namespace) -> list[str]:
    """The dataset options (``--n-*``, ``--k-*``) given other values than their defaults."""
    defaults = {**dataclasses.asdict(DatasetSpec()), **dataclasses.asdict(WearRegime())}
    return [k for k in SIMULATION if getattr(args, k, None) not in (defaults.get(k), None)]


def check_data_atlas(data_dir: Path, atlas_hash: str) -> None:
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


def write_evaluation(
    ev: Evaluation,
    out: Path,
    predictors: dict[str, Predictor],
    atlas: Atlas,
    data: dict[str, Any],
    *,
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
    write_text(markdown_tables(ev) + "\n", out / "table.md")
    return saved


def _save_models(
    predictors: dict[str, Predictor], out: Path, atlas: Atlas, seed: int
) -> dict[str, list[str]]:
    """The predictors evaluate keeps (:attr:`Predictor.kept_by_evaluate`: the MLP's
    weights) as model directories ``brakewear predict --model`` reads (no pickle), their
    files relative to ``out``."""
    saved = {}
    for name, pred in predictors.items():
        if pred.kept_by_evaluate:
            path = save_predictor(pred, out / "models" / name, atlas, seed=seed)
            saved[name] = [str((path / f).relative_to(out)) for f in (HEADER, ARRAYS)]
    return saved


def markdown_tables(ev: Evaluation) -> str:
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
