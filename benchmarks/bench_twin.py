"""Benchmark of the digital twin against the simulator in the same run (targets in brackets).

Prints events/s, each next to the simulator's measured in the same process:

- the simulator (the baseline): whole pad lives, the faster of one pad and eight pads per
  call (as ``bench_env.py``);
- the twin's fleet (``DigitalTwin.fleet``): the whole lives of ``--pads`` in-distribution
  pads, fed in calls of 500 events per pad (the env's default decision interval) with an
  estimate at each pad's latest event (a decision point) [>= 0.1x the simulator];
- the fleet with an estimate at every event (``predict_runs``, what ``brakewear evaluate``
  does);
- the single-pad twin (``DigitalTwin.update``, an estimate at every event) over one whole
  life in batches of 500 events, and over 3000 events in batches of 1;
- the paper's literal procedure (``twin.reference.ReferenceTwin``) updating at every event,
  a few events at mid-life, and the speed-up of the single-pad twin over it.

Rates come from the least CPU time of this process over ``--repeats`` rounds, the jobs
interleaved round by round, so that other work on the machine moves the ratios less.

Run: ``.venv/bin/python benchmarks/bench_twin.py [--pads 8] [--json out.json]``.
"""

from __future__ import annotations

import argparse
import platform
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from brake_env.data.datasets import DatasetSpec, make_dataset
from brake_env.model.atlas import Atlas, cached_atlas
from brake_env.model.simulator import simulate_runs
from brake_env.output import table, write_json
from brake_env.prognostics.fleet import concat_events, predict_runs
from brake_env.prognostics.protocol import EventBatch, iter_runs
from twin import DigitalTwin
from twin.reference import ReferenceTwin

DECISION = 500  # events per pad per fleet call: the env's default decision interval


def simulator_job(atlas: Atlas, pads_per_call: int, n_pads: int = 8) -> Callable[[], int]:
    """Simulate ``n_pads`` whole lives, ``pads_per_call`` per call; returns the events."""
    seeds = np.random.SeedSequence(1).spawn(n_pads)
    ks = np.random.default_rng(1).normal(2e-6, 2e-7, n_pads)

    def run() -> int:
        events = 0
        for i in range(0, n_pads, pads_per_call):
            sl = slice(i, i + pads_per_call)
            events += sum(t.n_events for t in simulate_runs(atlas, ks[sl], seeds[sl]))
        return events

    return run


def fleet_job(twin: DigitalTwin, runs: list[EventBatch]) -> Callable[[], int]:
    """All ``runs`` through one fleet: each call takes the next ``DECISION`` events of every
    pad still running and asks for the estimate at each pad's latest event."""
    calls = []
    for start in range(0, max(len(r) for r in runs), DECISION):
        parts = [r[start : start + DECISION] for r in runs if len(r) > start]
        slots = [i for i, r in enumerate(runs) if len(r) > start]
        pads = np.repeat(np.array(slots, dtype=np.intp), [len(p) for p in parts])
        calls.append((pads, concat_events(parts)))

    def run() -> int:
        fleet = twin.fleet(len(runs))
        for pads, events in calls:
            fleet.update(pads, events)
        return sum(len(r) for r in runs)

    return run


def single_job(twin: DigitalTwin, ev: EventBatch, step: int) -> Callable[[], int]:
    def run() -> int:
        twin.reset()
        for i in range(0, len(ev), step):
            twin.update(ev[i : i + step])
        return len(ev)

    return run


def rates(jobs: dict[str, Callable[[], int]], repeats: int) -> dict[str, float]:
    """Events per CPU second of each job, the least CPU time over ``repeats`` rounds."""
    best = dict.fromkeys(jobs, np.inf)
    events = {}
    for _ in range(repeats):
        for name, job in jobs.items():
            t0 = time.process_time()
            events[name] = job()
            best[name] = min(best[name], time.process_time() - t0)
    return {k: events[k] / best[k] for k in jobs}


def reference_rate(atlas: Atlas, twin: DigitalTwin, run: EventBatch, n_ref: int) -> float:
    """The literal reference updating at every event, timed on ``n_ref`` events at mid-life
    (near the start its searches are short): the first half goes in without updates."""
    ref = ReferenceTwin(atlas, update_every=10**9, window=1)
    ref.k_prior = twin.calibration.k_median if twin.calibration else 2e-6
    start = len(run) // 2
    ref.reset()
    ref.update(run[:start])
    ref.update_every = 1
    t0 = time.process_time()
    ref.update(run[start : start + n_ref])
    return n_ref / (time.process_time() - t0)


def main() -> dict[str, float]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--pads", type=int, default=8, help="in-distribution pads in the fleet")
    ap.add_argument("--ref-events", type=int, default=5, help="events for the reference")
    ap.add_argument("--json", default=None, help="also write the figures to this JSON file")
    args = ap.parse_args()

    atlas = cached_atlas()
    spec = DatasetSpec(n_train=10, n_id=args.pads, n_ood_slow=0, n_ood_fast=0)
    ds = make_dataset(atlas, spec, 0)
    runs = [ev for _, ev in iter_runs(ds.logs["id"])]
    twin = DigitalTwin(atlas).fit(ds.logs["train"])
    n_fleet = sum(len(r) for r in runs)
    jobs = {
        "sim_one": simulator_job(atlas, 1),
        "sim_batch": simulator_job(atlas, 8),
        "fleet_decisions": fleet_job(twin, runs),
        "fleet_every_event": lambda: sum(len(e) for e in predict_runs(twin, runs)),
        "single_batch500": single_job(twin, runs[0], DECISION),
        "single_batch1": single_job(twin, runs[0][:3000], 1),
    }
    r = rates(jobs, args.repeats)
    sim = max(r["sim_one"], r["sim_batch"])
    ref = reference_rate(atlas, twin, runs[0], args.ref_events)
    fig = {f"{k}_events_per_s": v for k, v in r.items()}
    fig.update(
        {f"{k}_ratio_to_simulator": v / sim for k, v in r.items() if not k.startswith("sim")}
    )
    fig["reference_events_per_s_every_event"] = ref
    fig["single_batch500_speedup_over_reference"] = r["single_batch500"] / ref
    fig["grid_points"] = float(twin.config.n_grid)

    print(f"machine: {platform.processor() or platform.machine()}, numpy {np.__version__}")
    rows = [["figure", "events/s", "x simulator", "target", "note"]]
    notes = {
        "sim_one": ("simulator, 1 pad per call", "", "baseline: 8 whole lives"),
        "sim_batch": ("simulator, 8 pads per call", "", "baseline"),
        "fleet_decisions": (
            "twin fleet, estimate per decision",
            ">= 0.1x",
            f"{args.pads} pads, {n_fleet:,} events, calls of {DECISION}/pad",
        ),
        "fleet_every_event": ("twin fleet, estimate at every event", "", "as brakewear evaluate"),
        "single_batch500": ("twin update, batches of 500", "", f"{len(runs[0]):,} events"),
        "single_batch1": ("twin update, batches of 1", "", "3000 events"),
    }
    for k, (label, target, note) in notes.items():
        ratio = "" if k.startswith("sim") else f"{r[k] / sim:.3f}x"
        rows.append([label, f"{r[k]:,.0f}", ratio, target, note])
    rows.append(
        [
            "reference, update every event",
            f"{ref:.3g}",
            "",
            "",
            f"{args.ref_events} events at mid-life; twin b500 {r['single_batch500'] / ref:,.0f}x",
        ]
    )
    print(table(rows))
    if args.json:
        write_json(fig, Path(args.json))
    return fig


if __name__ == "__main__":
    main()
