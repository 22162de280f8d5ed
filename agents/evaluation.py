"""Maintenance cost of a replacement policy on BrakeWear-v0, and its ratio to the oracle's.

One function evaluates any policy with SB3's ``predict`` (a rule or a trained agent) on any
(wrapped) BrakeWear-v0 env: one episode per seed, the same seeds for every policy, so every
policy meets the same pads under the same operating conditions.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, replace
from typing import Any

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

from agents.policies import Policy, RULThreshold
from brake_env.predictors import Oracle
from brake_env.wrappers import RULObservation

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class CostReport:
    """What a policy cost over a set of episodes.

    Attributes:
        name: Label of the policy.
        seeds: Episode seeds, one episode each.
        events: Braking events in all episodes.
        cost: Net cost (costs minus revenue) of all episodes [currency].
        cost_per_1000_events: ``1000 * cost / events``.
        episode_cost_per_1000_events: The same per episode, for intervals over seeds.
        failures: Brake failures.
        planned_replacements: Replacements the policy asked for.
        failures_per_100_pads: Failures per 100 pads taken off (planned or failed); pads
            still installed at truncation are not counted (their fate is unknown).
        mean_unused_life_frac: Mean share of its life a pad still had when taken off (0 for
            a failure) [-].
        retired_rul_events: Events of life left at each removal (0 for failures).
        ratio_to_oracle: ``cost`` over the oracle policy's cost on the same seeds, or None.
        seconds: Wall time.
    """

    name: str
    seeds: tuple[int, ...]
    events: int
    cost: float
    cost_per_1000_events: float
    episode_cost_per_1000_events: tuple[float, ...]
    failures: int
    planned_replacements: int
    failures_per_100_pads: float
    mean_unused_life_frac: float
    retired_rul_events: tuple[int, ...] = field(repr=False)
    ratio_to_oracle: float | None = None
    seconds: float = 0.0

    def interval(self, level: float = 0.95) -> tuple[float, float]:
        """Normal-approximation interval of the mean episode cost per 1000 events."""
        x = np.asarray(self.episode_cost_per_1000_events)
        if x.size < 2:
            return (float(x.mean()), float(x.mean()))
        from scipy.stats import t as student_t

        half = student_t.ppf(0.5 + level / 2, x.size - 1) * x.std(ddof=1) / np.sqrt(x.size)
        return (float(x.mean() - half), float(x.mean() + half))

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d.pop("retired_rul_events")
        d["cost_per_1000_events_ci95"] = self.interval()
        return d


def run_episodes(
    policy: Policy,
    env: gym.Env[Any, Any],
    seeds: Sequence[int],
    name: str = "policy",
    deterministic: bool = True,
) -> CostReport:
    """Run ``policy`` for one episode per seed on ``env`` and add up the costs."""
    if not seeds:
        raise ValueError("run_episodes: give at least one seed")
    t0 = time.perf_counter()
    events = failures = planned = 0
    cost = 0.0
    per_episode, retired = [], []
    for seed in seeds:
        obs, info = env.reset(seed=int(seed))
        ep_cost, ep_events = 0.0, len(info["events"])
        done = False
        while not done:
            action, _ = policy.predict(obs, deterministic=deterministic)
            obs, reward, terminated, truncated, info = env.step(action)
            done = terminated or truncated
            ep_cost -= float(reward)
            ep_events += len(info["events"])
            failures += info["failures"]
            planned += int(info["replaced"])
            retired.extend(info["retired"])
        cost += ep_cost
        events += ep_events
        per_episode.append(1000.0 * ep_cost / ep_events)
    left = np.array([r[0] for r in retired], dtype=np.int64)
    life = np.array([r[1] for r in retired], dtype=np.float64)
    n_pads = len(retired)
    return CostReport(
        name=name,
        seeds=tuple(int(s) for s in seeds),
        events=events,
        cost=cost,
        cost_per_1000_events=1000.0 * cost / events,
        episode_cost_per_1000_events=tuple(per_episode),
        failures=failures,
        planned_replacements=planned,
        failures_per_100_pads=100.0 * failures / n_pads if n_pads else float("nan"),
        mean_unused_life_frac=float((left / life).mean()) if n_pads else float("nan"),
        retired_rul_events=tuple(int(x) for x in left),
        seconds=time.perf_counter() - t0,
    )


def oracle_policy(env: gym.Env[Any, Any]) -> tuple[Policy, gym.Env[Any, Any]]:
    """The cheapest possible policy: the true RUL, replaced when the pad could not finish
    the next step. ``env`` is a bare BrakeWear-v0; it is wrapped with the oracle."""
    interval = env.unwrapped.config.decision_interval  # type: ignore[attr-defined]
    return RULThreshold(interval), RULObservation(env, Oracle())


def compare_policies(
    entries: Mapping[str, tuple[Policy, gym.Env[Any, Any]]],
    seeds: Sequence[int],
    make_env: Callable[[], gym.Env[Any, Any]] | None = None,
    progress: Callable[[str], object] | None = None,
) -> dict[str, CostReport]:
    """Evaluate every (policy, env) entry on the same seeds, plus the oracle, and give each
    its cost ratio to the oracle.

    Args:
        entries: Name -> (policy, the env it acts on, wrapped with its predictor).
        seeds: One episode per seed, the same for every entry.
        make_env: Builds a bare BrakeWear-v0 for the oracle; needed unless ``entries`` has
            an ``"oracle"`` entry.
        progress: Called with each name once it is done.
    """
    runs = dict(entries)
    if "oracle" not in runs:
        if make_env is None:
            raise ValueError("compare_policies: give make_env or an 'oracle' entry")
        runs["oracle"] = oracle_policy(make_env())
    reports = {}
    for name, (policy, env) in runs.items():
        reports[name] = run_episodes(policy, env, seeds, name)
        if progress:
            progress(name)
    base = reports["oracle"].cost
    return {
        name: _with_ratio(r, r.cost / base if base > 0 else float("nan"))
        for name, r in reports.items()
    }


def _with_ratio(report: CostReport, ratio: float) -> CostReport:
    return replace(report, ratio_to_oracle=ratio)


def summary_rows(reports: Mapping[str, CostReport]) -> list[list[str]]:
    """Rows of a terminal table, cheapest first."""
    rows = [["policy", "cost/1000 ev", "95% CI", "x oracle", "fail/100 pads", "unused life"]]
    for name, r in sorted(reports.items(), key=lambda kv: kv[1].cost):
        lo, hi = r.interval()
        rows.append(
            [
                name,
                f"{r.cost_per_1000_events:.3f}",
                f"{lo:.3f}-{hi:.3f}",
                "-" if r.ratio_to_oracle is None else f"{r.ratio_to_oracle:.3f}",
                f"{r.failures_per_100_pads:.1f}",
                f"{r.mean_unused_life_frac:.1%}",
            ]
        )
    return rows
