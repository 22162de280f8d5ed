"""Rank RUL predictors by the maintenance cost they lead to (the testbed's headline; README,
"Maintenance cost by predictor").

For each predictor: an RUL-threshold policy on its point estimate and, where it gives an
interval, one on its lower bound, each threshold tuned on tuning pads; and trained SB3
agents. Beside them: the fixed-interval policy with its age tuned, replace-on-failure and
the oracle. Every policy is evaluated on the same held-out pads (common random numbers),
pad by pad (:mod:`agents.pad_study`, :mod:`agents.outcomes`), with paired bootstrap
intervals over pads (:mod:`agents.bootstrap`). A rule's decisions do not depend on the cost
weights except through tuning, so each failure-to-planned ratio of the sensitivity study
gets its own tuned parameters; agents are priced as trained.

The pads and the agents' training are units of a :class:`~brake_env.runner.Runner`
(:mod:`agents.study`): in this process or on Ray, the same figures; each kept in
``<out>/units`` as it finishes, so an interrupted comparison resumes.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from agents import outcomes as oc
from agents.pad_study import PadSet
from agents.policies.rules import PolicyId
from agents.ranking import rank_policies
from agents.results import CompareResult, Timing, Tuning
from agents.study import CompareUnits, Progress
from brake_env.data.datasets import DatasetSpec, make_dataset
from brake_env.env.config import REGIMES, CostWeights, EnvConfig
from brake_env.model.atlas import Atlas
from brake_env.model.regime import WearRegime
from brake_env.prognostics.protocol import Predictor
from brake_env.prognostics.registry import make_predictor, predictor_names
from brake_env.runner import Runner

ORACLE = PolicyId("oracle")
REPLACE_ON_FAILURE = PolicyId("replace-on-failure")
FIXED_INTERVAL = PolicyId("fixed-interval")
# Thresholds in decision intervals (0: never replace) and replacement ages in mean lives of
# an ID pad (inf: never): geometric grids (4 and 16 a doubling, with the powers of two
# themselves, one decision interval among them), fine enough that tuning is not limited
# by them.
THRESHOLDS = (0.0, *(2.0 ** (k / 4) for k in range(-16, 38)))
AGES = (*(2.0 ** (k / 16) for k in range(-64, 25)), math.inf)


@dataclass(frozen=True)
class CompareConfig:
    """What ``brakewear compare`` runs.

    Attributes:
        regime: Wear regime of new pads (``mixed``: half OOD by default).
        ood_share: OOD share of the mixed regime [-].
        decision_interval: Braking events per decision [events].
        episode_events: Events per episode of the agents' training envs [events].
        predictors: Predictors whose threshold policies are tuned and evaluated.
        agent_predictors: Predictors that also get a trained agent (may be empty).
        algo: ``ppo`` or ``dqn``.
        timesteps: Training steps of each agent.
        min_timesteps: Fewer training steps than this train no agent: the report says the
            budget is too small instead of giving a figure.
        n_train_runs: Run-to-failure pads the predictors are fitted on.
        tune_pads: Tuning pads of each wear-regime label the regime draws.
        eval_pads: Held-out pads of each label, every policy evaluated on them.
        min_tune_pads: Fewer tuning pads in all than this tune nothing (as for agents).
        failure_ratios: Failure-to-planned cost ratios of the sensitivity study; the env's
            default weights (ratio 10) are the headline.
        thresholds: Candidate RUL thresholds in decision intervals (0: never replace).
        ages: Candidate ages of the fixed-interval policy in mean lives of an ID pad
            (``inf``: never replace).
        level: Confidence level of the intervals [-].
        n_resamples: Bootstrap resamples.
        wear: Distribution of K of the training pads and of every studied pad.
    """

    regime: str = "mixed"
    ood_share: float = 0.5
    decision_interval: int = 500
    episode_events: int = 500_000
    predictors: tuple[str, ...] = field(default_factory=predictor_names)
    agent_predictors: tuple[str, ...] = ("twin", "oracle")
    algo: str = "ppo"
    timesteps: int = 100_000
    min_timesteps: int = 50_000
    n_train_runs: int = 10
    tune_pads: int = 100
    eval_pads: int = 1000
    min_tune_pads: int = 90
    failure_ratios: tuple[float, ...] = (5.0, 10.0, 50.0, 200.0)
    thresholds: tuple[float, ...] = THRESHOLDS
    ages: tuple[float, ...] = AGES
    level: float = 0.95
    n_resamples: int = 4000
    wear: WearRegime = field(default_factory=WearRegime)

    def __post_init__(self) -> None:
        if self.regime not in REGIMES:
            raise ValueError(f"regime must be one of {list(REGIMES)}, got {self.regime!r}")
        for group in (self.predictors, self.agent_predictors):
            bad = [p for p in group if p not in predictor_names()]
            if bad:
                raise ValueError(f"unknown predictor(s) {bad}; valid are {list(predictor_names())}")
        for name in ("tune_pads", "eval_pads", "n_resamples", "timesteps", "n_train_runs"):
            if getattr(self, name) < 1:
                raise ValueError(f"{name} must be >= 1, got {getattr(self, name)}")
        if not self.thresholds or not self.ages:
            raise ValueError("give at least one threshold and one fixed-interval age")
        if min(self.thresholds) < 0 or min(self.ages) <= 0:
            raise ValueError("thresholds must be >= 0 and ages > 0")
        if not 0 < self.level < 1:
            raise ValueError(f"level must be in (0, 1), got {self.level}")
        if not isinstance(self.wear, WearRegime):
            raise TypeError(f"wear must be a WearRegime, got {self.wear!r}")
        EnvConfig.from_kwargs(**self.env_kwargs)  # validates the env's fields

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


def fit_predictors(
    names: tuple[str, ...],
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


def run_compare(
    config: CompareConfig,
    atlas: Atlas,
    out_dir: str | Path,
    seed: int = 0,
    progress: Progress | None = None,
    fitted: Mapping[str, Predictor] | None = None,
    hyperparams: Mapping[str, dict[str, Any]] | None = None,
    runner: Runner | None = None,
    resume: bool = True,
) -> CompareResult:
    """Fit, simulate, tune, train and evaluate (:meth:`CompareResult.to_dict` is
    ``costs.json``).

    Args:
        config: What to run.
        atlas: The brake atlas.
        out_dir: Trained agents go to ``out_dir/agents/<predictor>``, finished units to
            ``out_dir/units``.
        seed: Seeds the training pads, the agents, the tuning and the held-out pads.
        progress: ``progress(label, total)`` returns a callback advanced by the units done.
        fitted: Already fitted predictors by name (fitted here when missing).
        hyperparams: Agent hyperparameters by predictor (default: the predictor's file).
        runner: Where the pads are simulated and the agents trained (default: in this
            process, in order; the same figures anywhere).
        resume: Keep finished units in ``out_dir/units``, reuse those already there.

    Raises:
        ValueError: ``out_dir/units`` holds the units of a run with other settings.
    """
    t_start = time.perf_counter()
    study = CompareUnits(config, seed, Path(out_dir), hyperparams)
    store = study.store(atlas, fitted) if resume else None  # refuses other settings first
    used, fit_s = _fitted(config, atlas, seed, fitted)
    t0 = time.perf_counter()
    tune_set, eval_set, runs = study.run(runner or Runner(0), store, atlas, used, progress)
    pads_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    tuning = tune(config, tune_set, id_life(config, atlas))
    tune_s = time.perf_counter() - t0
    skipped = {**runs.skipped, **_untuned(config, tuning)}
    t0 = time.perf_counter()
    sensitivity = {
        r: rank_policies(config, eval_set, tuning, runs.outcomes, r, seed) for r in ratios(config)
    }
    evaluate_s = time.perf_counter() - t0
    timing = Timing(fit_s, pads_s, eval_set.seconds, tune_s, runs.seconds, evaluate_s,
                    time.perf_counter() - t_start)  # fmt: skip
    return CompareResult(
        seed=seed,
        config=config,
        failure_to_planned=CostWeights().failure_to_planned,
        tune_pads=_count(tune_set),
        eval_pads=_count(eval_set),
        sensitivity=sensitivity,
        tuning=tuning,
        skipped=skipped,
        timing=timing,
        learning_curves=runs.curves,
    )


def _fitted(
    config: CompareConfig, atlas: Atlas, seed: int, fitted: Mapping[str, Predictor] | None
) -> tuple[dict[str, Predictor], dict[str, float]]:
    """Every predictor the comparison uses, those not given fitted here; the fits' seconds."""
    names = tuple(dict.fromkeys((*config.predictors, *config.agent_predictors, "oracle")))
    have = dict(fitted or {})
    todo = tuple(n for n in names if n not in have)
    new, fit_s = fit_predictors(todo, atlas, seed, config.n_train_runs, config.wear)
    have.update(new)
    return {n: have[n] for n in names}, fit_s


def _untuned(config: CompareConfig, tuning: Tuning) -> dict[PolicyId, str]:
    """The tuned families, and why they have no figure, when there were too few pads."""
    if tuning.enough:
        return {}
    why = (
        f"not tuned: {tuning.n_pads} tuning pads is too small a budget"
        f" (it needs {config.min_tune_pads} or more)"
    )
    return dict.fromkeys(tuning.parameters, why)


def ratios(config: CompareConfig) -> tuple[float, ...]:
    """The sensitivity study's failure-to-planned ratios and the env's own."""
    return tuple(dict.fromkeys((*config.failure_ratios, CostWeights().failure_to_planned)))


def weights(ratio: float) -> CostWeights:
    """Cost weights of a failure-to-planned ratio (the env's own at its ratio)."""
    default = CostWeights()
    if np.isclose(ratio, default.failure_to_planned):
        return default
    return CostWeights.with_ratio(ratio, default.planned_replacement)


def id_life(config: CompareConfig, atlas: Atlas) -> float:
    """Expected life of an ID pad [events], the unit of the fixed interval's candidates."""
    from brake_env.model.wear import WearModel

    return float(WearModel.from_atlas(atlas).life(config.wear.k_mean))


def tune(config: CompareConfig, pads: PadSet, id_life: float) -> Tuning:
    """Every candidate of every tuned family on the tuning pads, and the cheapest of each
    family at each cost ratio. Of candidates that cost the same (no tuning pad tells them
    apart) "never" is chosen, so a family that cannot beat replace-on-failure falls back
    to it, else the most cautious (the highest threshold, the youngest age): held-out pads
    may tell them apart by a failure. Too few tuning pads tune nothing
    (:attr:`CompareConfig.min_tune_pads`).

    Args:
        config: The candidates and the cost ratios.
        pads: The tuning pads.
        id_life: Expected life of an ID pad [events]: the unit of the candidate ages.
    """
    d = config.decision_interval
    life = id_life
    # Candidate order: never first, then from the most cautious; argmin takes the first.
    cautious = sorted((h * d for h in config.thresholds if h > 0), reverse=True)
    grid = np.array([0.0, *cautious])
    grids = {"mean": grid, "lower": grid}
    ages = np.array([math.inf, *sorted(a * life for a in config.ages if math.isfinite(a))])
    families: dict[PolicyId, tuple[np.ndarray, oc.Outcomes]] = {}
    for name in config.predictors:
        est = pads.estimates[name]
        families[PolicyId("threshold", name)] = (
            grids["mean"],
            oc.threshold_outcomes(pads, est["rul_mean"], grids["mean"]),
        )
        if "rul_lower" in est:
            families[PolicyId("lower-threshold", name)] = (
                grids["lower"],
                oc.threshold_outcomes(pads, est["rul_lower"], grids["lower"]),
            )
    families[FIXED_INTERVAL] = (ages, oc.fixed_interval_outcomes(pads, ages))
    curves = {
        r: {fam: oc.cost_per_1000(pads, out, weights(r)) for fam, (_, out) in families.items()}
        for r in ratios(config)
    }
    best = {
        r: {fam: float(families[fam][0][int(np.argmin(c))]) for fam, c in by_fam.items()}
        for r, by_fam in curves.items()
    }
    enough = len(pads) >= config.min_tune_pads
    params = {fam: grid for fam, (grid, _) in families.items()}
    return Tuning(len(pads), enough, params, curves, best)


def _count(pads: PadSet) -> dict[str, int]:
    return {k: int(v.size) for k, v in pads.strata().items()}
