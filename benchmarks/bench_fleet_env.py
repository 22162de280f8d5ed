"""Benchmark of BrakeWearFleet-v0 at its default size against the simulator in the same run.

Prints (targets in brackets):
- the bare simulator's events/s (8 whole pad lives, 8 per call, as bench_env.py);
- the fleet env's events/s under a fixed dispatch (half the fleet on the hot route, half on
  the mild one, every vehicle serviced at each window, 2 spares ordered a shift), its
  ratio to the simulator [>= 0.5x], and steps (shifts) per second;
- the same with the digital twin's RUL wrapper (FleetRULObservation, one fleet update a
  shift) [>= 0.1x]; the twin is fitted on 6 simulated training pads first (not timed);
- memory: the env's bytes per vehicle (tracemalloc peak while stepping, from before its
  reset) over 50 shifts and over the whole episode (729) [bounded: the same whatever the
  length];
- the hot/mild wear ratio per event from the atlas (fresh pad and last layer) and per
  shift as the env braked it.

Rates are CPU time of this process, best of ``--repeats`` interleaved rounds (as
bench_env.py). Run: ``.venv/bin/python benchmarks/bench_fleet_env.py [--shifts 200]
[--repeats 3] [--json out.json]``.
"""

from __future__ import annotations

import argparse
import time
import tracemalloc
from collections.abc import Callable
from pathlib import Path

import numpy as np

from brake_env.data.datasets import DatasetSpec, make_dataset
from brake_env.env.atlases import default_atlas
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.routes import HOT, MILD, route_mean
from brake_env.env.fleet.shop import SERVICE
from brake_env.env.fleet.wrappers import FleetRULObservation
from brake_env.model.simulator import simulate_runs
from brake_env.output import table, write_json
from brake_env.prognostics.registry import make_predictor


def simulator_rate(atlas, n_pads: int = 8) -> float:
    seeds = np.random.SeedSequence(1).spawn(n_pads)
    ks = np.random.default_rng(1).normal(2e-6, 2e-7, n_pads)
    t0 = time.process_time()
    events = sum(t.n_events for t in simulate_runs(atlas, ks, seeds))
    return events / (time.process_time() - t0)


def dispatch(env: BrakeWearFleetEnv) -> Callable[[int], np.ndarray]:
    """Half hot, half mild; everyone serviced at each window; 2 spares a shift."""
    c = env.config
    base = np.array([0] * (c.n_vehicles // 2) + [1] * (c.n_vehicles - c.n_vehicles // 2) + [2])

    def act(shift: int) -> np.ndarray:
        a = base.copy()
        if c.is_window(shift):
            a[:-1] = SERVICE
        return a

    return act


def run(env, shifts: int, seed: int = 0) -> tuple[int, int, float, dict[str, float]]:
    """(shifts, events, seconds, summed counts) of ``shifts`` shifts after a reset."""
    env.reset(seed=seed)
    act = dispatch(env.unwrapped)
    counts: dict[str, float] = {}
    events = 0
    t0 = time.process_time()
    for s in range(shifts):
        _, _, _, truncated, info = env.step(act(s))
        events += info["counts"]["events"]
        for k, v in info["counts"].items():
            counts[k] = counts.get(k, 0) + v
        if truncated:
            env.reset(seed=seed + s + 1)
    return shifts, events, time.process_time() - t0, counts


def memory_per_vehicle(shifts: int) -> float:
    env = BrakeWearFleetEnv()
    tracemalloc.start()
    run(env, shifts)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    return peak / env.config.n_vehicles


def wear_per_shift(env: BrakeWearFleetEnv, shifts: int = 60) -> float:
    """Hot over mild: mean volume lost per working shift on each route, from the env."""
    env.reset(seed=3)
    act = dispatch(env)
    lost = {0: [], 1: []}
    for s in range(shifts):
        before = env.truth()["volume_frac"]
        _, _, _, _, info = env.step(act(s))
        veh, after = info["vehicles"], env.truth()["volume_frac"]
        for r in (0, 1):
            ok = (veh["route"] == r) & ~veh["failed"] & ~veh["replaced"] & (veh["events"] > 0)
            ok &= after <= before  # no new pad
            lost[r].extend((before - after)[ok] / env.truth()["wear_coeff"][ok])
    return float(np.mean(lost[0]) / np.mean(lost[1]))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--shifts", type=int, default=200)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    atlas = default_atlas()
    env = BrakeWearFleetEnv(atlas=atlas)
    env.reset(seed=0)  # warm caches (route means, corner tables)
    # Best of ``repeats`` interleaved rounds, in CPU time (as bench_env.py), so that other
    # work on the machine moves the ratio less.
    sim, fleet = 0.0, 0.0
    for _ in range(args.repeats):
        sim = max(sim, simulator_rate(atlas))
        n, ev, dt, _ = run(env, args.shifts)
        fleet = max(fleet, ev / dt)
        if ev / dt == fleet:
            shifts_per_s = n / dt
    ds = make_dataset(atlas, DatasetSpec(n_train=6, n_id=0, n_ood_slow=0, n_ood_fast=0), seed=1)
    twin = make_predictor("twin", atlas).fit(ds.logs["train"])
    wrapped = FleetRULObservation(BrakeWearFleetEnv(atlas=atlas), twin)
    wn = max(args.shifts // 4, 20)
    _, wev, wdt, _ = run(wrapped, wn)
    long = env.config.episode_shifts - 1  # the whole episode, before its reset
    mem_short, mem_long = memory_per_vehicle(50), memory_per_vehicle(long)
    w_hot, w_mild = route_mean(atlas, HOT), route_mean(atlas, MILD)
    res = {
        "simulator_events_per_s": sim,
        "fleet_events_per_s": fleet,
        "fleet_ratio": fleet / sim,
        "fleet_shifts_per_s": shifts_per_s,
        "twin_events_per_s": wev / wdt,
        "twin_ratio": wev / wdt / sim,
        "bytes_per_vehicle_50_shifts": mem_short,
        f"bytes_per_vehicle_{long}_shifts": mem_long,
        "hot_over_mild_per_event_fresh": float(w_hot[0] / w_mild[0]),
        "hot_over_mild_per_event_last_layer": float(w_hot[-1] / w_mild[-1]),
        "hot_over_mild_per_shift_env": wear_per_shift(BrakeWearFleetEnv(atlas=atlas)),
    }
    rows = [[k, f"{v:,.3f}" if abs(v) < 100 else f"{v:,.0f}"] for k, v in res.items()]
    print(table([["figure", "value"], *rows]))
    print("targets: fleet_ratio >= 0.5, twin_ratio >= 0.1, bytes per vehicle bounded")
    if args.json:
        write_json(res, args.json)


if __name__ == "__main__":
    main()
