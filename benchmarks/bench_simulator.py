"""Benchmark of the atlas build and the coupled wear simulator (targets in brackets).

Prints:
- default atlas build time, best of N [< 2 s on 2 cores];
- simulated events/s of the vectorised simulator on the paper's 30-run dataset, and of the
  literal per-event loop on the same atlas in the same run, and their ratio [>= 1e6 /s, >= 100x];
- time to build the 30-run dataset (simulation, and simulation plus noisy event logs) [< 3 s];
- peak memory of the 30-run simulation (tracemalloc: numpy allocations) and of the process.

Run: ``make bench`` or ``.venv/bin/python benchmarks/bench_simulator.py [--json out.json]``.
"""

from __future__ import annotations

import argparse
import platform
import resource
import time
import tracemalloc
from pathlib import Path

import numpy as np

from brake_env.data.datasets import DatasetSpec, make_dataset, seeded_plan
from brake_env.model.atlas import Atlas, AtlasSpec
from brake_env.model.simulator import simulate_runs
from brake_env.model.simulator_reference import simulate_run_reference
from brake_env.output import table, write_json


def timed(n: int, fn):
    """(first-call seconds, best seconds of n calls, result). The first call pays the page
    faults of fresh memory; later calls reuse freed memory, so both are reported."""
    times, out = [], None
    for _ in range(n):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return times[0], min(times), out


def main() -> dict[str, float]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--json", default=None, help="also write the figures to this JSON file")
    args = ap.parse_args()

    build_first, build_s, atlas = timed(args.repeats, lambda: Atlas.build(AtlasSpec()))

    spec = DatasetSpec()
    plan, per_run = seeded_plan(spec, seed=0)  # the runs of `brakewear simulate --seed 0`
    ks = [p.wear_coeff for p in plan]
    seeds = [cond for cond, _ in per_run]
    sim_first, sim_s, trajs = timed(args.repeats, lambda: simulate_runs(atlas, ks, seeds))
    n_events = sum(t.n_events for t in trajs)

    # The literal per-event loop on the dataset's first run, and the vectorised simulator on
    # that same run alone: like for like, without the gain of batching 30 runs.
    _, ref_s, ref = timed(1, lambda: simulate_run_reference(atlas, ks[0], seeds[0]))
    _, one_s, one = timed(args.repeats, lambda: simulate_runs(atlas, [ks[0]], [seeds[0]]))
    assert one[0].n_events == ref.n_events == trajs[0].n_events

    ds_first, ds_s, ds = timed(args.repeats, lambda: make_dataset(atlas, spec, seed=0))

    tracemalloc.start()
    simulate_runs(atlas, ks, seeds)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    trace_bytes = n_events * 8 * 7  # seven float64 columns per event is the output itself

    figures = {
        "atlas_build_s": build_s,
        "atlas_build_first_s": build_first,
        "atlas_layers": atlas.n_layers,
        "atlas_grid_events": int(atlas.fields["temp_mean_c"].size),
        "sim_30_runs_events": n_events,
        "sim_30_runs_s": sim_s,
        "sim_30_runs_first_s": sim_first,
        "sim_events_per_s": n_events / sim_s,
        "reference_events": ref.n_events,
        "reference_events_per_s": ref.n_events / ref_s,
        "vectorised_same_run_events_per_s": one[0].n_events / one_s,
        "speedup_30_runs_vs_reference": (n_events / sim_s) / (ref.n_events / ref_s),
        "speedup_same_run_vs_reference": (one[0].n_events / one_s) / (ref.n_events / ref_s),
        "dataset_30_runs_with_logs_s": ds_s,
        "dataset_30_runs_with_logs_first_s": ds_first,
        "peak_traced_mb_30_runs": peak / 1e6,
        "output_mb_30_runs": trace_bytes / 1e6,
        "process_max_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e3,
    }
    del ds
    print(f"machine: {platform.processor() or platform.machine()}, numpy {np.__version__}")
    rows = [
        (
            "atlas build (default grid)",
            f"{build_s:.2f} s",
            "< 2 s",
            f"first call {build_first:.2f} s; {atlas.n_layers} layers x "
            f"{atlas.fields['temp_mean_c'][0].size} conditions",
        ),
        (
            "simulator, 30 runs",
            f"{figures['sim_events_per_s']:.3g} ev/s",
            ">= 1e6 ev/s",
            f"{n_events} events in {sim_s:.2f} s (first call {sim_first:.2f} s:"
            f" {n_events / sim_first:.3g} ev/s)",
        ),
        (
            "per-event reference loop",
            f"{figures['reference_events_per_s']:.3g} ev/s",
            "",
            f"run {plan[0].run_id}: {ref.n_events} events in {ref_s:.1f} s",
        ),
        (
            "speed-up, 30 runs / reference",
            f"{figures['speedup_30_runs_vs_reference']:.0f}x",
            ">= 100x",
            f"first call {(n_events / sim_first) / (ref.n_events / ref_s):.0f}x;"
            f" same run alone {figures['speedup_same_run_vs_reference']:.0f}x",
        ),
        ("30-run dataset (sim only)", f"{sim_s:.2f} s", "< 3 s", f"first call {sim_first:.2f} s"),
        ("30-run dataset (sim + noisy logs)", f"{ds_s:.2f} s", "", f"first call {ds_first:.2f} s"),
        (
            "peak memory, 30-run simulation",
            f"{figures['peak_traced_mb_30_runs']:.0f} MB",
            "",
            f"output itself {figures['output_mb_30_runs']:.0f} MB",
        ),
        ("process max RSS", f"{figures['process_max_rss_mb']:.0f} MB", "", "whole benchmark"),
    ]
    print(table([["figure", "measured", "target", "note"], *(list(r) for r in rows)]))
    if args.json:
        write_json(figures, Path(args.json))
    return figures


if __name__ == "__main__":
    main()
