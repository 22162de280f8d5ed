"""Benchmark of BrakeWear-v0 against the bare simulator in the same run (targets in brackets).

Prints, next to the bare simulator's events/s measured in the same process:
- steps/s at the default interval (500) under three policies: keep only (a replacement only
  at each failure), random replacements with probability 0.01 and 0.5 per step, each with
  ``truth=True`` (the default: the exact RUL, each pad simulated ahead to failure when its
  truth is first read, :mod:`brake_env.env.lazy_truth`; nothing here reads it) and
  ``truth=False`` (events simulated only as the env serves them):
  - replace probability 0.5 with the default keyword arguments (truth=True), and with
    truth=False [>= 1,000 steps/s each];
  - replace probability 0.01 / keep only, truth=False [>= 0.5x] (before the truth was lazy,
    each replacement with truth simulated a whole life ahead: 0.45x, and 36 steps/s at
    probability 0.5);
  - keep only, truth=True, events/s / the simulator's [no lower than before pads were
    streamed: 0.61x, this script on commit 1de0289 without its truth=False rows].
- steps/s at interval 1, bare and with the oracle RUL wrapper [>= 20,000 steps/s bare].
- what an RL client sees, at the default keyword arguments (truth=True) and random actions
  (replace with probability 0.5): ``gym.make("BrakeWear-v0")`` steps/s, SB3's
  ``make_vec_env("BrakeWear-v0", n_envs=1)`` steps/s (its ``DummyVecEnv`` deep-copies every
  step's infos, and its Monitor and rgb_array render mode come along) and their ratio
  [>= 0.5x; 31 steps/s, 0.02x, while copying an info simulated its lazy truth], and SB3 PPO
  training steps/s on ``make_vec_env`` (4,096 steps, ``n_steps=512``, CPU, one torch
  thread, best of two interleaved rounds), with the default env [>= 500 steps/s; 28
  before] and with ``truth=False`` (the same, now that copies do not read the truth: what
  is left is PPO's own forward passes and updates, and the env's steps).

The simulator baseline is measured two ways: one pad per call (one pad's whole life, what
the env did at each installation before pads were streamed) and eight pads per call (the
batched use); the ratios are taken against the faster of the two.

Run: ``make bench`` or ``.venv/bin/python benchmarks/bench_env.py [--json out.json]``
(``--rl-only``: only the RL-client figures).
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from pathlib import Path

import gymnasium as gym
import numpy as np

import brake_env  # noqa: F401  (registers BrakeWear-v0)
from brake_env.env.atlases import default_atlas
from brake_env.env.wrappers import RULObservation
from brake_env.model.simulator import simulate_runs
from brake_env.output import table, write_json
from brake_env.prognostics.protocol import Oracle


def simulator_job(atlas, pads_per_call: int, n_pads: int = 8) -> Callable[[], tuple[int, int]]:
    """Simulate ``n_pads`` whole lives, ``pads_per_call`` per call: (0 steps, events)."""
    seeds = np.random.SeedSequence(1).spawn(n_pads)
    ks = np.random.default_rng(1).normal(2e-6, 2e-7, n_pads)

    def run() -> tuple[int, int]:
        events = 0
        for i in range(0, n_pads, pads_per_call):
            sl = slice(i, i + pads_per_call)
            events += sum(t.n_events for t in simulate_runs(atlas, ks[sl], seeds[sl]))
        return 0, events

    return run


def env_job(
    interval: int, steps: int, p_replace: float = 0.0, **kw
) -> Callable[[], tuple[int, int]]:
    """``steps`` steps that replace with probability ``p_replace`` (the same actions each
    time), reset included: (steps, events). ``kw``: ``oracle`` wraps the env in the
    oracle's RUL observation; the rest goes to ``gym.make``."""
    oracle = kw.pop("oracle", False)
    episode = max(steps * interval + 1, 2)
    env = gym.make("BrakeWear-v0", decision_interval=interval, episode_events=episode, **kw)
    if oracle:
        env = RULObservation(env, Oracle())
    actions = (np.random.default_rng(1).random(steps) < p_replace).astype(int).tolist()

    def run() -> tuple[int, int]:
        _, info = env.reset(seed=0)
        events = len(info["events"])
        for a in actions:
            _, _, _, _, info = env.step(a)
            events += len(info["events"])
        return steps, events

    return run


def client_jobs(steps: int = 2000) -> dict[str, Callable[[], tuple[int, int]]]:
    """The raw env and SB3's ``make_vec_env`` of it, at the default keyword arguments, each
    stepped ``steps`` times with the same random actions (replace with probability 0.5),
    reset when truncated: (steps, events)."""
    from stable_baselines3.common.env_util import make_vec_env

    actions = (np.random.default_rng(1).random(steps) < 0.5).astype(np.int64)
    env = gym.make("BrakeWear-v0")
    vec = make_vec_env("BrakeWear-v0", n_envs=1, seed=0)

    def raw() -> tuple[int, int]:
        _, info = env.reset(seed=0)
        events = len(info["events"])
        for a in actions.tolist():
            _, _, terminated, truncated, info = env.step(a)
            events += len(info["events"])
            if terminated or truncated:
                env.reset()
        return steps, events

    def vectorised() -> tuple[int, int]:
        vec.seed(0)
        vec.reset()
        events = 0
        for a in actions:
            _, _, _, infos = vec.step(a[None])
            events += len(infos[0]["events"])
        return steps, events

    return {"client_raw": raw, "client_make_vec_env": vectorised}


def ppo_rate(total: int = 4096, **env_kwargs) -> float:
    """SB3 PPO training steps/s on ``make_vec_env("BrakeWear-v0", n_envs=1)``: ``total``
    steps, ``n_steps=512``, CPU, one torch thread; CPU time of the ``learn`` call."""
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.env_util import make_vec_env

    torch.set_num_threads(1)
    vec = make_vec_env("BrakeWear-v0", n_envs=1, seed=0, env_kwargs=env_kwargs)
    model = PPO("MlpPolicy", vec, n_steps=512, batch_size=64, device="cpu", seed=0)
    t0 = time.process_time()
    model.learn(total_timesteps=total)
    return total / (time.process_time() - t0)


def client_figures(repeats: int) -> tuple[dict[str, float], list[list[str]]]:
    """The RL-client figures and their table rows."""
    r = rates(client_jobs(), repeats)
    raw, vec = r["client_raw"][0], r["client_make_vec_env"][0]
    # Best of two rounds, interleaved: the first learn() also pays torch's warm-up.
    ppo, ppo_no_truth = 0.0, 0.0
    for _ in range(2):
        ppo, ppo_no_truth = max(ppo, ppo_rate()), max(ppo_no_truth, ppo_rate(truth=False))
    fig = {
        "client_raw_env_steps_per_s": raw,
        "client_make_vec_env_steps_per_s": vec,
        "client_make_vec_env_ratio_to_raw": vec / raw,
        "client_ppo_train_steps_per_s": ppo,
        "client_ppo_train_steps_per_s_truth_false": ppo_no_truth,
    }
    rows = [
        ["RL client: gym.make, replace p=0.5", f"{raw:,.0f} steps/s", "", "", "", "baseline"],
        [
            "RL client: make_vec_env(n_envs=1), p=0.5",
            f"{vec:,.0f} steps/s",
            "",
            "",
            f"{vec / raw:.2f}x raw",
            ">= 0.5x raw",
        ],
        ["RL client: SB3 PPO learn (defaults)", f"{ppo:,.0f} steps/s", "", "", "", ">= 500"],
        ["RL client: SB3 PPO learn, truth=False", f"{ppo_no_truth:,.0f} steps/s", "", "", "", ""],
    ]
    return fig, rows


def rates(
    jobs: dict[str, Callable[[], tuple[int, int]]], repeats: int
) -> dict[str, tuple[float, float]]:
    """(steps/s, events/s) of each job, from its least CPU time over ``repeats`` rounds.

    CPU time of this process, not wall time, and the jobs interleaved round by round, so
    that other work on the machine moves the ratios less (everything here is one thread).
    """
    best = dict.fromkeys(jobs, np.inf)
    counts = {}
    for _ in range(repeats):
        for name, job in jobs.items():
            t0 = time.process_time()
            counts[name] = job()
            best[name] = min(best[name], time.process_time() - t0)
    return {k: (counts[k][0] / best[k], counts[k][1] / best[k]) for k in jobs}


# (replace probability, steps, target) at the default interval. truth=True is the default:
# the truth is simulated only when read (brake_env.env.lazy_truth), and nothing here reads
# it, so p = 0.5 with the default keyword arguments must run as fast as without truth.
SCENARIOS = {
    True: (
        (0.0, 2000, ">= 0.61x simulator (before)"),
        (0.01, 2000, ""),
        (0.5, 2000, ">= 1,000 steps/s (defaults)"),
    ),
    False: (
        (0.0, 2000, ""),
        (0.01, 2000, ">= 0.5x keep-only"),
        (0.5, 2000, ">= 1,000 steps/s"),
    ),
}


def main() -> dict[str, float]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--json", default=None, help="also write the figures to this JSON file")
    ap.add_argument("--rl-only", action="store_true", help="only the RL-client figures")
    args = ap.parse_args()
    header = ["figure", "steps/s", "events/s", "x simulator", "x keep-only", "target"]
    if args.rl_only:
        fig, rows = client_figures(args.repeats)
        print(table([header, *rows]))
        if args.json:
            write_json(fig, Path(args.json))
        return fig
    atlas = default_atlas()
    jobs = {"sim_one": simulator_job(atlas, 1), "sim_batch": simulator_job(atlas, 8)}
    for truth, scenarios in SCENARIOS.items():
        for p, steps, _ in scenarios:
            jobs[f"interval_500_p{p:g}_truth_{truth}"] = env_job(500, steps, p, truth=truth)
    # Interval 1: 100k steps (~one pad life): the cost of a step itself.
    for oracle in (False, True):
        jobs[f"interval_1_{'oracle' if oracle else 'bare'}"] = env_job(1, 100_000, oracle=oracle)
    r = rates(jobs, args.repeats)
    sim = max(r["sim_one"][1], r["sim_batch"][1])
    fig: dict[str, float] = {
        "simulator_events_per_s_one_pad_per_call": r["sim_one"][1],
        "simulator_events_per_s_8_pads_per_call": r["sim_batch"][1],
    }
    rows = [
        ["simulator, 1 pad per call", "", f"{r['sim_one'][1]:.3g} ev/s", "", "", "baseline"],
        ["simulator, 8 pads per call", "", f"{r['sim_batch'][1]:.3g} ev/s", "", "", "baseline"],
    ]
    for truth, scenarios in SCENARIOS.items():
        keep = r[f"interval_500_p0_truth_{truth}"][0]
        for p, _, target in scenarios:
            tag = f"interval_500_p{p:g}_truth_{truth}"
            sps, eps = r[tag]
            fig[f"{tag}_steps_per_s"], fig[f"{tag}_events_per_s"] = sps, eps
            fig[f"{tag}_events_ratio_to_simulator"] = eps / sim
            fig[f"{tag}_steps_ratio_to_keep_only"] = sps / keep
            label = "keep only" if p == 0 else f"replace p={p:g}"
            rows.append(
                [
                    f"env, interval 500, {label}, truth={truth}",
                    f"{sps:,.0f} steps/s",
                    f"{eps:.3g} ev/s",
                    f"{eps / sim:.2f}x",
                    f"{sps / keep:.2f}x",
                    target,
                ]
            )
    for oracle in (False, True):
        tag = f"interval_1_{'oracle' if oracle else 'bare'}"
        sps, eps = r[tag]
        fig[f"{tag}_steps_per_s"], fig[f"{tag}_events_per_s"] = sps, eps
        rows.append(
            [
                f"env, interval 1, {'oracle wrapper' if oracle else 'bare'}",
                f"{sps:,.0f} steps/s",
                f"{eps:.3g} ev/s",
                f"{eps / sim:.2f}x",
                "",
                "" if oracle else ">= 20,000 steps/s",
            ]
        )
    client_fig, client_rows = client_figures(args.repeats)
    fig.update(client_fig)
    rows.extend(client_rows)
    print(table([header, *rows]))
    if args.json:
        write_json(fig, Path(args.json))
    return fig


if __name__ == "__main__":
    main()
