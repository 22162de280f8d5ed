"""Rank RUL predictors by the maintenance cost they lead to (the testbed's headline).

For each predictor: an RUL-threshold policy with its threshold tuned on training seeds, and
a trained SB3 agent. Beside them: the fixed-interval policy with its interval tuned,
replace-on-failure, and the oracle. All are evaluated on the same held-out seeds, so they
meet the same pads under the same operating conditions. Because the decisions of a policy
do not depend on the cost weights, the tuning runs also give the best threshold under
other failure-to-planned cost ratios, and the ranking under each ratio follows.

Episodes run seed by seed, every policy on a seed before the next seed, so the env's pad
cache holds one seed's pads and each pad is simulated, and each predictor run over it,
once for all policies (``RULObservation(precompute=True)``).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from agents.evaluation import (
    CostReport,
    merge_reports,
    ratio_per_seed,
    run_episodes,
    t_interval,
    with_oracle_ratios,
)
from agents.policies import FixedInterval, Policy, ReplaceOnFailure, RULThreshold
from brake_env.data.datasets import DatasetSpec, make_dataset
from brake_env.env.brake_wear import BrakeWearEnv
from brake_env.env.config import REGIMES, CostWeights
from brake_env.env.wrappers import RULObservation
from brake_env.model.atlas import Atlas
from brake_env.model.regime import WearRegime
from brake_env.prognostics.protocol import Predictor
from brake_env.prognostics.registry import make_predictor, predictor_names

Entry = tuple[Policy, gym.Env[Any, Any]]


@dataclass(frozen=True)
class CompareConfig:
    """What ``brakewear compare`` runs.

    Attributes:
        regime: Wear regime of new pads (``mixed``: half OOD by default).
        ood_share: OOD share of the mixed regime [-].
        decision_interval: Braking events per decision [events].
        episode_events: Braking events per episode [events].
        predictors: Predictors whose threshold policy is tuned and evaluated.
        agent_predictors: Predictors that also get a trained agent (may be empty).
        algo: ``ppo`` or ``dqn``.
        timesteps: Training steps of each agent.
        n_train_runs: Run-to-failure pads the predictors are fitted on.
        tune_seeds: Episodes (seeds) for tuning thresholds and the fixed interval.
        eval_seeds: Held-out episodes every policy is evaluated on.
        failure_ratios: Failure-to-planned cost ratios of the sensitivity study; the env's
            default weights (ratio 10) are the headline.
        thresholds: Candidate RUL thresholds, in decision intervals.
        fixed_intervals: Candidate replacement ages of the fixed-interval policy [events].
        k_mean, k_std: Wear-coefficient distribution of training and ID pads [-].
    """

    regime: str = "mixed"
    ood_share: float = 0.5
    decision_interval: int = 500
    episode_events: int = 500_000
    predictors: tuple[str, ...] = field(default_factory=predictor_names)
    agent_predictors: tuple[str, ...] = field(default_factory=predictor_names)
    algo: str = "ppo"
    timesteps: int = 50_000
    n_train_runs: int = 10
    tune_seeds: int = 4
    eval_seeds: int = 8
    failure_ratios: tuple[float, ...] = (5.0, 10.0, 50.0)
    thresholds: tuple[float, ...] = (0, 1, 1.5, 2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64, 96)
    fixed_intervals: tuple[int, ...] = tuple(range(30_000, 135_001, 5_000))
    k_mean: float = 2e-6
    k_std: float = 2e-7

    def __post_init__(self) -> None:
        if self.regime not in REGIMES:
            raise ValueError(f"regime must be one of {list(REGIMES)}, got {self.regime!r}")
        for group in (self.predictors, self.agent_predictors):
            bad = [p for p in group if p not in predictor_names()]
            if bad:
                raise ValueError(f"unknown predictor(s) {bad}; valid are {list(predictor_names())}")
        missing = [p for p in self.agent_predictors if p not in self.predictors]
        if missing:
            raise ValueError(f"agent predictor(s) {missing} are not among the predictors")
        if self.tune_seeds < 1 or self.eval_seeds < 1:
            raise ValueError("tune_seeds and eval_seeds must be >= 1")
        if not self.thresholds or not self.fixed_intervals:
            raise ValueError("give at least one threshold and one fixed interval")

    @property
    def env_kwargs(self) -> dict[str, Any]:
        return {
            "regime": self.regime,
            "ood_share": self.ood_share,
            "decision_interval": self.decision_interval,
            "episode_events": self.episode_events,
            "k_mean": self.k_mean,
            "k_std": self.k_std,
        }


def evaluate_seed_major(
    entries: Mapping[str, Entry],
    seeds: Sequence[int],
    progress: Callable[[int], object] | None = None,
) -> dict[str, CostReport]:
    """``run_episodes`` for every entry, seed by seed (cache-friendly), merged per entry."""
    parts: dict[str, list[CostReport]] = {k: [] for k in entries}
    for seed in seeds:
        for name, (policy, env) in entries.items():
            parts[name].append(run_episodes(policy, env, [seed], name))
            if progress:
                progress(1)
    return {name: merge_reports(reps) for name, reps in parts.items()}


def fit_predictors(
    names: Sequence[str],
    atlas: Atlas,
    seed: int,
    n_train_runs: int,
    k_mean: float = 2e-6,
    k_std: float = 2e-7,
) -> tuple[dict[str, Predictor], dict[str, float]]:
    """Each named predictor fitted on ``n_train_runs`` freshly simulated training pads; and
    the seconds each fit took."""
    spec = DatasetSpec(
        n_train=n_train_runs, n_id=0, n_ood_slow=0, n_ood_fast=0, wear=WearRegime(k_mean, k_std)
    )
    train_log = make_dataset(atlas, spec, seed).logs["train"]
    fitted, seconds = {}, {}
    for name in names:
        t0 = time.perf_counter()
        fitted[name] = make_predictor(name, atlas, seed).fit(train_log)
        seconds[name] = time.perf_counter() - t0
    return fitted, seconds


def run_compare(
    config: CompareConfig,
    atlas: Atlas,
    out_dir: str | Path,
    seed: int = 0,
    progress: Callable[[str, int], Callable[[int], object]] | None = None,
    fitted: Mapping[str, Predictor] | None = None,
    hyperparams: Mapping[str, dict[str, Any]] | None = None,
) -> dict[str, Any]:
    """Fit, tune, train and evaluate; returns the content of ``costs.json``.

    Args:
        config: What to run.
        atlas: The brake atlas.
        out_dir: Trained agents go to ``out_dir/agents/<predictor>``.
        seed: Seeds the training pads, the agents and (offset) the tuning and evaluation
            episodes, which never overlap.
        progress: ``progress(label, total)`` returns a callback advanced by 1 per episode.
        fitted: Already fitted predictors by name (fitted here when missing).
        hyperparams: Agent hyperparameters by predictor (default: the predictor's file).
    """
    from agents.train import TrainedAgent, agent_env, train_agent

    t_start = time.perf_counter()
    names = tuple(dict.fromkeys((*config.predictors, "oracle")))
    timing: dict[str, Any] = {}
    have = dict(fitted or {})
    todo = [n for n in names if n not in have]
    new, timing["fit_s"] = fit_predictors(
        todo, atlas, seed, config.n_train_runs, config.k_mean, config.k_std
    )
    have.update(new)
    base = BrakeWearEnv(atlas=atlas, cache_pads=64, **config.env_kwargs)
    wrapped = {n: RULObservation(base, have[n], precompute=True) for n in names}
    interval = config.decision_interval
    tune_seeds = [seed * 10_000 + 1_000 + i for i in range(config.tune_seeds)]
    eval_seeds = [seed * 10_000 + 5_000 + i for i in range(config.eval_seeds)]

    # ---- tuning: every candidate on the tuning seeds, once for all cost ratios
    candidates: dict[str, Entry] = {}
    for n in config.predictors:
        for h in config.thresholds:
            candidates[f"{n}/threshold/{h * interval:g}"] = (RULThreshold(h * interval), wrapped[n])
    for age in config.fixed_intervals:
        candidates[f"fixed-interval/{age}"] = (FixedInterval(age), base)
    t0 = time.perf_counter()
    bar = progress("tune", len(candidates) * len(tune_seeds)) if progress else None
    tuned = evaluate_seed_major(candidates, tune_seeds, bar)
    timing["tune_s"] = time.perf_counter() - t0
    ratios = tuple(dict.fromkeys((*config.failure_ratios, base.config.costs.failure_to_planned)))
    best: dict[float, dict[str, str]] = {}  # ratio -> policy family -> candidate key
    for r in ratios:
        w = _weights(base.config.costs, r)
        families = {f"{n}/threshold": f"{n}/threshold/" for n in config.predictors}
        families["fixed-interval"] = "fixed-interval/"
        best[r] = {
            fam: min(
                (k for k in tuned if k.startswith(prefix)), key=lambda k: tuned[k].cost_with(w)
            )
            for fam, prefix in families.items()
        }

    # ---- agents
    agents: dict[str, TrainedAgent] = {}
    timing["train_s"] = {}
    for n in config.agent_predictors:
        res = train_agent(
            have[n],
            atlas,
            Path(out_dir) / "agents" / n,
            algo=config.algo,
            timesteps=config.timesteps,
            seed=seed,
            env_kwargs=config.env_kwargs,
            hyperparams=hyperparams.get(n) if hyperparams else None,
        )
        timing["train_s"][n] = res.seconds
        agents[n] = TrainedAgent(res.out_dir)

    # ---- evaluation on held-out seeds
    default_ratio = base.config.costs.failure_to_planned
    entries: dict[str, Entry] = {}
    params: dict[str, float] = {}
    for r in ratios:
        for fam, key in best[r].items():
            name = fam if r == default_ratio else f"{fam}@{r:g}"
            entries[name] = candidates[key]
            params[name] = float(key.rsplit("/", 1)[1])
    for n, agent in agents.items():
        env = agent_env(have[n], atlas, {**config.env_kwargs, "cache_pads": 64})
        entries[f"{n}/{config.algo}"] = (agent, env)
    entries["replace-on-failure"] = (ReplaceOnFailure(), base)
    entries["oracle"] = (RULThreshold(interval), wrapped["oracle"])
    t0 = time.perf_counter()
    bar = progress("evaluate", len(entries) * len(eval_seeds)) if progress else None
    reports = evaluate_seed_major(entries, eval_seeds, bar)
    timing["evaluate_s"] = time.perf_counter() - t0
    reports = with_oracle_ratios(reports, reports["oracle"])

    # ---- cost sensitivity: each family's policy tuned for the ratio (agents as trained)
    sensitivity = {}
    for r in ratios:
        w = _weights(base.config.costs, r)
        oracle_cost = reports["oracle"].cost_with(w)
        rows = {}
        for fam in best[r]:
            name = fam if r == default_ratio else f"{fam}@{r:g}"
            rows[fam] = _sensitivity_row(reports[name], w, reports["oracle"], params[name])
        for n in agents:
            rows[f"{n}/{config.algo}"] = _sensitivity_row(
                reports[f"{n}/{config.algo}"], w, reports["oracle"], None
            )
        rows["replace-on-failure"] = _sensitivity_row(
            reports["replace-on-failure"], w, reports["oracle"], None
        )
        ranking = sorted(
            config.predictors,
            key=lambda n: min(
                rows[k]["cost_per_1000_events"] for k in rows if k.startswith(f"{n}/")
            ),
        )
        sensitivity[f"{r:g}"] = {
            "failure_to_planned": r,
            "oracle_cost_per_1000_events": oracle_cost,
            "policies": rows,
            "predictor_ranking": ranking,
        }
    timing["total_s"] = time.perf_counter() - t_start
    headline = {k: v for k, v in reports.items() if "@" not in k}
    return {
        "seed": seed,
        "config": asdict(config),
        "failure_to_planned": default_ratio,
        "tune_seeds": tune_seeds,
        "eval_seeds": eval_seeds,
        "tuned_parameters": {k: v for k, v in params.items() if "@" not in k},
        "policies": {k: {**v.to_dict(), "parameter": params.get(k)} for k, v in headline.items()},
        "sensitivity": sensitivity,
        "tuning": {k: v.cost_per_1000_events for k, v in tuned.items()},
        "timing_s": timing,
        "_reports": headline,  # for the plots; dropped before writing JSON
    }


def _weights(default: CostWeights, ratio: float) -> CostWeights:
    if np.isclose(ratio, default.failure_to_planned):
        return default
    return CostWeights.with_ratio(ratio, default.planned_replacement)


def _sensitivity_row(
    r: CostReport, w: CostWeights, oracle: CostReport, parameter: float | None
) -> dict[str, Any]:
    per_seed = ratio_per_seed(r.episode_costs_with(w), oracle.episode_costs_with(w))
    return {
        "cost_per_1000_events": r.cost_with(w),
        "ratio_to_oracle": r.cost_with(w) / oracle.cost_with(w),
        "ratio_to_oracle_ci95": t_interval(per_seed.tolist()),
        "failures_per_100_pads": r.failures_per_100_pads,
        "parameter": parameter,
    }
