"""Rank RUL predictors by the maintenance cost they lead to (the testbed's headline; README,
"Maintenance cost by predictor").

For each predictor: an RUL-threshold policy with its threshold tuned on training seeds, and
a trained SB3 agent. Beside them: the fixed-interval policy with its interval tuned,
replace-on-failure, and the oracle. All are evaluated on the same held-out seeds, so they
meet the same pads under the same operating conditions (common random numbers).
Because the decisions of a policy do not depend on the cost weights, the tuning runs also
give the best threshold under other failure-to-planned cost ratios, and the ranking under
each ratio follows.

Episodes run seed by seed, every policy on a seed before the next seed, so the env's pad
cache holds one seed's pads and each pad is simulated, and each predictor run over it,
once for all policies (``RULObservation(precompute=True)``).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Hashable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any, TypeVar

import gymnasium as gym
import numpy as np

from agents.evaluation import CostReport, merge_reports, run_episodes, with_oracle_ratios
from agents.policies import FixedInterval, Policy, PolicyId, ReplaceOnFailure, RULThreshold
from agents.results import CompareResult, PolicyCost, RatioResult, Timing
from brake_env.data.datasets import DatasetSpec, make_dataset
from brake_env.env.brake_wear import BrakeWearEnv
from brake_env.env.config import REGIMES, CostWeights
from brake_env.env.wrappers import RULObservation
from brake_env.model.atlas import Atlas
from brake_env.model.regime import WearRegime
from brake_env.prognostics.protocol import Predictor
from brake_env.prognostics.registry import make_predictor, predictor_names

Entry = tuple[Policy, gym.Env[Any, Any]]
# progress(label, total) returns a callback advanced by 1 per episode.
Progress = Callable[[str, int], Callable[[int], object]]
K = TypeVar("K", bound=Hashable)

ORACLE = PolicyId("oracle")
REPLACE_ON_FAILURE = PolicyId("replace-on-failure")
FIXED_INTERVAL = PolicyId("fixed-interval")


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
        wear: Distribution of K of the training pads and of the env's new pads.
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
    wear: WearRegime = field(default_factory=WearRegime)

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
        if not isinstance(self.wear, WearRegime):
            raise TypeError(f"wear must be a WearRegime, got {self.wear!r}")

    @property
    def env_kwargs(self) -> dict[str, Any]:
        """BrakeWear-v0's keyword arguments."""
        return {
            "regime": self.regime,
            "ood_share": self.ood_share,
            "decision_interval": self.decision_interval,
            "episode_events": self.episode_events,
            **self.wear.env_kwargs(),
        }

    def to_dict(self) -> dict[str, Any]:
        """The fields as JSON-ready values, the wear regime's flat (like ``env_kwargs``)."""
        d = asdict(self)
        d.update(d.pop("wear"))
        return d


def evaluate_seed_major(
    entries: Mapping[K, Entry],
    seeds: Sequence[int],
    progress: Callable[[int], object] | None = None,
) -> dict[K, CostReport]:
    """``run_episodes`` for every entry, seed by seed (cache-friendly), merged per entry.
    Each report is named ``str(key)`` (a :class:`PolicyId`'s label)."""
    parts: dict[K, list[CostReport]] = {k: [] for k in entries}
    for seed in seeds:
        for key, (policy, env) in entries.items():
            parts[key].append(run_episodes(policy, env, [seed], str(key)))
            if progress:
                progress(1)
    return {key: merge_reports(reps) for key, reps in parts.items()}


def fit_predictors(
    names: Sequence[str],
    atlas: Atlas,
    seed: int,
    n_train_runs: int,
    wear: WearRegime | None = None,
) -> tuple[dict[str, Predictor], dict[str, float]]:
    """Each named predictor fitted on ``n_train_runs`` freshly simulated training pads whose
    K follows ``wear`` (default :class:`WearRegime`'s); and the seconds each fit took."""
    spec = DatasetSpec(
        n_train=n_train_runs, n_id=0, n_ood_slow=0, n_ood_fast=0, wear=wear or WearRegime()
    )
    train_log = make_dataset(atlas, spec, seed).logs["train"]
    fitted, seconds = {}, {}
    for name in names:
        t0 = time.perf_counter()
        fitted[name] = make_predictor(name, atlas, seed).fit(train_log)
        seconds[name] = time.perf_counter() - t0
    return fitted, seconds


@dataclass(frozen=True)
class _Testbed:
    """What the stages of one comparison share: one env (with a pad cache) seen bare and
    through each predictor, and the seeds of the tuning and the held-out episodes."""

    config: CompareConfig
    base: BrakeWearEnv
    wrapped: dict[str, RULObservation]
    tune_seeds: tuple[int, ...]
    eval_seeds: tuple[int, ...]

    @classmethod
    def make(
        cls, config: CompareConfig, atlas: Atlas, predictors: Mapping[str, Predictor], seed: int
    ) -> _Testbed:
        base = BrakeWearEnv(atlas=atlas, cache_pads=64, **config.env_kwargs)
        wrapped = {n: RULObservation(base, p, precompute=True) for n, p in predictors.items()}
        tune = tuple(seed * 10_000 + 1_000 + i for i in range(config.tune_seeds))
        held_out = tuple(seed * 10_000 + 5_000 + i for i in range(config.eval_seeds))
        return cls(config, base, wrapped, tune, held_out)

    @property
    def costs(self) -> CostWeights:
        return self.base.config.costs

    @property
    def ratios(self) -> tuple[float, ...]:
        """The sensitivity study's failure-to-planned ratios and the env's own."""
        return tuple(dict.fromkeys((*self.config.failure_ratios, self.costs.failure_to_planned)))

    @property
    def families(self) -> tuple[PolicyId, ...]:
        """The policies whose parameter is tuned."""
        return (*(PolicyId("threshold", n) for n in self.config.predictors), FIXED_INTERVAL)


def run_compare(
    config: CompareConfig,
    atlas: Atlas,
    out_dir: str | Path,
    seed: int = 0,
    progress: Progress | None = None,
    fitted: Mapping[str, Predictor] | None = None,
    hyperparams: Mapping[str, dict[str, Any]] | None = None,
) -> CompareResult:
    """Fit, tune, train and evaluate (:meth:`CompareResult.to_dict` is ``costs.json``).

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
    t_start = time.perf_counter()
    names = tuple(dict.fromkeys((*config.predictors, "oracle")))
    have = dict(fitted or {})
    todo = [n for n in names if n not in have]
    new, fit_s = fit_predictors(todo, atlas, seed, config.n_train_runs, config.wear)
    have.update(new)
    bed = _Testbed.make(config, atlas, {n: have[n] for n in names}, seed)

    candidates = _candidates(bed)
    tuned, tune_s = _timed(candidates, bed.tune_seeds, progress, "tune")
    best = {r: _best(bed, tuned, r) for r in bed.ratios}
    agents, train_s = _train_agents(config, have, atlas, Path(out_dir), seed, hyperparams)
    entries = _evaluation_entries(bed, candidates, best, agents)
    reports, evaluate_s = _timed(entries, bed.eval_seeds, progress, "evaluate")
    reports = with_oracle_ratios(reports, reports[ORACLE])

    default = best[bed.costs.failure_to_planned]
    unparametrised = (*agents, REPLACE_ON_FAILURE)
    headline = {fam: replace(reports[c], name=fam.label) for fam, c in default.items()}
    headline.update((p, reports[p]) for p in (*unparametrised, ORACLE))
    parameters = {fam: c.parameter for fam, c in default.items() if c.parameter is not None}
    return CompareResult(
        seed=seed,
        config=config,
        failure_to_planned=bed.costs.failure_to_planned,
        tune_seeds=bed.tune_seeds,
        eval_seeds=bed.eval_seeds,
        policies=headline,
        parameters=parameters,
        sensitivity={r: _ratio_result(bed, r, best[r], unparametrised, reports) for r in best},
        tuning=tuned,
        timing=Timing(fit_s, tune_s, train_s, evaluate_s, time.perf_counter() - t_start),
    )


def _timed(
    entries: Mapping[PolicyId, Entry], seeds: Sequence[int], progress: Progress | None, label: str
) -> tuple[dict[PolicyId, CostReport], float]:
    """:func:`evaluate_seed_major` with a progress bar named ``label``, and its seconds."""
    t0 = time.perf_counter()
    bar = progress(label, len(entries) * len(seeds)) if progress else None
    return evaluate_seed_major(entries, seeds, bar), time.perf_counter() - t0


def _candidates(bed: _Testbed) -> dict[PolicyId, Entry]:
    """Every threshold of every predictor and every fixed interval, to be tuned."""
    interval = bed.config.decision_interval
    out: dict[PolicyId, Entry] = {}
    for n in bed.config.predictors:
        for h in bed.config.thresholds:
            threshold = float(h * interval)
            out[PolicyId("threshold", n, parameter=threshold)] = (
                RULThreshold(threshold),
                bed.wrapped[n],
            )
    for age in bed.config.fixed_intervals:
        out[replace(FIXED_INTERVAL, parameter=float(age))] = (FixedInterval(age), bed.base)
    return out


def _best(
    bed: _Testbed, tuned: Mapping[PolicyId, CostReport], ratio: float
) -> dict[PolicyId, PolicyId]:
    """Each family's cheapest candidate on the tuning episodes at cost ratio ``ratio``
    (the first of equals, in candidate order)."""
    w = _weights(bed.costs, ratio)
    return {
        fam: min((c for c in tuned if c.family == fam), key=lambda c: tuned[c].cost_with(w))
        for fam in bed.families
    }


def _train_agents(
    config: CompareConfig,
    predictors: Mapping[str, Predictor],
    atlas: Atlas,
    out_dir: Path,
    seed: int,
    hyperparams: Mapping[str, dict[str, Any]] | None,
) -> tuple[dict[PolicyId, Entry], dict[str, float]]:
    """An agent per agent predictor, trained into ``out_dir/agents/<predictor>``, with the
    env it acts on; and the seconds each took."""
    from agents.train import TrainedAgent, agent_env, train_agent

    agents: dict[PolicyId, Entry] = {}
    seconds: dict[str, float] = {}
    for n in config.agent_predictors:
        res = train_agent(
            predictors[n],
            atlas,
            out_dir / "agents" / n,
            algo=config.algo,
            timesteps=config.timesteps,
            seed=seed,
            env_kwargs=config.env_kwargs,
            hyperparams=hyperparams.get(n) if hyperparams else None,
        )
        seconds[n] = res.seconds
        env = agent_env(predictors[n], atlas, {**config.env_kwargs, "cache_pads": 64})
        agents[PolicyId("agent", n, algo=config.algo)] = (TrainedAgent(res.out_dir), env)
    return agents, seconds


def _evaluation_entries(
    bed: _Testbed,
    candidates: Mapping[PolicyId, Entry],
    best: Mapping[float, Mapping[PolicyId, PolicyId]],
    agents: Mapping[PolicyId, Entry],
) -> dict[PolicyId, Entry]:
    """What runs on the held-out episodes: each candidate that is best at some cost ratio
    (once, however many ratios it wins), the agents, replace-on-failure and the oracle."""
    entries = {c: candidates[c] for winners in best.values() for c in winners.values()}
    entries.update(agents)
    entries[REPLACE_ON_FAILURE] = (ReplaceOnFailure(), bed.base)
    entries[ORACLE] = (RULThreshold(bed.config.decision_interval), bed.wrapped["oracle"])
    return entries


def _ratio_result(
    bed: _Testbed,
    ratio: float,
    best: Mapping[PolicyId, PolicyId],
    unparametrised: Sequence[PolicyId],
    reports: Mapping[PolicyId, CostReport],
) -> RatioResult:
    """Each family's policy tuned for ``ratio``, the agents (as trained) and
    replace-on-failure, priced with that ratio's weights; and the predictors' ranking."""
    w = _weights(bed.costs, ratio)
    oracle = reports[ORACLE]
    rows = {fam: PolicyCost.of(reports[c], w, oracle, c.parameter) for fam, c in best.items()}
    rows.update((p, PolicyCost.of(reports[p], w, oracle, None)) for p in unparametrised)
    ranking = sorted(
        bed.config.predictors,
        key=lambda n: min(r.cost_per_1000_events for p, r in rows.items() if p.predictor == n),
    )
    return RatioResult(ratio, oracle.cost_with(w), rows, tuple(ranking))


def _weights(default: CostWeights, ratio: float) -> CostWeights:
    if np.isclose(ratio, default.failure_to_planned):
        return default
    return CostWeights.with_ratio(ratio, default.planned_replacement)
