"""brakewear: brake-pad wear simulation and predictive-maintenance testbed."""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from importlib.metadata import entry_points
from pathlib import Path
from typing import Any

from tqdm import tqdm

from brake_env.atlas import Atlas, AtlasSpec, cached_atlas
from brake_env.datasets import SPLITS, DatasetSpec, make_dataset, write_dataset
from brake_env.params import BrakeModel
from brake_env.summary import atlas_summary, dataset_summary

FORMATS = ("parquet", "csv")


def _formats(text: str) -> tuple[str, ...]:
    out = tuple(f.strip() for f in text.split(",") if f.strip())
    bad = [f for f in out if f not in FORMATS]
    if bad or not out:
        raise argparse.ArgumentTypeError(f"--format takes parquet, csv or both, got {text!r}")
    return out


def int_at_least(lo: int) -> Callable[[str], int]:
    """An argparse ``type`` for integers >= ``lo``, with one clear error otherwise."""

    def parse(text: str) -> int:
        n = int(text)
        if n < lo:
            raise argparse.ArgumentTypeError(f"expected an integer >= {lo}, got {text}")
        return n

    parse.__name__ = f"int>={lo}"  # argparse names the type in its error message
    return parse


def write_json(obj: Any, path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(obj, indent=2, sort_keys=False) + "\n")
    return path


def load_atlas(args: argparse.Namespace, preset: str | None = None) -> Atlas:
    """The atlas file given by --atlas (its own parameters), else the preset's cached atlas."""
    if getattr(args, "atlas", None) and preset is None:
        return Atlas.load(args.atlas)
    spec = AtlasSpec(model=BrakeModel.preset(preset or args.preset))
    with tqdm(desc="atlas layers", unit="layer", disable=args.quiet, delay=0.5) as bar:
        return cached_atlas(spec, args.cache_dir, getattr(args, "rebuild", False), bar.update)


def table(rows: list[list[str]]) -> str:
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    lines = ["  ".join(c.rjust(w) for c, w in zip(r, widths, strict=True)) for r in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


# ---------------------------------------------------------------------- atlas
def cmd_atlas(args: argparse.Namespace) -> dict[str, Any]:
    from brake_env.plots import plot_calibration

    out = Path(args.out)
    atlas = load_atlas(args)
    atlas.save(out / "atlas.npz")
    info = atlas_summary(atlas)
    info["build_seconds"] = atlas.build_seconds
    info["preset"] = args.preset
    write_json(info, out / "atlas.json")
    other = "cold-start" if args.preset == "hot-duty" else "hot-duty"
    # The calibration figure sets the other preset beside this one (DESIGN 3's contrast).
    plot_calibration(atlas, out / "calibration.png", compare={other: load_atlas(args, other)})
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
                    args.preset,
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


# ---------------------------------------------------------------------- simulate
def dataset_spec(args: argparse.Namespace) -> DatasetSpec:
    """The DatasetSpec of the ``--n-*``, ``--k-*``, ``--interpolate-layers`` and
    ``--route-block-events`` options."""
    return DatasetSpec(
        n_train=args.n_train,
        n_id=args.n_id,
        n_ood_slow=args.n_ood_slow,
        n_ood_fast=args.n_ood_fast,
        k_mean=args.k_mean,
        k_std=args.k_std,
        interpolate_layers=args.interpolate_layers,
        route_block_events=args.route_block_events,
    )


def cmd_simulate(args: argparse.Namespace) -> dict[str, Any]:
    from brake_env.plots import plot_trace, plot_volume_trajectories

    out = Path(args.out)
    atlas = load_atlas(args)
    spec = dataset_spec(args)
    with tqdm(total=atlas.n_layers, desc="simulate", unit="layer", disable=args.quiet) as bar:
        ds = make_dataset(atlas, spec, args.seed, progress=bar.update)
    t0 = time.perf_counter()
    n_files = len(args.format) * len(SPLITS)
    with tqdm(total=n_files, desc="write logs", unit="file", disable=args.quiet) as bar:
        write_dataset(ds, out, args.format, progress=lambda _: bar.update())
    summary = dataset_summary(ds, atlas, args.seed)
    summary["timing_s"]["write"] = time.perf_counter() - t0
    summary["files"] = sorted(f"{s}.{f}" for s in SPLITS for f in args.format)
    write_json(summary, out / "summary.json")
    if ds.runs:
        plot_volume_trajectories(ds.runs, out / "figures" / "volume_trajectories.png")
        split, run_id, _ = next((r for r in ds.runs if r[1].startswith("ood-fast")), ds.runs[0])
        plot_trace(ds.logs[split], run_id, out / "figures" / f"trace_{run_id}.png")
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


# ---------------------------------------------------------------------- demo
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


# A demo stage returns (result for later stages, Markdown section for report.md).
DemoStage = Callable[[DemoContext], tuple[Any, str]]


def _entry_points(group: str) -> list[Any]:
    """Installed plug-ins of ``group``, ordered by name (demo stages are named "NN-what")."""
    return sorted(entry_points(group=group), key=lambda ep: ep.name)


def cmd_demo(args: argparse.Namespace) -> dict[str, Any]:
    out = Path(args.out)
    t0 = time.perf_counter()
    stages = _entry_points("brakewear.demo")
    n = 2 + len(stages)
    print(f"== 1/{n} atlas and calibration")
    atlas_info = cmd_atlas(argparse.Namespace(**{**vars(args), "out": str(out / "atlas")}))
    print(f"\n== 2/{n} run-to-failure datasets")
    data_args = {**vars(args), "out": str(out / "data"), "atlas": None}
    summary = cmd_simulate(argparse.Namespace(**data_args))
    ctx = DemoContext(args, out, out / "atlas" / "atlas.npz", out / "data")
    sections = []
    for i, ep in enumerate(stages, start=3):
        name = ep.name.split("-", 1)[-1]
        print(f"\n== {i}/{n} {name}")
        stage: DemoStage = ep.load()
        ctx.results[name], section = stage(ctx)
        sections.append(section)
    report = _demo_report(atlas_info, summary, out, time.perf_counter() - t0)
    (out / "report.md").write_text(report + "".join("\n" + s for s in sections))
    print(f"\nreport: {out / 'report.md'}")
    return summary


def _demo_report(atlas: dict[str, Any], s: dict[str, Any], out: Path, seconds: float) -> str:
    life = s["life_events"]
    rising = atlas["mean_temp_strictly_rising_everywhere"]
    rows = "\n".join(
        f"| {k} | {v['runs']} | {v['mean']:.0f} | {v['std']:.0f}"
        f" | {v['min']:.0f} | {v['max']:.0f} |"
        for k, v in life.items()
    )
    return f"""# BrakeWear demo report

Seed {s["seed"]}; total {seconds:.1f} s. Atlas `{atlas["hash"][:16]}`.

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


def add_common_args(sp: argparse.ArgumentParser, out_default: str) -> None:
    """The options every subcommand takes (plug-in commands use them too)."""
    sp.add_argument("--out", default=out_default, help="output directory")
    sp.add_argument("--seed", type=int, default=0, help="random seed (same seed, same files)")
    sp.add_argument(
        "--preset",
        default="hot-duty",
        choices=["hot-duty", "cold-start"],
        help="brake calibration (docs/calibration.md)",
    )
    sp.add_argument(
        "--cache-dir",
        default=None,
        help="atlas cache (default $BRAKEWEAR_CACHE_DIR or ~/.cache/brakewear)",
    )
    sp.add_argument("--quiet", action="store_true", help="no progress bars")


# ---------------------------------------------------------------------- parser
def build_parser() -> argparse.ArgumentParser:
    fmt = argparse.ArgumentDefaultsHelpFormatter
    p = argparse.ArgumentParser(prog="brakewear", description=__doc__, formatter_class=fmt)
    sub = p.add_subparsers(dest="command", required=True)

    def sim_args(sp: argparse.ArgumentParser, fmt_default: str) -> None:
        sp.add_argument(
            "--format",
            type=_formats,
            default=_formats(fmt_default),
            help="event-log formats: parquet, csv or parquet,csv",
        )
        for name, n in (("train", 10), ("id", 10), ("ood-slow", 5), ("ood-fast", 5)):
            sp.add_argument(f"--n-{name}", type=int_at_least(0), default=n, help=f"{name} runs")
        sp.add_argument("--k-mean", type=float, default=2e-6, help="mean Archard coefficient")
        sp.add_argument("--k-std", type=float, default=2e-7, help="std of the coefficient")
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
    sim_args(s, "parquet,csv")
    s.set_defaults(func=cmd_simulate)

    d = sub.add_parser(
        "demo", formatter_class=fmt, help="the main job on small defaults: atlas, datasets, report"
    )
    add_common_args(d, "out/demo")
    d.add_argument("--rebuild", action="store_true", help="ignore the atlas cache")
    sim_args(d, "parquet")
    d.set_defaults(func=cmd_demo)

    # Commands of the downstream packages (twin, baselines, agents, sim2real) register
    # themselves as plug-ins, so brake_env never imports them (DESIGN 2: imports flow one way).
    for ep in _entry_points("brakewear.commands"):
        ep.load()(sub)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        args.func(args)
    except (ValueError, FileNotFoundError) as e:
        print(f"brakewear {args.command}: error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
