"""``brakewear fit`` and ``brakewear predict``: a predictor fitted once, run on any fleet log
(docs/results/prognostics.md).

``fit`` fits one predictor on a training log and saves it without pickle
(:mod:`brake_env.prognostics.persist`). ``predict`` runs a saved predictor over every pad of
an event log (no ground truth needed; ``event`` counts from each pad's installation, so a log
may start mid-life) and writes, per pad, the current RUL with its interval, volume and K
where the predictor gives them and the events since installation:

- ``fleet.csv`` / ``fleet.json``: one row per pad, most urgent first (standard JSON: a
  missing value is ``null``);
- ``traces.parquet``: the estimate after every event of every pad;
- ``fleet.png``: RUL bars with intervals, and each pad's RUL along its events.

The pads run in units of a few pads (:mod:`~brake_env.prognostics.commands.predict_units`), in this
process or on Ray (``--workers``, ``--ray``; docs/cluster.md), each saved
under ``OUT/units/`` as it finishes: an interrupted predict run again resumes there.

Both check what they are given (model header, format, atlas, log columns) before the long
work, and a channel missing for a whole pad is reported, not silently worked around.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
from tqdm import tqdm

from brake_env.cli.common import (
    add_common_args,
    add_runner_args,
    add_strict_arg,
    int_at_least,
    make_runner,
    out_dir,
    read_atlas,
)
from brake_env.cli.predict_planner import PlannerSettings, add_planner_args, planner_settings
from brake_env.csv_safe import write_csv
from brake_env.data.datasets import find_logs
from brake_env.data.plausibility import warn_fitted, warn_implausible
from brake_env.data.runs import run_ends
from brake_env.data.schema import read_event_log
from brake_env.model.atlas import Atlas, AtlasSpec
from brake_env.output import atomic_path, table, write_json
from brake_env.prognostics.commands import predict_units
from brake_env.prognostics.commands.fit_effects import add_effect_args, fit_atlas
from brake_env.prognostics.commands.fleet_plot import plot_fleet
from brake_env.prognostics.commands.self_check import self_check
from brake_env.prognostics.persist import (
    check_atlas,
    load_predictor,
    model_atlas,
    read_header,
    save_predictor,
)
from brake_env.prognostics.protocol import MEASURED, EventBatch, Predictor, iter_runs
from brake_env.prognostics.registry import make_predictor, predictor_names
from brake_env.runner import UnitsFailed
from brake_env.units import UnitStore, open_store


def register(sub: argparse._SubParsersAction[Any]) -> None:
    """Add ``fit`` and ``predict`` to the ``brakewear`` parser."""
    fmt = argparse.ArgumentDefaultsHelpFormatter
    f = sub.add_parser(
        "fit", formatter_class=fmt, help="fit a RUL predictor on a training log and save it"
    )
    add_common_args(f, "out/model")
    f.add_argument(
        "--data",
        required=True,
        help="training event log (.parquet/.csv), or a brakewear simulate directory (its"
        " train log); runs without failure are used as censored if the predictor can",
    )
    f.add_argument("--predictor", required=True, choices=predictor_names())
    f.add_argument("--atlas", default=None, help="atlas .npz to use instead of the cache")
    add_effect_args(f)
    add_strict_arg(f)
    f.set_defaults(func=cmd_fit)

    p = sub.add_parser(
        "predict", formatter_class=fmt, help="RUL of every pad of an event log from a saved model"
    )
    p.add_argument("--model", required=True, help="model directory written by brakewear fit")
    p.add_argument("--log", required=True, help="event log (.parquet/.csv), no truth needed")
    p.add_argument("--out", type=out_dir, default="out/predict", help="output directory")
    p.add_argument(
        "--atlas", default=None, help="atlas .npz (default: the model's atlas, from the cache)"
    )
    p.add_argument(
        "--cache-dir", type=out_dir, default=None, help="atlas cache (as for the other commands)"
    )
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument(
        "--pads-per-unit",
        type=int_at_least(1),
        default=predict_units.PADS_PER_UNIT,
        help="pads per unit of work: units run in parallel with --workers/--ray, and an"
        " interrupted predict resumes from the units saved in OUT/units/ (the estimates do"
        " not depend on where units run; another chunking moves them by rounding, ~1e-13)",
    )
    add_planner_args(p)
    add_runner_args(p)
    add_strict_arg(p)
    p.set_defaults(func=cmd_predict)


# ---------------------------------------------------------------------------------- fit
def training_log_path(data: str) -> Path:
    """The log file itself, or the train log of a ``brakewear simulate`` directory."""
    d = Path(data)
    if d.is_dir():  # through the manifest check: a half-rewritten directory is refused
        return find_logs(d, ("train",))["train"]
    if not d.exists():
        raise FileNotFoundError(f"training log {d} does not exist")
    return d


def cmd_fit(args: argparse.Namespace) -> Path:
    """``brakewear fit``: read, fit, save. The log is checked before the atlas is built."""
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out}: exists and is not a directory")
    path = training_log_path(args.data)
    log = read_event_log(path)
    atlas = fit_atlas(args)
    warn_implausible(log, atlas, "fit", lives=True, strict=args.strict)
    pred = make_predictor(args.predictor, atlas, args.seed)
    if type(pred).get_state is Predictor.get_state:
        raise ValueError(f"predictor {args.predictor!r} cannot be saved (no get_state)")
    n_runs = int(log["run_id"].nunique())
    censored = censored_runs(log)
    if not args.quiet:
        print(f"fit {args.predictor} on {n_runs} runs, {len(log):,} events ...", file=sys.stderr)
    t0 = time.perf_counter()
    pred.fit(log)
    fit_s = time.perf_counter() - t0
    warn_fitted({args.predictor: pred.fitted_wear_coeff()}, "fit", strict=args.strict)
    info = {
        "data": str(path),
        "runs": n_runs,
        "events": len(log),
        "censored_runs": censored,
        "fit_seconds": fit_s,
        "effects": list(atlas.spec.effects),
        "self_check": self_check(pred, log, "fit", args.strict),
    }
    save_predictor(pred, out, atlas, seed=args.seed, info=info)
    meta, _ = pred.get_state()
    learned = {k: v for k, v in meta.items() if k != "config"}  # settings are not learned
    flat = {
        f"{k}.{k2}": v for k, d in learned.items() if isinstance(d, dict) for k2, v in d.items()
    }
    flat.update((k, v) for k, v in learned.items() if not isinstance(v, dict))
    rows = [["learned", "value"]] + [
        [k, f"{v:.6g}" if isinstance(v, float) else str(v)]
        for k, v in flat.items()
        if isinstance(v, int | float | str)
    ]
    if len(rows) > 1:
        print(table(rows))
    print(
        f"fitted {args.predictor} on {n_runs} runs ({len(censored)} censored) in"
        f" {fit_s:.1f} s{_with_effects(atlas)}; wrote {out}/ (predictor.json, arrays.npz)"
    )
    return out


def _with_effects(atlas: Atlas) -> str:
    effects = atlas.spec.effects
    return f" on the physics with {' + '.join(effects)}" if effects else ""


def censored_runs(log: pd.DataFrame) -> list[str]:
    """Runs whose last event is not marked ``failed`` (removed before failure); none when
    the log has no ``failed`` column (every run then ends at failure)."""
    ends = run_ends(log, "fit")
    return [str(r) for r in ends.names[ends.censored]]


# ------------------------------------------------------------------------------ predict
UNITS = "units"  # the unit store under --out: its files removed once the outputs are written


def cmd_predict(args: argparse.Namespace) -> pd.DataFrame:
    """``brakewear predict``; returns the fleet table.

    The pads run in units of ``--pads-per-unit`` (:mod:`.predict_units`), here or on Ray,
    each saved under ``OUT/units/`` as it finishes, so an interrupted predict resumes; that
    store goes once the outputs hold every pad."""
    t0 = time.perf_counter()
    header = read_header(args.model)
    atlas_of = _atlas_loader(header, args)  # checks the atlas hash, builds nothing yet
    log = read_event_log(args.log)
    planner = planner_settings(log, args)  # its flags checked before the long work
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out}: exists and is not a directory")
    missing = missing_channels(log)
    runs = list(iter_runs(log))
    with _open_store(header, args, len(runs)) as store:  # before the long start-up
        atlas = atlas_of()
        warn_implausible(log, atlas, "predict", strict=args.strict)
        pred = load_predictor(args.model, atlas)
        try:
            traces, rows = _predict_units(pred, (header, atlas), runs, args, store)
        finally:
            predict_units.forget()
        checks = _checks(pred, log, header, args.strict)
        context = (header, args, planner, atlas)
        fleet = _finish(out, (traces, rows), (missing, checks), pred, context)
        store.discard()  # its own files only: anything else in OUT/units/ stays
    print(table(_display_rows(fleet)))
    print(
        f"\n{len(fleet)} pads, {len(log):,} events in {time.perf_counter() - t0:.1f} s;"
        f" wrote {out}/fleet.csv, fleet.json, traces.parquet, fleet.png"
    )
    return fleet


def _checks(
    pred: Predictor, log: pd.DataFrame, header: dict[str, Any], strict: bool
) -> dict[str, Any]:
    """The model's self-check on this log, and the one its fit recorded (repeated as a
    warning when it warned: a model fitted on a misfitting log stays suspect)."""
    fitted = (header.get("info") or {}).get("self_check") or {}
    if fitted.get("warns"):
        print(f"brakewear predict: warning: at fit: {fitted['message']}", file=sys.stderr)
    return {"log": self_check(pred, log, "predict", strict), "fit": fitted}


def _finish(
    out: Path,
    outputs: tuple[pd.DataFrame, pd.DataFrame],
    found: tuple[dict[str, list[str]], dict[str, Any]],
    pred: Predictor,
    context: tuple[dict[str, Any], argparse.Namespace, PlannerSettings, Atlas],
) -> pd.DataFrame:
    """Write the outputs of the units' ``(traces, rows)``; the table, the planner's
    columns appended (:mod:`brake_env.cli.predict_planner`)."""
    (traces, rows), (header, args, planner, atlas), (missing, checks) = outputs, context, found
    fleet = predict_units.sort_table(rows, missing)
    fleet, planned = planner.columns(fleet, atlas, pred.interval_level)
    warnings = [
        f"pad {run}: {', '.join(ch)} missing at every event; {pred.name} cannot use"
        f" {'them' if len(ch) > 1 else 'it'} for this pad (a predictor that needs it gives"
        " what it learned in training: the twin its prior over K)"
        for run, ch in missing.items()
    ]
    for w in warnings:
        print(f"predict: warning: {w}", file=sys.stderr)
    if planner.note():  # not a warning: the log says nothing of time, nothing is wrong
        print(f"predict: note: {planner.note()}", file=sys.stderr)
    warnings += [f"{at}: {c['message']}" for at, c in checks.items() if c.get("warns")]
    info = {"planner_units": planned, "warnings": warnings}
    _write_outputs(out, fleet, traces, pred, (header, checks), args, info=info)
    return fleet


def _open_store(header: dict[str, Any], args: argparse.Namespace, n_pads: int) -> UnitStore:
    """The predict's unit store (locked, checked), opened before the atlas and model load:
    a store of other settings, a damaged unit or another run in ``--out`` is told first."""
    ppu = args.pads_per_unit
    settings = predict_units.store_settings(args.model, args.log, header["atlas_hash"], n_pads, ppu)
    keys = predict_units.unit_keys(n_pads, ppu)
    return open_store(Path(args.out) / UNITS, settings, keys, "predict")


def _predict_units(
    pred: Predictor,
    fitted: tuple[dict[str, Any], Atlas],
    runs: list[tuple[str, EventBatch]],
    args: argparse.Namespace,
    store: UnitStore,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """(traces, unsorted per-pad rows) of every pad, unit by unit (or read back from the
    store of an interrupted run with the same settings); ``fitted``: the model's header
    and atlas."""
    header, atlas = fitted
    ppu = args.pads_per_unit
    n_events = sum(len(ev) for _, ev in runs)
    with (
        make_runner(args) as runner,
        tqdm(
            total=n_events, desc="predict", unit="event", unit_scale=True, disable=args.quiet
        ) as bar,
    ):
        model = runner.share(predict_units.SavedModel.of(pred, args.model, header, atlas))
        units = predict_units.pad_units(model, runner.share(atlas), runs, ppu)
        try:
            return predict_units.run_pads(runner, units, store, bar.update)
        except UnitsFailed as e:
            raise ValueError(
                f"{e}\nthe other units are saved in {store.directory}; run the same command"
                " again to redo only the failed ones"
            ) from e


def _atlas_loader(header: dict[str, Any], args: argparse.Namespace) -> Callable[[], Atlas]:
    """A function giving the model's atlas, after checking its hash against the header."""
    if args.atlas:
        atlas = read_atlas(args.atlas)
        check_atlas(header, atlas.content_hash, args.model)
        return lambda: atlas
    check_atlas(
        header, AtlasSpec.from_dict(header.get("atlas_spec") or {}).content_hash(), args.model
    )
    return lambda: model_atlas(header, args.cache_dir)


def missing_channels(log: pd.DataFrame) -> dict[str, list[str]]:
    """Run -> measured channels with no value at all in that run (empty runs left out)."""
    nan = log[list(MEASURED)].isna()
    allnan = nan.groupby(log["run_id"], observed=True, sort=False).all()
    return {
        str(run): [c for c in MEASURED if row[c]] for run, row in allnan.iterrows() if row.any()
    }


def _display_rows(fleet: pd.DataFrame) -> list[list[str]]:
    def num(x: Any, spec: str) -> str:
        return "-" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, spec)

    head = ["pad", "events", "since install", "RUL", "interval", "volume", "K", "missing"]
    rows = [head]
    for r in fleet.to_dict("records"):
        lo, hi = r.get("rul_lower"), r.get("rul_upper")
        interval = "-" if lo is None else f"[{num(lo, ',.0f')}, {num(hi, ',.0f')}]"
        rows.append(
            [
                r["run_id"],
                f"{r['events_logged']:,}",
                f"{r['events_since_install']:,}",
                num(r["rul_mean"], ",.0f"),
                interval,
                num(r.get("volume_frac"), ".3f"),
                num(r.get("wear_coeff"), ".3e"),
                r["missing_channels"] or "-",
            ]
        )
    return rows


def _write_outputs(
    out: Path,
    fleet: pd.DataFrame,
    traces: pd.DataFrame,
    pred: Predictor,
    model: tuple[dict[str, Any], dict[str, Any]],
    args: argparse.Namespace,
    *,
    info: dict[str, Any],
) -> None:
    """``info``: ``warnings`` and ``planner_units`` (the planner columns' settings)."""
    header, checks = model
    write_csv(fleet, out / "fleet.csv")  # spreadsheet-safe: a pad id is never a formula
    doc = {
        "model": str(args.model),
        "predictor": pred.name,
        "log": str(args.log),
        "atlas_hash": header["atlas_hash"],
        "effects": list((header.get("atlas_spec") or {}).get("effects") or []),
        "interval_level": pred.interval_level,
        "warnings": info["warnings"],
        "self_check": checks,
        "planner_units": info["planner_units"],
        "pads": [
            {**r, "missing_channels": [c for c in r["missing_channels"].split(";") if c]}
            for r in fleet.to_dict("records")
        ],
    }
    write_json(doc, out / "fleet.json")  # standard JSON: a missing value is null
    with atomic_path(out / "traces.parquet") as tmp:
        pq.write_table(pa.Table.from_pandas(traces, preserve_index=False), tmp, compression="zstd")
    with atomic_path(out / "fleet.png") as tmp:
        plot_fleet(fleet, traces, pred.name, Path(args.log).name).savefig(tmp, dpi=100)
