"""``brakewear demo``: the main job on small defaults. The atlas and the datasets, then the
stages of the ``brakewear.demo`` entry-point group in name order, then ``report.md``."""

from __future__ import annotations

import argparse
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from brake_env.cli.common import add_common_args, int_at_least, load_atlas, plugins
from brake_env.cli.demo_stages import run_stages
from brake_env.cli.simulate import (
    SimulateJob,
    add_simulation_args,
    dataset_spec,
    write_atlas,
    write_datasets,
)
from brake_env.cli.stage_clock import StageClock
from brake_env.output import write_text
from brake_env.runner import Runner, ray_available


@dataclass
class DemoContext:
    """What a demo stage gets: the demo's options and the files made before it.

    Attributes:
        args: The parsed ``brakewear demo`` options (seed, preset, cache_dir, quiet, ...).
        out: The demo's output directory; a stage writes under ``out / <its name>``.
        atlas_file: The atlas of the demo, as saved by the atlas stage.
        data_dir: The run-to-failure datasets ({train,id,ood}.parquet).
        results: Stage name -> what the stage returned, for later stages.
    """

    args: argparse.Namespace
    out: Path
    atlas_file: Path
    data_dir: Path
    results: dict[str, Any] = field(default_factory=dict)


DemoStage = Callable[[DemoContext], tuple[Any, str]]
# What the stages that compare policies share: the paper's three predictors between no
# prognostics and the oracle; and the default of --workers: the stages side by side in two
# processes (brake_env.cli.demo_stages), each stage's units in its own process.
DEMO_PREDICTORS = ("none", "physics", "data", "twin", "oracle")
DEMO_WORKERS = 2
# The demo's run-to-failure datasets (brakewear simulate's defaults: 10, 10, 5, 5).
DEMO_RUNS = {"n_train": 4, "n_id": 5, "n_ood_slow": 3, "n_ood_fast": 3}


def cmd_demo(args: argparse.Namespace) -> dict[str, Any]:
    out = Path(args.out)
    stages = plugins("brakewear.demo")
    n = 2 + len(stages)
    with StageClock() as clock:
        print(f"== 1/{n} atlas and calibration")
        atlas = load_atlas(args)
        other = "cold-start" if args.preset == "hot-duty" else "hot-duty"
        others = {other: load_atlas(args, other)}
        atlas_info = write_atlas(atlas, args.preset, others, out / "atlas")
        times = {"atlas": _lap(clock)}
        print(f"\n== 2/{n} run-to-failure datasets")
        job = SimulateJob(dataset_spec(args), args.seed, args.format, out / "data", args.quiet)
        summary = write_datasets(atlas, job)
        times["datasets"] = _lap(clock)
        ctx = DemoContext(args, out, out / "atlas" / "atlas.npz", out / "data")
        workers = getattr(args, "workers", DEMO_WORKERS)
        runs = run_stages(ctx, stages, workers, 3, n)
        times.update({r.name: (r.wall, r.cpu) for r in runs})
        times["total"] = (clock.wall(), clock.cpu())
    beside = min(workers, len(runs)) if workers >= 2 and len(runs) > 1 else 0
    report = _demo_report(atlas_info, summary, times, processes=beside)
    sections = [r.section for r in runs]
    write_text(report + "".join("\n" + s for s in sections), out / "report.md")
    summary["stage_seconds"] = {k: {"wall": w, "cpu": c} for k, (w, c) in times.items()}
    print(f"\nreport: {out / 'report.md'}")
    return summary


def _lap(clock: StageClock) -> tuple[float, float]:
    wall, cpu = clock.lap()
    print(f"(stage: {wall:.1f} s wall, {cpu:.1f} s CPU)")
    return wall, cpu


def _times_table(times: dict[str, tuple[float, float]], processes: int) -> str:
    rows = "\n".join(f"| {k} | {w:.1f} | {c:.1f} |" for k, (w, c) in times.items())
    beside = (
        f"\n\nThe stages after the datasets ran side by side in {processes} processes: their"
        " wall times overlap, so they add up to more than the total's."
        if processes > 1
        else ""
    )
    return f"""| stage | wall s | CPU s |
|---|---|---|
{rows}

CPU is user + system time of this process and every process it started (a local Ray's
workers included), read from /proc each second.{beside}"""


def _demo_report(
    atlas: dict[str, Any],
    s: dict[str, Any],
    times: dict[str, tuple[float, float]],
    processes: int,
) -> str:
    life = s["life_events"]
    rising = atlas["mean_temp_strictly_rising_everywhere"]
    rows = "\n".join(
        f"| {k} | {v['runs']} | {v['mean']:.0f} | {v['std']:.0f}"
        f" | {v['min']:.0f} | {v['max']:.0f} |"
        for k, v in life.items()
    )
    return f"""# BrakeWear demo report

Seed {s["seed"]}; total {times["total"][0]:.1f} s wall, {times["total"][1]:.1f} s CPU.
Atlas `{atlas["hash"][:16]}`.

## Stage times

{_times_table(times, processes)}

## Calibration

- end of pad life at **{atlas["failure_volume_frac"]:.2%}** volume ({atlas["failure_mode"]}: the
  most severe event cannot stop, or the wear-out limit)
- mean wear per event, last layer / fresh pad: **{atlas["wear_per_event_ratio_end_fresh"]:.3f}**
  (atlas, uniform operating conditions); **{s["wear_per_event_ratio_end_fresh_runs"]["mean"]:.3f}**
  measured over the simulated runs
- mean event temperature {atlas["mean_temp_c_fresh"]:.0f} C fresh, {atlas["mean_temp_c_end"]:.0f} C
  at end of life; strictly rising at every grid condition: {rising}

![calibration](atlas/calibration.png)

## Run-to-failure datasets (paper 2.1.6)

| split | runs | life mean | std | min | max |
|---|---|---|---|---|---|
{rows}

{s["events_total"]} events simulated in {s["timing_s"]["simulate"]:.2f} s.

![volume](data/figures/volume_trajectories.png)
"""


def demo_runner(args: argparse.Namespace) -> Runner:
    """Where a stage's units run: a local Ray of ``--workers`` CPUs, else this process
    (side by side, :mod:`brake_env.cli.demo_stages` gives each stage ``workers=0``)."""
    workers = getattr(args, "workers", DEMO_WORKERS)
    return Runner(workers) if workers and ray_available() else Runner(0)


def register(sub: argparse._SubParsersAction[Any]) -> None:
    """Add ``demo`` to the ``brakewear`` parser."""
    fmt = argparse.ArgumentDefaultsHelpFormatter
    d = sub.add_parser(
        "demo", formatter_class=fmt, help="the main job on small defaults: atlas, datasets, report"
    )
    add_common_args(d, "out/demo")
    d.add_argument("--rebuild", action="store_true", help="ignore the atlas cache")
    d.add_argument(
        "--workers",
        type=int_at_least(0),
        default=DEMO_WORKERS,
        help="processes the stages after the datasets run in side by side, each stage's units"
        " in its own process (0: one stage after the other, all in this process; 1: the"
        " same, the comparison's and the fleet's units on a local Ray of 1 CPU)",
    )
    add_simulation_args(d, "parquet")
    # Smaller datasets than `simulate`'s: every later stage fits its predictors on
    # max(3, --n-train) pads, and the evaluation's time is mostly the twin over the test runs.
    d.set_defaults(**DEMO_RUNS)
    d.set_defaults(func=cmd_demo)
