"""What the sim-to-real package's ``brakewear`` subcommands run (their parser is
:mod:`sim2real.commands.parser`, which names these functions, so this module and the
diagnosis it imports load only when a command runs):

- ``diagnose --real FILE [--model ATLAS] --out DIR``: localise, attribute, quantify;
- ``validate-gap --out DIR --seed S [--workers N | --ray [ADDRESS]]``: withheld-effect
  validation, confusion matrix; each case a unit of the runner (:mod:`sim2real.commands.units`),
  saved in ``DIR/units/`` as it finishes, so that a rerun of the same command resumes;
- ``simulate --effect``: added to ``brakewear simulate`` (:mod:`sim2real.commands.simulate`).

Each command turns its arguments into typed settings (:class:`DiagnosisConfig`,
:class:`ValidationSpec`); the figures (matplotlib) are imported only when drawn.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

import pandas as pd
from tqdm import tqdm

from brake_env.cli.common import (
    load_atlas,
    make_runner,
)
from brake_env.data.plausibility import warn_implausible
from brake_env.data.schema import read_event_log
from brake_env.model.atlas import Atlas
from brake_env.output import write_json, write_text
from sim2real.commands.units import open_store, validate_gap
from sim2real.diagnosis.config import DiagnosisConfig
from sim2real.diagnosis.diagnose import DiagnosisResult, diagnose
from sim2real.diagnosis.fix import worth_of_fix
from sim2real.diagnosis.preconditions import check_log
from sim2real.diagnosis.rul import rul_scorer
from sim2real.effects.library import describe_library, registry
from sim2real.validation.plots import validation_figures
from sim2real.validation.report import validation_text, write_outputs
from sim2real.validation.validate import ValidationSpec, selected_cases


# ---------------------------------------------------------------------- diagnose
def _config(args: argparse.Namespace) -> DiagnosisConfig:
    return DiagnosisConfig(calibration_fraction=args.calibration_fraction)


def cmd_diagnose(args: argparse.Namespace) -> dict[str, Any]:
    out = Path(args.out)
    log = read_event_log(args.real)
    # Before the long work: a log it cannot use fails in seconds.
    checked = check_log(log, _config(args), with_rul=not args.no_rul)
    for w in checked.warnings:
        print(f"diagnose: warning: {w}", file=sys.stderr)

    atlas = Atlas.load(args.model) if args.model else load_atlas(args)
    warn_implausible(log, atlas, "diagnose", strict=args.strict)
    cands = None
    if args.candidates:
        reg = registry()
        bad = [c for c in args.candidates if c not in reg]
        if bad:
            raise ValueError(f"unknown candidate(s) {bad}; valid are {sorted(reg)}")
        cands = [reg[c] for c in args.candidates]
    t0 = time.perf_counter()
    with tqdm(desc="diagnose", unit="model", disable=args.quiet, delay=0.5) as bar:
        res = diagnose(
            log,
            atlas,
            cands,
            _config(args),
            args.seed,
            progress=lambda _: bar.update(),
            rul=None if args.no_rul else rul_scorer(atlas),
        )
    seconds = time.perf_counter() - t0
    extra = {"seconds": seconds, "real": str(args.real), "library": describe_library()}
    extra["log_checks"] = checked.summary()
    text = write_outputs(res, out, extra)  # written before the back-test, which may fail
    if args.backtest:
        text = _worth_of_fix(args, log, atlas, res, out, extra)
    print(text)
    print(f"\nwrote {out}/diagnosis.json, report.md, figures/ ({seconds:.1f} s)")
    return res.summary


def _worth_of_fix(
    args: argparse.Namespace,
    log: pd.DataFrame,
    atlas: Atlas,
    res: DiagnosisResult,
    out: Path,
    extra: dict[str, Any],
) -> str:
    """``--backtest``: what the fix is worth on the log, in ``fix`` of the diagnosis's
    files (rewritten); the report's text."""
    t0 = time.perf_counter()
    winner = res.winner
    fed = args.backtest_fed_back
    n_fits = (len(args.backtest_predictors) + len(fed)) * res.summary["log"]["runs"]
    with tqdm(total=n_fits, desc="backtest", unit="fit", disable=args.quiet, delay=0.5) as bar:
        fix = worth_of_fix(
            log,
            atlas,
            winner,
            res.summary["attribution"]["parameter"],
            predictors=args.backtest_predictors,
            fed_back=fed,
            seed=args.seed,
            cache_dir=args.cache_dir,
            progress=lambda _: bar.update(),
        )
    fix["seconds_total"] = time.perf_counter() - t0
    if fix["status"] != "done":
        print(f"diagnose: --backtest: {fix['note']}", file=sys.stderr)
    res.summary["fix"] = fix
    return write_outputs(res, out, extra, draw=False)  # the figures are drawn


# ---------------------------------------------------------------------- validate-gap
def cmd_validate_gap(args: argparse.Namespace) -> dict[str, Any]:
    """``brakewear validate-gap``: every case a unit of the runner, saved in ``OUT/units/``
    as it finishes; the same command again resumes from the saved cases."""
    _jobs_alias(args)
    out = Path(args.out)
    atlas = load_atlas(args)
    spec = _validation_spec(args)
    # Before any work (and before Ray starts): a store of other settings is refused.
    store = open_store(out / "units", atlas, spec, args.seed, args.only)
    todo = selected_cases(spec, args.seed, args.only)
    t0 = time.perf_counter()
    with (
        make_runner(args) as runner,
        tqdm(desc="validate", unit="case", total=len(todo), disable=args.quiet) as bar,
    ):
        r = validate_gap(
            atlas,
            spec,
            args.seed,
            progress=lambda _: bar.update(),
            case_filter=args.only,
            runner=runner,
            store=store,
        )
    r["seconds"] = time.perf_counter() - t0
    r["settings"] = {
        "seed": args.seed,
        **{k: getattr(spec, k) for k in _SPEC_SETTINGS},
        "only": args.only,
        "workers": args.workers,
        "ray": args.ray,
    }
    _write_validation(r, out, args.seed)
    return r


_SPEC_SETTINGS = (
    "seeds_mid",
    "low_magnitude",
    "n_controls",
    "n_out_of_library",
    "n_runs",
    "k_mean",
    "route_block_events",
)


def _jobs_alias(args: argparse.Namespace) -> None:
    """``--jobs N``, deprecated: ``--workers N`` (``--jobs 1`` was and is: in this process)."""
    if args.jobs is None:
        return
    workers = args.jobs if args.jobs > 1 else 0
    if args.workers not in (0, workers):
        raise ValueError(f"--jobs {args.jobs} and --workers {args.workers}: give --workers only")
    print(f"note: --jobs is deprecated, use --workers {workers}", file=sys.stderr)
    args.workers = workers


def _validation_spec(args: argparse.Namespace) -> ValidationSpec:
    return ValidationSpec(
        seeds_mid=args.seeds,
        low_magnitude=args.low,
        n_out_of_library=args.out_of_library,
        n_controls=args.controls,
        n_runs=args.runs,
        with_rul=not args.no_rul,
        route_block_events=args.route_block_events,
    )


def _write_validation(r: dict[str, Any], out: Path, seed: int) -> None:
    write_json(r, out / "validation.json")
    text = validation_text(r)
    figs = validation_figures(r, out)
    write_text(
        f"# Withheld-effect validation (seed {seed})\n\n```\n{text}\n```\n\n"
        + "\n".join(f"![{p.stem}]({p.name})" for p in figs)
        + "\n",
        out / "validation.md",
    )
    print(text)
    print(
        f"\nwrote {out}/validation.json, validation.md, confusion.png, shrink.png,"
        f" units/ ({r['seconds']:.0f} s)"
    )


# ---------------------------------------------------------------------- parser
