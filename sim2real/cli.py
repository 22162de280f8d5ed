"""``brakewear`` subcommands of the sim-to-real package (registered as a plug-in; the
diagnosis, the truth simulator and their plots are imported by the commands that run them,
so that parsing the command line stays fast).

- ``simulate --effect NAME[:PARAM=VALUE,...]`` (repeatable): the truth simulator, writing the
  same event-log files as ``brakewear simulate`` (plus ``time_s``);
- ``diagnose --real FILE [--model ATLAS] --out DIR``: localise, attribute, quantify;
- ``validate-gap --out DIR --seed S [--workers N | --ray [ADDRESS]]``: withheld-effect
  validation, confusion matrix; each case a unit of the runner, saved in ``DIR/units/`` as it
  finishes, so that a rerun of the same command resumes;
- the ``make demo`` stage: one withheld-effect diagnosis.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

from tqdm import tqdm

from brake_env.cli.common import (
    add_common_args,
    add_runner_args,
    add_strict_arg,
    int_at_least,
    load_atlas,
    make_runner,
)
from brake_env.cli.demo import DemoContext
from brake_env.cli.simulate import cmd_simulate, dataset_spec
from brake_env.data.datasets import SPLITS, DatasetSpec, write_dataset
from brake_env.data.plausibility import warn_implausible
from brake_env.data.schema import read_event_log
from brake_env.model.atlas import Atlas
from brake_env.model.regime import WearRegime
from brake_env.output import table, write_json, write_text
from sim2real.effects import Effect
from sim2real.library import describe_library, parse_effect, registry

if TYPE_CHECKING:
    from sim2real.config import DiagnosisConfig
    from sim2real.validate import ValidationSpec

_FMT = argparse.ArgumentDefaultsHelpFormatter


def _effect_arg(text: str) -> Effect:
    try:
        return parse_effect(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


# ---------------------------------------------------------------------- simulate --effect
def cmd_simulate_truth(args: argparse.Namespace) -> dict[str, Any]:
    """``brakewear simulate``: the truth simulator when effects are given, else the nominal."""
    from sim2real.truth import TruthSpec, simulate_truth

    effects: list[Effect] = args.effect or []
    if not effects:
        return cmd_simulate(args)
    if args.interpolate_layers:
        raise ValueError("--interpolate-layers is not supported together with --effect")
    out = Path(args.out)
    atlas = load_atlas(args)
    ds_spec = dataset_spec(args)
    spec = TruthSpec(ds_spec, mean_gap_s=args.mean_gap_s)
    t0 = time.perf_counter()
    with tqdm(desc="truth simulation", disable=args.quiet, delay=0.5) as bar:
        logs = simulate_truth(atlas.spec, effects, spec, args.seed, progress=bar.update)
    t_sim = time.perf_counter() - t0
    from brake_env.data.datasets import Dataset

    ds = Dataset([], logs, t_sim, seed=args.seed, spec=ds_spec)
    write_dataset(ds, out, args.format, meta={"effects": [e.key for e in effects]})
    rows = [["split", "runs", "events", "life mean", "temp mean C", "stop mean m"]]
    info: dict[str, Any] = {
        "seed": args.seed,
        "effects": [e.key for e in effects],
        "simulate_seconds": t_sim,
        "splits": {},
    }
    for split in SPLITS:
        lg = logs[split]
        if len(lg) == 0:
            continue
        life = lg.groupby("run_id", observed=True).size()
        info["splits"][split] = {
            "runs": int(life.size),
            "events": len(lg),
            "life_mean": float(life.mean()),
        }
        rows.append(
            [
                split,
                str(life.size),
                str(len(lg)),
                f"{life.mean():.0f}",
                f"{lg['temp_c'].mean():.1f}",
                f"{lg['stop_dist_m'].mean():.2f}",
            ]
        )
    write_json(info, out / "summary.json")
    print(f"effects: {', '.join(e.key for e in effects)}")
    print(table(rows))
    print(
        f"wrote {out}/{{{','.join(f'{s}.{f}' for s in SPLITS for f in args.format)}}},"
        f" summary.json ({t_sim:.1f} s)"
    )
    return info


# ---------------------------------------------------------------------- diagnose
def _config(args: argparse.Namespace) -> DiagnosisConfig:
    from sim2real.config import DiagnosisConfig

    return DiagnosisConfig(calibration_fraction=args.calibration_fraction)


def cmd_diagnose(args: argparse.Namespace) -> dict[str, Any]:
    from sim2real.preconditions import check_log

    out = Path(args.out)
    log = read_event_log(args.real)
    # Before the heavy imports and the long work: a log it cannot use fails in seconds.
    checked = check_log(log, _config(args), with_rul=not args.no_rul)
    for w in checked.warnings:
        print(f"diagnose: warning: {w}", file=sys.stderr)
    from sim2real.diagnose import diagnose
    from sim2real.report import write_outputs
    from sim2real.rul import rul_scorer

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
    text = write_outputs(res, out, {**extra, "log_checks": checked.summary()})
    print(text)
    print(f"\nwrote {out}/diagnosis.json, report.md, figures/ ({seconds:.1f} s)")
    return res.summary


# ---------------------------------------------------------------------- validate-gap
def cmd_validate_gap(args: argparse.Namespace) -> dict[str, Any]:
    """``brakewear validate-gap``: every case a unit of the runner, saved in ``OUT/units/``
    as it finishes; the same command again resumes from the saved cases."""
    from sim2real.validate import case_key, open_store, selected_cases, validate_gap

    _jobs_alias(args)
    out = Path(args.out)
    atlas = load_atlas(args)
    spec = _validation_spec(args)
    # Before any work (and before Ray starts): a store of other settings is refused.
    store = open_store(out / "units", atlas, spec, args.seed, args.only)
    todo = selected_cases(spec, args.seed, args.only)
    done = sum(case_key(c) in store for c in todo)
    if done:
        print(f"resuming: {done} of {len(todo)} cases already done")
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
    from sim2real.validate import ValidationSpec

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
    from sim2real.report import validation_figures, validation_text

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


# ---------------------------------------------------------------------- demo stage
def demo_stage(ctx: DemoContext) -> tuple[dict[str, Any], str]:
    """One withheld-effect case: truth logs with speed-dependent friction, diagnosed."""
    from sim2real.diagnose import diagnose
    from sim2real.report import write_outputs
    from sim2real.rul import rul_scorer
    from sim2real.truth import TruthSpec, simulate_truth

    out = ctx.out / "sim2real"
    atlas = Atlas.load(ctx.atlas_file)
    effect = parse_effect("speed_friction:a=0.2")
    ds = DatasetSpec(n_train=6, n_id=0, n_ood_slow=0, n_ood_fast=0, wear=WearRegime(2e-5, 2e-6))
    t0 = time.perf_counter()
    logs = simulate_truth(atlas.spec, [effect], TruthSpec(ds), seed=ctx.args.seed)
    from brake_env.data.schema import write_event_log

    write_event_log(logs["train"], out / "real.parquet")
    res = diagnose(logs["train"], atlas, seed=ctx.args.seed, rul=rul_scorer(atlas))
    seconds = time.perf_counter() - t0
    text = write_outputs(res, out, {"seconds": seconds, "withheld_effect": effect.key})
    print(f"withheld effect: {effect.key}\n{text}\n({seconds:.1f} s)")
    md = (
        f"## Sim-to-real gap diagnosis (withheld effect: `{effect.key}`)\n\n"
        f"6 short truth runs ({len(logs['train'])} events), {seconds:.0f} s."
        f" Verdict: **{res.verdict}**.\n\n```\n{text}\n```\n\n"
        "![residual maps](sim2real/figures/residual_maps.png)\n"
        "![before/after](sim2real/figures/before_after.png)\n"
    )
    return res.summary, md


# ---------------------------------------------------------------------- parser
def register(sub: argparse._SubParsersAction[Any]) -> None:
    """Add this package's subcommands to the ``brakewear`` parser."""
    sim = sub.choices.get("simulate")
    if sim is not None:
        _add_effect_args(sim)
    _add_diagnose(sub)
    _add_validate_gap(sub)


def _add_effect_args(sim: argparse.ArgumentParser) -> None:
    """``brakewear simulate --effect``: the truth simulator."""
    sim.add_argument(
        "--effect",
        action="append",
        type=_effect_arg,
        default=None,
        metavar="NAME[:PARAM=VALUE,...]",
        help="attach an unmodelled effect (repeatable; truth simulator). Names: "
        + ", ".join(sorted(registry())),
    )
    sim.add_argument(
        "--mean-gap-s",
        type=float,
        default=60.0,
        help="mean time between events with --effect [s]",
    )
    sim.set_defaults(func=cmd_simulate_truth)


def _add_diagnose(sub: argparse._SubParsersAction[Any]) -> None:
    d = sub.add_parser(
        "diagnose", formatter_class=_FMT, help="diagnose the sim-to-real gap of an event log"
    )
    add_common_args(d, "out/diagnose")
    d.add_argument("--real", required=True, help="event log (.parquet or .csv) to diagnose")
    d.add_argument("--model", default=None, help="the nominal model's atlas .npz")
    d.add_argument("--candidates", nargs="+", default=None, help="candidate effect names")
    d.add_argument(
        "--calibration-fraction",
        type=float,
        default=0.5,
        help="share of runs used to fit candidate parameters",
    )
    d.add_argument("--no-rul", action="store_true", help="skip the twin's RUL error")
    add_strict_arg(d)
    d.set_defaults(func=cmd_diagnose)


def _add_validate_gap(sub: argparse._SubParsersAction[Any]) -> None:
    v = sub.add_parser(
        "validate-gap",
        formatter_class=_FMT,
        help="withheld-effect validation of the diagnosis (confusion matrix)",
    )
    add_common_args(v, "out/validate-gap")
    v.add_argument("--seeds", type=int, default=3, help="seeds per effect at mid magnitude")
    v.add_argument("--controls", type=int, default=4, help="no-effect control cases")
    v.add_argument(
        "--out-of-library",
        type=int,
        default=2,
        help="cases of the out-of-library effect (pad glazing)",
    )
    v.add_argument("--runs", type=int, default=8, help="truth runs per case")
    v.add_argument(
        "--low", action="store_true", help="also each effect once at half its mid magnitude"
    )
    v.add_argument("--no-rul", action="store_true", help="skip the twin's RUL error")
    v.add_argument("--only", nargs="+", default=None, help="run only cases containing these")
    v.add_argument(
        "--route-block-events",
        type=int_at_least(0),
        default=0,
        help="0: independent operating conditions; N: haul-road and pit blocks of N events",
    )
    add_runner_args(v)
    # Deprecated alias of --workers, kept for old scripts (README's examples used it).
    v.add_argument("--jobs", type=int_at_least(1), default=None, help=argparse.SUPPRESS)
    v.set_defaults(func=cmd_validate_gap)
