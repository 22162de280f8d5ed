"""``brakewear backtest``: the predictors scored on a fleet's own history, with no truth
columns (:mod:`brake_env.prognostics.backtest`; docs/cli.md, "backtest").

Reads the history (a log file, or the train log of a ``brakewear simulate`` directory),
holds each pad out in turn (``--folds K``: K groups of pads), fits every predictor on the
other pads and scores it on the held-out ones, and writes:

- ``backtest.json``: the settings, one row per predictor and pad, per predictor the means
  over pads with bootstrap intervals, and the ranking by RMSE with paired intervals;
- ``backtest.csv``: the per-pad rows;
- ``backtest.png``: each predictor's RUL error along the lives of the failed pads, and the
  means with their intervals.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Sequence
from functools import partial
from pathlib import Path
from typing import Any

from tqdm import tqdm

from brake_env.cli.common import (
    add_common_args,
    add_strict_arg,
    int_at_least,
    load_atlas,
    predictor_list,
)
from brake_env.csv_safe import write_csv
from brake_env.data.plausibility import warn_implausible
from brake_env.data.schema import read_event_log
from brake_env.model.atlas import Atlas, cached_atlas
from brake_env.output import atomic_path, table, write_json
from brake_env.prognostics.backtest import (
    CENSORED_METRICS,
    BacktestResult,
    backtest,
    history_pads,
)
from brake_env.prognostics.commands.fit_effects import (
    add_effect_args,
    effect_spec,
    requested_effects,
)
from brake_env.prognostics.commands.fit_predict import training_log_path
from brake_env.prognostics.protocol import Predictor
from brake_env.prognostics.registry import ORACLE, Factory, make_predictor, predictor_names
from brake_env.prognostics.tables import rmse_table

DEFAULT_PREDICTORS = ("twin", "window", "physics")
FILES = ("backtest.json", "backtest.csv", "backtest.png")


def register(sub: argparse._SubParsersAction[Any]) -> None:
    """Add ``backtest`` to the ``brakewear`` parser."""
    b = sub.add_parser(
        "backtest",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
        help="score RUL predictors on your own history (pads run to failure and pads removed"
        " early), leaving each pad out in turn; no truth columns needed",
    )
    add_common_args(b, "out/backtest")
    b.add_argument(
        "--data",
        required=True,
        help="the history: an event log (.parquet/.csv) or a brakewear simulate directory (its"
        " train log); a run whose last event is not 'failed' was removed before failure",
    )
    b.add_argument(
        "--predictors",
        type=predictor_list,
        default=DEFAULT_PREDICTORS,
        help=f"comma-separated predictors among {','.join(predictor_names())}",
    )
    b.add_argument(
        "--folds",
        type=int_at_least(0),
        default=0,
        help="0: leave one pad out; K >= 2: K groups of pads, drawn with --seed",
    )
    b.add_argument("--atlas", default=None, help="atlas .npz to use instead of the cache")
    add_effect_args(b)
    b.add_argument(
        "--fed-back",
        type=predictor_list,
        default=("twin",),
        help="with --effect/--diagnosis: these predictors are scored a second time, fitted"
        " on the physics with the effect (named NAME+effect), beside the nominal ones",
    )
    add_strict_arg(b)
    b.set_defaults(func=cmd_backtest)


def cmd_backtest(args: argparse.Namespace) -> BacktestResult:
    """``brakewear backtest``: read, check, back-test, write, print."""
    t0 = time.perf_counter()
    out = Path(args.out)
    path = training_log_path(args.data)
    log = read_event_log(path)
    _, pads, truth = history_pads(log)  # the log's own errors before the atlas is built
    if truth:
        print(
            f"backtest: the log holds truth column(s) {', '.join(truth)}; they are ignored"
            " (neither fitted on nor scored against)",
            file=sys.stderr,
        )
    effects = requested_effects(args)
    atlas = load_atlas(args)
    warn_implausible(log, atlas, "backtest", lives=True, strict=args.strict)
    factories = _with_fed_back(args, effects)
    n_folds = args.folds or len(pads)
    with tqdm(
        total=n_folds * len(factories), desc="backtest", unit="fit", disable=args.quiet
    ) as bar:
        res = backtest(
            log, atlas, factories, args.folds, args.seed, progress=lambda _n: bar.update()
        )
    res.settings.update(data=str(path), atlas_hash=atlas.content_hash, effects=list(effects))
    _write_outputs(res, out)
    if res.ranking is not None:  # a pad run to failure: evaluate's table of RMSE per pad
        print(rmse_table(_rmse_metrics(res)) + "\n")
    print(summary_table(res))
    print(
        f"\n{len(pads)} pads, {res.settings['protocol']}, {time.perf_counter() - t0:.1f} s;"
        f" wrote {out}/{', '.join(FILES)}"
    )
    return res


def _with_fed_back(args: argparse.Namespace, effects: tuple[str, ...]) -> dict[str, Factory]:
    """The factories of ``--predictors`` and, with effects, of each ``--fed-back`` predictor
    on the atlas with the effects (the names checked before that atlas is built)."""
    predictor_factories(args.predictors, args.fed_back)  # unknown names fail in seconds
    if not effects:
        return predictor_factories(args.predictors)
    fed = cached_atlas(effect_spec(args, effects), args.cache_dir)
    return predictor_factories(args.predictors, args.fed_back, fed)


def predictor_factories(
    names: Sequence[str], fed_back: Sequence[str] = (), fed_atlas: Atlas | None = None
) -> dict[str, Factory]:
    """Name -> factory of each predictor in ``names`` (checked by name), plus, with
    ``fed_atlas``, ``NAME+effect`` for each of ``fed_back``: made on ``fed_atlas`` (the
    physics with the effect fed back) whatever atlas the back-test passes.

    Raises:
        ValueError: An unknown name, or the oracle (it reads truth columns).
    """
    known = predictor_names()
    bad = [n for n in (*names, *fed_back) if n not in known or n == ORACLE]
    if bad:
        valid = [n for n in known if n != ORACLE]
        raise ValueError(
            f"backtest: unknown predictor(s) {bad}; valid are {valid} (the oracle reads truth"
            " columns, which a history does not hold)"
        )
    out: dict[str, Factory] = {n: partial(make_predictor, n) for n in names}
    if fed_atlas is not None:
        for n in fed_back:
            out[f"{n}+effect"] = partial(_on_atlas, n, fed_atlas)
    return out


def _on_atlas(name: str, atlas: Atlas, _nominal: Atlas, seed: int) -> Predictor:
    return make_predictor(name, atlas, seed)


# ---------------------------------------------------------------------- tables
def _rmse_metrics(res: BacktestResult) -> dict[str, Any]:
    """The failed pads' RMSE in the shape of ``brakewear evaluate``'s metrics, so its table
    (:func:`~brake_env.prognostics.tables.rmse_table`) prints them: one split, ``failed``."""
    failed = res.pads[res.pads["outcome"] == "failed"]
    runs = list(dict.fromkeys(failed["pad"]))
    models = {}
    for name, s in res.summary.items():
        mine = failed[failed["predictor"] == name].set_index("pad")["rmse"]
        per = {r: {"rul_rmse": _value(mine.get(r))} for r in runs}
        mean = {"rul_rmse": s["rmse"]["mean"] if s["rmse"] else None}
        models[name] = {"splits": {"failed": {"runs": per, "mean": mean}}}
    return {"splits": {"failed": {"runs": runs}}, "models": models}


def _value(x: Any) -> float | None:
    return None if x is None or (isinstance(x, float) and math.isnan(x)) else float(x)


def interval_cell(stat: dict[str, Any] | None, fmt: str) -> str:
    """``mean [lo, hi]`` (``-`` without a value, no interval from one pad)."""
    if stat is None:
        return "-"
    if stat["lo"] is None:
        return format(stat["mean"], fmt)
    return f"{stat['mean']:{fmt}} [{stat['lo']:{fmt}}, {stat['hi']:{fmt}}]"


def summary_table(res: BacktestResult, markdown: bool = False) -> str:
    """Per predictor: pads used and the means over pads with their bootstrap intervals."""
    level = f"{res.settings['level']:.0%}"
    lo, hi = (f"{c:.0%}" for c in res.settings["cut"])
    rows = [
        [
            "model",
            "failed",
            f"RMSE {lo}-{hi} [{level}]",
            "RMSE every event",
            f"coverage [{level}]",
            "censored",
            f"premature [{level}]",
            "measured",
            f"volume error [{level}]",
        ]
    ]
    for name, s in res.summary.items():
        rows.append(
            [
                name,
                str(s["failed_pads"]),
                interval_cell(s["rmse"], ",.0f"),
                interval_cell(s["rmse_all"], ",.0f"),
                interval_cell(s["coverage"], ".2f"),
                str(s["censored_pads"]),
                interval_cell(s["premature"], ".2f"),
                str(s["measured_pads"]),
                interval_cell(s["volume_abs_error"], ".3f"),
            ]
        )
    return table(rows, markdown)


# ---------------------------------------------------------------------- files
def _write_outputs(res: BacktestResult, out: Path) -> None:
    doc = {
        "settings": res.settings,
        "summary": res.summary,
        "ranking": res.ranking,
        "seconds": res.seconds,
        "pads": res.pads.to_dict("records"),
    }
    write_json(doc, out / "backtest.json")  # standard JSON: a missing value is null
    write_csv(res.pads, out / "backtest.csv")  # spreadsheet-safe pad ids
    with atomic_path(out / "backtest.png") as tmp:
        plot_backtest(res).savefig(tmp, dpi=100)


def plot_backtest(res: BacktestResult) -> Any:
    """One panel per predictor: the RUL error along each failed pad's life (the cut points
    shaded); then the mean RMSE [events] and the mean rates (coverage, premature, volume
    error, all in [0, 1]) over pads, with their intervals."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(res.summary)
    fig, axes = plt.subplots(1, len(names) + 2, figsize=(3.8 * (len(names) + 2), 3.6))
    for ax, name in zip(axes, names, strict=False):
        err = res.errors[res.errors["predictor"] == name]
        for _, tr in err.groupby("pad", sort=False):
            ax.plot(tr["life_frac"], tr["error"], lw=0.8, alpha=0.7)
        ax.axvspan(*res.settings["cut"], color="0.9", zorder=0)
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set(title=name, xlabel="life fraction", ylabel="RUL error [events]")
        if err.empty:
            ax.text(0.5, 0.5, "no failed pad", ha="center", transform=ax.transAxes)
    _bars(axes[-2], res, ("rmse",), "RMSE over failed pads [events]")
    _bars(axes[-1], res, ("coverage", *CENSORED_METRICS), "rates over pads [-]")
    fig.tight_layout()
    return fig


def _bars(ax: Any, res: BacktestResult, scores: tuple[str, ...], title: str) -> None:
    """Each score's mean over pads and its interval, a bar per predictor."""
    names = list(res.summary)
    width = 0.8 / len(names)
    for j, name in enumerate(names):
        for i, key in enumerate(scores):
            s = res.summary[name][key]
            if s is None:
                continue
            x = i + (j - (len(names) - 1) / 2) * width
            ax.bar(x, s["mean"], width, color=f"C{j}", label=name if i == 0 else None)
            if s["lo"] is not None:
                ax.plot([x, x], [s["lo"], s["hi"]], color="k", lw=1)
    ax.set_xticks(range(len(scores)), scores, rotation=15)
    ax.set_title(title)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=8)
