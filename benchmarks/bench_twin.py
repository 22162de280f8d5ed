"""Benchmark of the digital twin's update rate against the paper's literal procedure.

Prints, for one in-distribution pad of ``make_dataset(atlas, DatasetSpec(), seed=0)``:
- twin updates per second, updating its estimate at every event, in batches of 500 events
  (the environment's default decision interval), of 1 event, and the whole run at once
  [>= 20,000 events/s];
- the literal reference (``twin.reference.ReferenceTwin``: reverse inference, iterative K
  search and forward simulation in batches of 100 events) updating at every event, timed on
  a few events in the same run, and the ratio [>= 100x]; and the reference at the paper's
  cadence (an update every 1000 events) for context.

Run: ``.venv/bin/python benchmarks/bench_twin.py [--json out.json]``.
"""

from __future__ import annotations

import argparse
import platform
import time
from pathlib import Path

import numpy as np

from brake_env.data.datasets import DatasetSpec, make_dataset
from brake_env.model.atlas import cached_atlas
from brake_env.output import table, write_json
from brake_env.prognostics.protocol import EventBatch, Predictor, iter_runs
from twin import DigitalTwin
from twin.reference import ReferenceTwin


def events_per_s(pred: Predictor, ev: EventBatch, step: int, repeats: int) -> float:
    """Best of ``repeats`` passes over ``ev`` in batches of ``step`` events."""
    best = np.inf
    for _ in range(repeats):
        pred.reset()
        t0 = time.perf_counter()
        for i in range(0, len(ev), step):
            pred.update(ev[i : i + step])
        best = min(best, time.perf_counter() - t0)
    return len(ev) / best


def main() -> dict[str, float]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--events", type=int, default=60_000, help="events of the pad to replay")
    ap.add_argument("--ref-events", type=int, default=5, help="events for the reference")
    ap.add_argument("--json", default=None, help="also write the figures to this JSON file")
    args = ap.parse_args()

    atlas = cached_atlas()
    ds = make_dataset(atlas, DatasetSpec(n_train=10, n_id=1, n_ood_slow=0, n_ood_fast=0), 0)
    _, run = next(iter_runs(ds.logs["id"]))
    ev = run[: args.events]
    twin = DigitalTwin(atlas).fit(ds.logs["train"])
    b500 = events_per_s(twin, ev, 500, args.repeats)
    whole = events_per_s(twin, ev, len(ev), args.repeats)
    b1 = events_per_s(twin, ev[:3000], 1, args.repeats)

    # Each update searches K by simulating the pad down to the volume inferred from the
    # event and simulates on to failure. Timed at mid-life (near the start both searches
    # are short): the first half of the run goes in without updates, then every event.
    ref = ReferenceTwin(atlas, update_every=10**9, window=1)
    ref.k_prior = twin.calibration.k_median if twin.calibration else 2e-6
    n_ref, start = args.ref_events, len(run) // 2
    ref.reset()
    ref.update(run[:start])
    ref.update_every = 1
    t0 = time.perf_counter()
    ref.update(run[start : start + n_ref])
    ref_every = n_ref / (time.perf_counter() - t0)
    paper = ReferenceTwin(atlas, update_every=1000, window=1000)
    paper.k_prior = ref.k_prior
    t0 = time.perf_counter()
    paper.reset()
    paper.update(run[:20_000])
    ref_paper = 20_000 / (time.perf_counter() - t0)

    figures = {
        "twin_events_per_s_batch500": b500,
        "twin_events_per_s_batch1": b1,
        "twin_events_per_s_whole_run": whole,
        "reference_events_per_s_every_event": ref_every,
        "reference_events_per_s_every_1000": ref_paper,
        "ratio_batch500_vs_reference": b500 / ref_every,
        "ratio_batch1_vs_reference": b1 / ref_every,
        "grid_points": float(twin.config.n_grid),
    }
    print(f"machine: {platform.processor() or platform.machine()}, numpy {np.__version__}")
    rows = [
        ("twin, batches of 500", f"{b500:,.0f} ev/s", ">= 20,000 ev/s", f"{len(ev)} events"),
        ("twin, batches of 1", f"{b1:,.0f} ev/s", "", "3000 events"),
        ("twin, whole run at once", f"{whole:,.0f} ev/s", "", f"{len(ev)} events"),
        (
            "reference, update every event",
            f"{ref_every:.3g} ev/s",
            "",
            f"{n_ref} events at mid-life",
        ),
        ("reference, update every 1000", f"{ref_paper:,.0f} ev/s", "", "first 20000 events"),
        ("speed-up, twin b500 / reference", f"{b500 / ref_every:,.0f}x", ">= 100x", "same run"),
        ("speed-up, twin b1 / reference", f"{b1 / ref_every:,.0f}x", "", ""),
    ]
    print(table([["figure", "measured", "target", "note"], *(list(r) for r in rows)]))
    if args.json:
        write_json(figures, Path(args.json))
    return figures


if __name__ == "__main__":
    main()
