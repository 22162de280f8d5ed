"""BrakeWear-v0 as an RL researcher meets it: the digital twin's RUL estimate appended to the
observation, and a rule that replaces the pads when that estimate gets short.

Run: ``python examples/rl_rule_policy.py`` (~15 s on 2 cores). Fits the twin (paper 2.4) on a
few simulated run-to-failure pads, wraps ``gym.make("BrakeWear-v0")`` in ``RULObservation``,
drives it with ``RULThreshold`` (SB3's ``predict`` signature, so a trained agent would slot
in the same way) and prints the maintenance cost, the failures and the planned replacements,
beside the oracle's cost on the same pads.
Fast-wearing pads (K ten times the paper's) keep it short; ``brakewear compare`` does the
full study (docs/results/single-pad.md).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym

import brake_env  # noqa: F401  (registers BrakeWear-v0)
from agents.policies.rules import RULThreshold
from brake_env.data.datasets import DatasetSpec, make_dataset
from brake_env.env.atlases import default_atlas
from brake_env.env.wrappers import RULObservation
from brake_env.model.regime import WearRegime
from brake_env.prognostics.protocol import Oracle
from brake_env.prognostics.registry import make_predictor


def main(
    episodes: int = 2,
    k_mean: float = 1e-5,
    episode_events: int = 60_000,
    decision_interval: int = 500,
    threshold_steps: float = 2.0,
    seed: int = 0,
) -> dict[str, Any]:
    """Run the twin-threshold policy and the oracle on the same episodes; return their costs.

    Args:
        episodes: Episodes of each policy (seeds ``seed + 1``, ``seed + 2``, ...).
        k_mean: Mean wear coefficient of new pads (a pad lasts ~2.4e4 events at 1e-5) [-].
        episode_events: Braking events per episode [events].
        decision_interval: Braking events per step [events].
        threshold_steps: Replace when the twin's RUL estimate is below this many steps.
        seed: Seeds the twin's training pads and the episodes.
    """
    wear = WearRegime(k_mean, k_mean / 10)
    atlas = default_atlas()  # built once (~1 s), then loaded from the cache

    # The digital twin, fitted on three simulated run-to-failure pads.
    spec = DatasetSpec(n_train=3, n_id=0, n_ood_slow=0, n_ood_fast=0, wear=wear)
    twin = make_predictor("twin", atlas, seed).fit(make_dataset(atlas, spec, seed).logs["train"])

    def make_env() -> gym.Env[Any, Any]:
        # Half the new pads wear out of distribution (-/+ 6 sigma): the twin must notice.
        return gym.make(
            "BrakeWear-v0",
            atlas=atlas,
            regime="mixed",
            **wear.env_kwargs(),
            decision_interval=decision_interval,
            episode_events=episode_events,
        )

    seeds = [seed + 1 + i for i in range(episodes)]
    policy = RULThreshold(threshold_steps * decision_interval)
    result = run(RULObservation(make_env(), twin), policy, seeds)
    # The oracle knows the true RUL and replaces when the pad could not finish the next step.
    oracle = run(RULObservation(make_env(), Oracle()), RULThreshold(decision_interval), seeds)
    result["oracle_cost_per_1000_events"] = oracle["cost_per_1000_events"]
    print(
        f"twin RUL < {policy.threshold_events:g} events: {result['cost_per_1000_events']:.1f}"
        f" per 1000 braking events ({result['failures']} failures,"
        f" {result['planned_replacements']} planned replacements); the oracle:"
        f" {oracle['cost_per_1000_events']:.1f}"
    )
    return result


def run(env: gym.Env[Any, Any], policy: RULThreshold, seeds: list[int]) -> dict[str, Any]:
    """One episode per seed: the cost per 1000 braking events, failures, replacements."""
    cost, events, failures, planned = 0.0, 0, 0, 0
    for seed in seeds:
        obs, info = env.reset(seed=seed)
        events += len(info["events"])
        done = False
        while not done:
            action, _ = policy.predict(obs, deterministic=True)
            obs, reward, terminated, truncated, info = env.step(action)
            cost -= float(reward)  # the reward is minus the step's maintenance cost
            events += len(info["events"])
            failures += info["failures"]
            planned += int(info["replaced"])
            done = terminated or truncated
    return {
        "episodes": len(seeds),
        "events": events,
        "cost_per_1000_events": 1000.0 * cost / events,
        "failures": failures,
        "planned_replacements": planned,
    }


if __name__ == "__main__":
    main()
