"""``brakewear simulate --effect NAME[:PARAM=VALUE,...]`` (repeatable): the truth simulator,
writing the same event-log files as ``brakewear simulate`` (plus ``time_s``). Without an
effect the command is the nominal ``brakewear simulate``."""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

from tqdm import tqdm

from brake_env.cli.common import POSITIVE, load_atlas
from brake_env.cli.simulate import cmd_simulate, dataset_spec
from brake_env.data.datasets import SPLITS, Dataset, write_dataset
from brake_env.output import table, write_json
from sim2real.effects.interface import Effect
from sim2real.effects.library import parse_effect, registry
from sim2real.effects.truth import TruthSpec, simulate_truth


def _effect_arg(text: str) -> Effect:
    try:
        return parse_effect(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def cmd_simulate_truth(args: argparse.Namespace) -> dict[str, Any]:
    """``brakewear simulate``: the truth simulator when effects are given, else the nominal."""
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


def add_effect_args(sim: argparse.ArgumentParser) -> None:
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
        type=POSITIVE,
        default=60.0,
        help="mean time between events with --effect [s]",
    )
    sim.set_defaults(func=cmd_simulate_truth)
