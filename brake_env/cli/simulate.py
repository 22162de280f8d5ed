"""``brakewear atlas`` and ``brakewear simulate``: the atlas and the run-to-failure datasets."""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from tqdm import tqdm

from brake_env.cli.common import (
    add_common_args,
    add_wear_args,
    int_at_least,
    load_atlas,
    wear_regime,
)
from brake_env.data.datasets import SPLITS, DatasetSpec, make_dataset, write_dataset
from brake_env.data.summary import atlas_summary, dataset_summary
from brake_env.model.atlas import Atlas
from brake_env.output import table, write_json

FORMATS = ("parquet", "csv")


def _formats(text: str) -> tuple[str, ...]:
    out = tuple(f.strip() for f in text.split(",") if f.strip())
    bad = [f for f in out if f not in FORMATS]
    if bad or not out:
        raise argparse.ArgumentTypeError(f"--format takes parquet, csv or both, got {text!r}")
    return out


def add_simulation_args(sp: argparse.ArgumentParser, fmt_default: str) -> None:
    """Options of the datasets: formats, run counts, K distribution, duty cycle."""
    sp.add_argument(
        "--format",
        type=_formats,
        default=_formats(fmt_default),
        help="event-log formats: parquet, csv or parquet,csv",
    )
    for name, n in (("train", 10), ("id", 10), ("ood-slow", 5), ("ood-fast", 5)):
        sp.add_argument(f"--n-{name}", type=int_at_least(0), default=n, help=f"{name} runs")
    add_wear_args(sp)
    sp.add_argument(
        "--interpolate-layers",
        action="store_true",
        help="blend adjacent atlas layers by volume (paper footnote 1)",
    )
    sp.add_argument(
        "--route-block-events",
        type=int_at_least(0),
        default=0,
        help="0: independent operating conditions; N: haul-road and pit blocks of N events",
    )


def cmd_atlas(args: argparse.Namespace) -> dict[str, Any]:
    other = "cold-start" if args.preset == "hot-duty" else "hot-duty"
    return write_atlas(
        load_atlas(args), args.preset, {other: load_atlas(args, other)}, Path(args.out)
    )


def write_atlas(atlas: Atlas, preset: str, others: dict[str, Atlas], out: Path) -> dict[str, Any]:
    """``atlas.npz``, ``atlas.json`` and the calibration figure, which sets the ``others``
    presets beside this one (docs/model.md's contrast); the summary printed."""
    from brake_env.data.plots import plot_calibration

    atlas.save(out / "atlas.npz")
    info = atlas_summary(atlas)
    info["build_seconds"] = atlas.build_seconds
    info["preset"] = preset
    write_json(info, out / "atlas.json")
    plot_calibration(atlas, out / "calibration.png", compare=others)
    print(
        table(
            [
                [
                    "preset",
                    "layers",
                    "failure volume",
                    "wear end/fresh",
                    "T fresh",
                    "T end",
                    "build s",
                ],
                [
                    preset,
                    str(atlas.n_layers),
                    f"{atlas.failure_volume:.2%} ({atlas.failure_mode})",
                    f"{info['wear_per_event_ratio_end_fresh']:.3f}",
                    f"{info['mean_temp_c_fresh']:.0f} C",
                    f"{info['mean_temp_c_end']:.0f} C",
                    f"{atlas.build_seconds:.2f}",
                ],
            ]
        )
    )
    print(f"wrote {out / 'atlas.npz'}, atlas.json, calibration.png")
    return info


def dataset_spec(args: argparse.Namespace) -> DatasetSpec:
    """The DatasetSpec of the ``--n-*``, ``--k-*``, ``--interpolate-layers`` and
    ``--route-block-events`` options (the spec's defaults for those a command lacks)."""
    default = DatasetSpec()
    return DatasetSpec(
        n_train=args.n_train,
        n_id=args.n_id,
        n_ood_slow=args.n_ood_slow,
        n_ood_fast=args.n_ood_fast,
        wear=wear_regime(args),
        interpolate_layers=getattr(args, "interpolate_layers", default.interpolate_layers),
        route_block_events=getattr(args, "route_block_events", default.route_block_events),
    )


def cmd_simulate(args: argparse.Namespace) -> dict[str, Any]:
    job = SimulateJob(dataset_spec(args), args.seed, args.format, Path(args.out), args.quiet)
    return write_datasets(load_atlas(args), job)


@dataclass(frozen=True)
class SimulateJob:
    """What ``brakewear simulate`` writes: the datasets of ``spec`` from ``seed``, as event
    logs in ``formats`` under ``out``."""

    spec: DatasetSpec
    seed: int
    formats: tuple[str, ...]
    out: Path
    quiet: bool = False


def write_datasets(atlas: Atlas, job: SimulateJob) -> dict[str, Any]:
    """Simulate and write the datasets, ``summary.json`` and figures; the summary printed."""
    from brake_env.data.plots import plot_trace, plot_volume_trajectories

    out = job.out
    with tqdm(total=atlas.n_layers, desc="simulate", unit="layer", disable=job.quiet) as bar:
        ds = make_dataset(atlas, job.spec, job.seed, progress=bar.update)
    t0 = time.perf_counter()
    n_files = len(job.formats) * len(SPLITS)
    with tqdm(total=n_files, desc="write logs", unit="file", disable=job.quiet) as bar:
        write_dataset(ds, out, job.formats, progress=lambda _: bar.update())
    summary = dataset_summary(ds, atlas, job.seed)
    summary["timing_s"]["write"] = time.perf_counter() - t0
    summary["files"] = sorted(f"{s}.{f}" for s in SPLITS for f in job.formats)
    write_json(summary, out / "summary.json")
    if ds.runs:
        plot_volume_trajectories(ds.runs, out / "figures" / "volume_trajectories.png")
        r = next((r for r in ds.runs if r.run_id.startswith("ood-fast")), ds.runs[0])
        plot_trace(ds.logs[r.split], r.run_id, out / "figures" / f"trace_{r.run_id}.png")
    rows = [["split", "runs", "life mean", "life std", "life min", "life max"]]
    for split, life in summary["life_events"].items():
        rows.append(
            [
                split,
                str(life["runs"]),
                f"{life['mean']:.0f}",
                f"{life['std']:.0f}",
                f"{life['min']:.0f}",
                f"{life['max']:.0f}",
            ]
        )
    print(table(rows))
    print(
        f"events: {summary['events_total']}  simulate: {ds.simulate_seconds:.2f} s"
        f"  ({summary['events_total'] / max(ds.simulate_seconds, 1e-9):.3g} events/s)"
        f"  wear end/fresh: {summary['wear_per_event_ratio_end_fresh_runs']['mean']:.3f}"
        f"  failure volume: {summary['failure_volume_frac']['mean']:.2%}"
    )
    print(f"wrote {out}/{{{','.join(summary['files'])}}}, summary.json, figures/")
    return summary


def register(sub: argparse._SubParsersAction[Any]) -> None:
    """Add ``atlas`` and ``simulate`` to the ``brakewear`` parser."""
    fmt = argparse.ArgumentDefaultsHelpFormatter
    a = sub.add_parser(
        "atlas",
        formatter_class=fmt,
        help="build (or load from cache) the atlas; calibration figure beside the other preset",
    )
    add_common_args(a, "out/atlas")
    a.add_argument("--rebuild", action="store_true", help="ignore the cache")
    a.set_defaults(func=cmd_atlas)

    s = sub.add_parser(
        "simulate",
        formatter_class=fmt,
        help="simulate the train / ID / OOD run-to-failure datasets",
    )
    add_common_args(s, "out/data")
    s.add_argument("--atlas", default=None, help="atlas .npz to use instead of the cache")
    add_simulation_args(s, "parquet,csv")
    s.set_defaults(func=cmd_simulate)
