"""What a policy costs on BrakeWearFleet-v0, per vehicle-shift, on common random numbers; and
paired bootstrap intervals of the difference and the ratio of two policies' costs.

Every policy is run on the same episode seeds (an episode seed fixes the pads, their K, the
streams and the breakdowns), so two policies' costs on one seed are a pair. Intervals
resample episodes, pairs kept together (``scipy.stats.bootstrap(paired=True)``, BCa, the
percentile method when BCa is degenerate). A ratio is a ratio of means, never a t-interval.

A learned policy is a distribution over training seeds: :func:`seeds_interval` gives the
interquartile mean (IQM) of the seeds' mean costs, as rliable reports it, and a two-level
bootstrap that resamples the seeds and, paired with a baseline's, the episodes.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray
from scipy.stats import DegenerateDataWarning, bootstrap, trim_mean

from agents.fleet.policies.view import respects
from agents.fleet.settings import OBJECTIVES, Objective
from brake_env.env.fleet.config import COST_TERMS
from brake_env.env.fleet.episode_cost import FITS, headline, life_value

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class EpisodeCost:
    """One episode of one policy.

    Attributes:
        seed: The episode's seed.
        vehicles: Fleet size.
        shifts: Shifts run.
        terms: Total of each cost term (keys of ``info["costs"]``).
        counts: Total of each count of ``info["counts"]`` (fits, failures, ...).
        pad_price: The env's price of a pad (to price pads when fitted).
        life_value: The pads' life left at the episode's end, priced as the bound's
            terminal credit (:func:`life_value`): what the policy leaves to the shifts after.
    """

    seed: int
    vehicles: int
    shifts: int
    terms: dict[str, float] = field(default_factory=dict)
    counts: dict[str, float] = field(default_factory=dict)
    pad_price: float = 0.0
    life_value: float = 0.0

    @property
    def total(self) -> float:
        """The env's bill: the sum of its cost terms (pads priced when ordered)."""
        return float(sum(self.terms.values()))

    @property
    def fits(self) -> float:
        return float(sum(self.counts.get(k, 0) for k in FITS))

    @property
    def billed(self) -> float:
        """The env's bill per vehicle-shift."""
        return self.total / (self.vehicles * self.shifts)

    @property
    def per_vehicle_shift(self) -> float:
        """The headline figure: cost per vehicle-shift with pads priced when fitted (so
        that neither the free initial stock nor the spares left at the end, which the bill
        prices when ordered, move it), order and holding costs included."""
        return headline(self.terms, self.counts, self.vehicles, self.shifts, self.pad_price)

    @property
    def net(self) -> float:
        """:attr:`per_vehicle_shift` less the value of the pad life left at the end: an
        episode's end is arbitrary (the mine goes on), and a policy that runs its pads down
        before it leaves the next shifts the bill. The Lagrangian bound is on this figure."""
        return self.per_vehicle_shift - self.life_value / (self.vehicles * self.shifts)

    @property
    def model_terms(self) -> float:
        """:attr:`per_vehicle_shift` without order and holding costs: the terms of the
        perfect-information reference's model (which idealises spares away)."""
        rest = self.terms["order"] + self.terms["holding"]
        return self.per_vehicle_shift - rest / (self.vehicles * self.shifts)


def term_means(eps: Sequence[EpisodeCost]) -> dict[str, float]:
    """Mean cost per vehicle-shift of each term over episodes, pads priced when fitted (as
    :attr:`EpisodeCost.per_vehicle_shift`; the terms add up to its mean)."""
    out = {}
    for t in eps[0].terms:
        each = [(e.pad_price * e.fits if t == "pad" else e.terms[t]) / e.vehicles for e in eps]
        out[t] = float(np.mean([x / e.shifts for x, e in zip(each, eps, strict=True)]))
    return out


def run_episode(env: Any, policy: Any, seed: int, check_masks: bool = False) -> EpisodeCost:
    """Run ``policy`` (SB3's ``predict``) for one whole episode of ``env`` from ``seed``.
    With ``check_masks`` every action is checked against the env's mask (ValueError)."""
    base = env.unwrapped
    n = base.config.n_vehicles
    obs, _ = env.reset(seed=seed)
    terms = dict.fromkeys(COST_TERMS, 0.0)
    counts: dict[str, float] = {}
    shifts, done = 0, False
    while not done:
        action, _ = policy.predict(obs, deterministic=True)
        if check_masks and not respects(action, base.action_masks(), n):
            raise ValueError(f"{policy!r} broke the mask at shift {shifts}: {action}")
        obs, _, terminated, truncated, info = env.step(action)
        for k, v in info["costs"].items():
            terms[k] += v
        for k, v in info["counts"].items():
            counts[k] = counts.get(k, 0) + v
        shifts, done = shifts + 1, terminated or truncated
    return EpisodeCost(seed, n, shifts, terms, counts, base.config.costs.pad, life_value(base))


def run_episodes(
    env: Any, policy: Any, seeds: Sequence[int], check_masks: bool = False
) -> list[EpisodeCost]:
    """:func:`run_episode` on each seed, in order."""
    return [run_episode(env, policy, int(s), check_masks) for s in seeds]


def figures(eps: Sequence[EpisodeCost], objective: Objective = "cost") -> F64:
    """Each episode's ``cost`` (:attr:`EpisodeCost.per_vehicle_shift`, the headline) or
    ``net`` (:attr:`EpisodeCost.net`: less the pad life left at the end)."""
    if objective not in OBJECTIVES:
        raise ValueError(f"objective must be one of {OBJECTIVES}, got {objective!r}")
    return np.array([e.net if objective == "net" else e.per_vehicle_shift for e in eps])


def evaluate(
    env: Any, policy: Any, seeds: Sequence[int], check_masks: bool = False,
    objective: Objective = "cost",
) -> F64:  # fmt: skip
    """:func:`figures` of ``policy``'s episodes on ``seeds``."""
    return figures(run_episodes(env, policy, seeds, check_masks), objective)


@dataclass(frozen=True)
class Interval:
    """A point estimate and its bootstrap interval."""

    point: float
    low: float
    high: float
    level: float

    def __str__(self) -> str:
        return f"{self.point:.4g} [{self.low:.4g}, {self.high:.4g}]"


def paired_interval(
    a: Sequence[float] | F64, b: Sequence[float] | F64,
    statistic: Literal["difference", "ratio"] = "difference",
    level: float = 0.95, n_resamples: int = 4000, seed: int = 0,
) -> Interval:  # fmt: skip
    """Paired bootstrap interval over episodes of mean(a) - mean(b) or mean(a) / mean(b).

    Args:
        a, b: Per-episode costs of two policies on the same seeds (same order).
        statistic: ``difference`` or ``ratio`` (of means).
        level: Confidence level.
        n_resamples: Bootstrap resamples.
        seed: Seed of the resampling.
    """
    x, y = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    if x.shape != y.shape or x.ndim != 1 or x.size < 2:
        raise ValueError(f"paired_interval: need two 1-D arrays of one length >= 2, got"
                         f" {x.shape} and {y.shape}")  # fmt: skip
    if statistic not in ("difference", "ratio"):
        raise ValueError(
            f"paired_interval: statistic must be difference or ratio, got {statistic!r}"
        )

    def stat(u: F64, v: F64, axis: int = -1) -> F64:
        mu, mv = u.mean(axis=axis), v.mean(axis=axis)
        return mu - mv if statistic == "difference" else mu / mv

    point = float(stat(x, y))
    if np.allclose(x - y, (x - y)[0]) and statistic == "difference":
        return Interval(point, point, point, level)  # no spread: BCa is undefined
    for method in ("BCa", "percentile"):
        with warnings.catch_warnings():  # a degenerate BCa falls back to the percentile
            warnings.simplefilter("ignore", RuntimeWarning)
            warnings.simplefilter("ignore", DegenerateDataWarning)
            res = bootstrap((x, y), stat, paired=True, vectorized=True, confidence_level=level,
                            n_resamples=n_resamples, method=method,
                            rng=np.random.default_rng(seed))  # fmt: skip
        lo, hi = res.confidence_interval
        if np.isfinite(lo) and np.isfinite(hi):
            return Interval(point, float(lo), float(hi), level)
    return Interval(point, float("nan"), float("nan"), level)


def iqm(x: F64, axis: int = -1) -> F64:
    """Interquartile mean: the mean of the middle half (25% trimmed off each end)."""
    return np.asarray(trim_mean(x, 0.25, axis=axis))


def seeds_interval(
    per_seed: F64, baseline: F64, level: float = 0.95, n_resamples: int = 4000, seed: int = 0
) -> dict[str, Interval]:
    """IQM over seeds of an agent's mean cost, and its difference from and ratio to a
    baseline policy's mean cost, with two-level bootstrap percentile intervals.

    Args:
        per_seed: (seeds, episodes) costs of the agent trained from each seed.
        baseline: (episodes,) costs of the baseline on the same episodes.
    """
    point, agent, (base,) = _two_level(per_seed, [baseline], n_resamples, seed)
    b = float(np.mean(baseline))
    return {
        "iqm": _percentile(point, agent, level),
        "difference": _percentile(point - b, agent - base, level),
        "ratio": _percentile(point / b, agent / base, level),
    }


def gap_closed(
    per_seed: F64, base: F64, better: F64, level: float = 0.95, n_resamples: int = 4000,
    seed: int = 0,
) -> Interval:  # fmt: skip
    """The fraction of the gap from ``base`` down to ``better`` (two policies' (episodes,)
    costs) that the agent's IQM closes: ``(base - agent) / (base - better)``, 1 at
    ``better``'s cost, 0 at ``base``'s, negative above it; the same two-level bootstrap as
    :func:`seeds_interval`, the three paired on episodes; nan where the two policies' means
    are equal (no gap)."""
    point, agent, (b, w) = _two_level(per_seed, [base, better], n_resamples, seed)
    mb, mw = float(np.mean(base)), float(np.mean(better))
    if mb == mw:  # no gap to close
        return Interval(float("nan"), float("nan"), float("nan"), level)
    with np.errstate(divide="ignore", invalid="ignore"):
        return _percentile((mb - point) / (mb - mw), (b - agent) / (b - w), level)


def _two_level(
    per_seed: F64, baselines: list[F64], n_resamples: int, seed: int
) -> tuple[float, F64, list[F64]]:
    """The agent's IQM, and its and the baselines' means over ``n_resamples`` two-level
    resamples (seeds with replacement, then episodes, one episode draw for all)."""
    x = np.asarray(per_seed, dtype=np.float64)
    bs = [np.asarray(b, dtype=np.float64) for b in baselines]
    if x.ndim != 2 or x.shape[0] < 1 or any(b.shape != x.shape[1:] or b.size < 2 for b in bs):
        raise ValueError(f"seeds_interval: need (seeds, episodes) and (episodes,), got"
                         f" {x.shape} and {[b.shape for b in bs]}")  # fmt: skip
    rng = np.random.default_rng(seed)
    n_s, n_e = x.shape
    pick_e = rng.integers(0, n_e, (n_resamples, n_e))
    pick_s = rng.integers(0, n_s, (n_resamples, n_s))
    seed_means = x[:, pick_e].mean(axis=-1)  # (seeds, resamples)
    agent = iqm(np.take_along_axis(seed_means.T, pick_s, axis=1), axis=1)
    return float(iqm(x.mean(axis=1))), agent, [b[pick_e].mean(axis=-1) for b in bs]


def _percentile(point: float, draws: F64, level: float) -> Interval:
    a = (1 - level) / 2 * 100
    lo, hi = np.percentile(draws, [a, 100 - a])
    return Interval(point, float(lo), float(hi), level)
