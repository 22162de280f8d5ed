"""Maintenance cost of a replacement policy on BrakeWear-v0 episodes, and its ratio to the
oracle's.

One function evaluates any policy with SB3's ``predict`` (a rule or a trained agent) on any
(wrapped) BrakeWear-v0 env: one episode per seed, the same seeds for every policy, so every
policy meets the same pads under the same operating conditions. Intervals are bootstrap
intervals over episodes of the ratio of total cost to total events (paired with the
oracle's episodes for the ratio to it), never a t-interval of per-episode ratios; with a
few episodes they are wide, as they should be. The cost study (``brakewear compare``)
evaluates pad by pad instead (:mod:`agents.study.outcomes`), over thousands of pads.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Hashable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, replace
from typing import Any, TypeVar

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

from agents.policies.rules import Policy, RULThreshold
from agents.study import costs
from brake_env.env.config import CostWeights
from brake_env.env.pads import RetiredPad
from brake_env.env.wrappers import RULObservation
from brake_env.prognostics.protocol import Oracle

F64 = NDArray[np.float64]
K = TypeVar("K", bound=Hashable)  # what a set of reports is keyed by: a name or a PolicyId


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
        failures_per_100_pads_by_regime: The same for ``id``, ``ood-slow``, ``ood-fast``
            and all ``ood`` pads (NaN where no such pad was taken off).
        mean_unused_life_frac: Mean share of its life a pad still had when taken off (0 for
            a failure) [-].
        retired: Each pad taken off, in order (life left, life, regime; life left 0 for a
            failure).
        episode_failures, episode_planned: Failures and planned replacements per episode,
            so the cost under other weights follows without running again.
        ratio_to_oracle: ``cost`` over the oracle policy's cost on the same seeds, or None.
        ratio_to_oracle_ci95: Its paired bootstrap 95% interval over episodes, or None.
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
    failures_per_100_pads_by_regime: dict[str, float]
    mean_unused_life_frac: float
    retired: tuple[RetiredPad, ...] = field(repr=False)
    episode_failures: tuple[int, ...] = field(repr=False)
    episode_planned: tuple[int, ...] = field(repr=False)
    episode_events: tuple[int, ...] = field(repr=False)
    ratio_to_oracle: float | None = None
    ratio_to_oracle_ci95: tuple[float, float] | None = None
    seconds: float = 0.0

    def interval(self, level: float = 0.95) -> tuple[float, float]:
        """Bootstrap interval over episodes of the cost per 1000 events (total cost over
        total events)."""
        events = np.asarray(self.episode_events, dtype=np.float64)
        cost = np.asarray(self.episode_cost_per_1000_events) * events / 1000.0
        return episode_interval([cost, events], level)

    def cost_with(self, weights: CostWeights) -> float:
        """Cost per 1000 events under other weights (no revenue): same decisions, same pads."""
        c = weights.planned_replacement * sum(self.episode_planned)
        return 1000.0 * (c + weights.failure * sum(self.episode_failures)) / self.events

    def episode_costs_with(self, weights: CostWeights) -> NDArray[np.float64]:
        p, f = np.asarray(self.episode_planned), np.asarray(self.episode_failures)
        cost = weights.planned_replacement * p + weights.failure * f
        return 1000.0 * cost / np.asarray(self.episode_events)

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        for k in ("retired", "episode_events"):
            d.pop(k)
        d["cost_per_1000_events_ci95"] = self.interval()
        return d


def episode_interval(
    sums: Sequence[NDArray[np.float64]], level: float = 0.95, seed: int = 0
) -> tuple[float, float]:
    """Percentile bootstrap interval over episodes (paired) of ``1000 * sum(a) / sum(b)``,
    or of that over ``1000 * sum(c) / sum(d)`` for four per-episode arrays ``a, b, c, d``
    (a cost ratio to the oracle). A point where every resample agrees or there is one
    episode; it always holds the estimate and never leaves the range of the resamples."""
    from scipy.stats import bootstrap

    x = [np.asarray(v, dtype=np.float64) for v in sums]

    def stat(*v: NDArray[np.float64], axis: int = -1) -> NDArray[np.float64]:
        r = 1000.0 * v[0].sum(axis) / v[1].sum(axis)
        return r / (1000.0 * v[2].sum(axis) / v[3].sum(axis)) if len(v) == 4 else r

    point = float(stat(*x))
    if len(x[0]) < 2:
        return (point, point)
    rng = np.random.default_rng(seed)
    res = bootstrap(x, stat, paired=True, vectorized=True, method="percentile",
                    confidence_level=level, n_resamples=2000, rng=rng)  # fmt: skip
    lo, hi = float(res.confidence_interval.low), float(res.confidence_interval.high)
    if not (np.isfinite(lo) and np.isfinite(hi)):
        return (point, point)
    return (min(lo, point), max(hi, point))


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
    cost = 0.0
    per_episode, ep_fail, ep_plan, ep_events = [], [], [], []
    retired: list[RetiredPad] = []
    for seed in seeds:
        obs, info = env.reset(seed=int(seed))
        c, n, f, p = 0.0, len(info["events"]), 0, 0
        done = False
        while not done:
            action, _ = policy.predict(obs, deterministic=deterministic)
            obs, reward, terminated, truncated, info = env.step(action)
            done = terminated or truncated
            c -= float(reward)
            n += len(info["events"])
            f += info["failures"]
            p += int(info["replaced"])
            retired.extend(info["retired"])
        cost += c
        per_episode.append(1000.0 * c / n)
        ep_fail.append(f)
        ep_plan.append(p)
        ep_events.append(n)
    return _report(
        name,
        retired,
        seeds=tuple(int(s) for s in seeds),
        cost=cost,
        per_episode=tuple(per_episode),
        ep_fail=tuple(ep_fail),
        ep_plan=tuple(ep_plan),
        ep_events=tuple(ep_events),
        seconds=time.perf_counter() - t0,
    )


def _report(
    name: str,
    retired: Sequence[RetiredPad],
    *,
    seeds: tuple[int, ...],
    cost: float,
    per_episode: tuple[float, ...],
    ep_fail: tuple[int, ...],
    ep_plan: tuple[int, ...],
    ep_events: tuple[int, ...],
    seconds: float,
) -> CostReport:
    left = np.array([r.life_left for r in retired], dtype=np.int64)
    life = np.array([r.life for r in retired], dtype=np.int64)
    label = np.array([r.regime for r in retired], dtype=object)
    rates = costs.failure_rates(left == 0, label, None)  # pooled over the pads taken off
    by_regime = {k: rates[k] for k in costs.RATE_GROUPS}
    unused = costs.unused_life(left, life, label, None) if retired else float("nan")
    return CostReport(
        name=name,
        seeds=seeds,
        events=sum(ep_events),
        cost=cost,
        cost_per_1000_events=1000.0 * cost / sum(ep_events),
        episode_cost_per_1000_events=per_episode,
        failures=sum(ep_fail),
        planned_replacements=sum(ep_plan),
        failures_per_100_pads=100.0 * sum(ep_fail) / len(retired) if retired else float("nan"),
        failures_per_100_pads_by_regime=by_regime,
        mean_unused_life_frac=unused,
        retired=tuple(retired),
        episode_failures=ep_fail,
        episode_planned=ep_plan,
        episode_events=ep_events,
        seconds=seconds,
    )


def merge_reports(reports: Sequence[CostReport]) -> CostReport:
    """One report over the episodes of several (the same policy on other seeds)."""
    if not reports:
        raise ValueError("merge_reports: nothing to merge")
    retired = [pad for r in reports for pad in r.retired]
    return _report(
        reports[0].name,
        retired,
        seeds=tuple(s for r in reports for s in r.seeds),
        cost=sum(r.cost for r in reports),
        per_episode=tuple(x for r in reports for x in r.episode_cost_per_1000_events),
        ep_fail=tuple(x for r in reports for x in r.episode_failures),
        ep_plan=tuple(x for r in reports for x in r.episode_planned),
        ep_events=tuple(x for r in reports for x in r.episode_events),
        seconds=sum(r.seconds for r in reports),
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
    return with_oracle_ratios(reports, reports["oracle"])


def with_oracle_ratios(reports: Mapping[K, CostReport], oracle: CostReport) -> dict[K, CostReport]:
    """Each report with its cost ratio to ``oracle`` (which must have run the same seeds)
    and the ratio's paired bootstrap interval over episodes."""

    def sums(r: CostReport) -> list[NDArray[np.float64]]:
        events = np.asarray(r.episode_events, dtype=np.float64)
        return [np.asarray(r.episode_cost_per_1000_events) * events / 1000.0, events]

    out = {}
    for name, r in reports.items():
        if r.seeds != oracle.seeds:
            raise ValueError(f"{name} ran seeds {r.seeds}, the oracle {oracle.seeds}")
        if oracle.cost <= 0:
            out[name] = replace(r, ratio_to_oracle=float("nan"))
            continue
        ci = episode_interval([*sums(r), *sums(oracle)])
        out[name] = replace(r, ratio_to_oracle=r.cost / oracle.cost, ratio_to_oracle_ci95=ci)
    return out


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
