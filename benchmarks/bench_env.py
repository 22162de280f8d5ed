"""Benchmark of BrakeWear-v0 against the bare simulator in the same run (targets in brackets).

Prints env steps/s and braking events/s for ``decision_interval`` 1 and the default (500),
bare (``gym.make``, with Gymnasium's default wrappers) and with the oracle RUL wrapper, next
to the bare simulator's events/s measured in the same process:
- steps/s at interval 1 [>= 20,000];
- events/s through the env at the default interval / the bare simulator's [>= 0.5].

The simulator baseline is measured two ways: one pad per call (what the env does at each
installation) and eight pads per call (the batched use); the ratio is taken against the
faster of the two.

Run: ``make bench`` or ``.venv/bin/python benchmarks/bench_env.py [--json out.json]``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import gymnasium as gym
import numpy as np

import brake_env  # noqa: F401  (registers BrakeWear-v0)
from brake_env.env.brake_wear import default_atlas
from brake_env.env.wrappers import RULObservation
from brake_env.model.simulator import simulate_runs
from brake_env.output import table, write_json
from brake_env.prognostics.protocol import Oracle


def best_of(n: int, fn):
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return min(times), out


def simulator_events_per_s(atlas, pads_per_call: int, n_pads: int, repeats: int) -> float:
    seeds = np.random.SeedSequence(1).spawn(n_pads)
    ks = np.random.default_rng(1).normal(2e-6, 2e-7, n_pads)

    def run() -> int:
        events = 0
        for i in range(0, n_pads, pads_per_call):
            sl = slice(i, i + pads_per_call)
            events += sum(t.n_events for t in simulate_runs(atlas, ks[sl], seeds[sl]))
        return events

    s, events = best_of(repeats, run)
    return events / s


def env_rate(interval: int, wrapped: bool, steps: int, repeats: int) -> tuple[float, float]:
    """(steps/s, events/s) of ``steps`` keep-actions, resets included, best of ``repeats``."""
    episode = max(steps * interval + 1, 2)
    env = gym.make("BrakeWear-v0", decision_interval=interval, episode_events=episode)
    if wrapped:
        env = RULObservation(env, Oracle())

    def run() -> int:
        _, info = env.reset(seed=0)
        events = len(info["events"])
        for _ in range(steps):
            _, _, _, _, info = env.step(0)
            events += len(info["events"])
        return events

    s, events = best_of(repeats, run)
    return steps / s, events / s


def main() -> dict[str, float]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--json", default=None, help="also write the figures to this JSON file")
    args = ap.parse_args()
    atlas = default_atlas()
    sim_one = simulator_events_per_s(atlas, 1, 8, args.repeats)
    sim_batch = simulator_events_per_s(atlas, 8, 8, args.repeats)
    sim = max(sim_one, sim_batch)
    fig: dict[str, float] = {
        "simulator_events_per_s_one_pad_per_call": sim_one,
        "simulator_events_per_s_8_pads_per_call": sim_batch,
    }
    rows = []
    # Interval 1: 100k steps (~one pad life); default: 2000 steps (~8 pad lives).
    for interval, steps in ((1, 100_000), (500, 2000)):
        for wrapped in (False, True):
            sps, eps = env_rate(interval, wrapped, steps, args.repeats)
            tag = f"interval_{interval}_{'oracle' if wrapped else 'bare'}"
            fig[f"{tag}_steps_per_s"], fig[f"{tag}_events_per_s"] = sps, eps
            fig[f"{tag}_events_ratio_to_simulator"] = eps / sim
            target = ""
            if interval == 1 and not wrapped:
                target = ">= 20,000 steps/s"
            elif interval == 500 and not wrapped:
                target = ">= 0.5x simulator"
            rows.append(
                (
                    f"env, interval {interval}, {'oracle wrapper' if wrapped else 'bare'}",
                    f"{sps:,.0f} steps/s",
                    f"{eps:.3g} ev/s",
                    f"{eps / sim:.2f}x",
                    target,
                )
            )
    rows.insert(0, ("simulator, 1 pad per call", "", f"{sim_one:.3g} ev/s", "", "baseline"))
    rows.insert(1, ("simulator, 8 pads per call", "", f"{sim_batch:.3g} ev/s", "", "baseline"))
    header = ("figure", "steps/s", "events/s", "x simulator", "target")
    print(table([list(r) for r in (header, *rows)]))
    if args.json:
        write_json(fig, Path(args.json))
    return fig


if __name__ == "__main__":
    main()
