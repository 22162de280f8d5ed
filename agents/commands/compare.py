"""Rank RUL predictors by the maintenance cost they lead to (the testbed's headline;
docs/results/single-pad.md).

For each predictor: an RUL-threshold policy on its point estimate and, where it gives an
interval, one on its lower bound, each threshold tuned on tuning pads; and trained SB3
agents. Beside them: the fixed-interval policy with its age tuned, replace-on-failure and
the oracle. Every policy is evaluated on the same held-out pads (common random numbers),
pad by pad (:mod:`agents.study.pads`, :mod:`agents.study.outcomes`), with paired bootstrap
intervals over pads (:mod:`agents.study.bootstrap`). A rule's decisions do not depend on the cost
weights except through tuning, so each failure-to-planned ratio of the sensitivity study
gets its own tuned parameters; agents are priced as trained.

The pads and the agents' training are units of a :class:`~brake_env.runner.Runner`
(:mod:`agents.commands.study_units`): in this process or on Ray, the same figures; each kept in
``<out>/units`` as it finishes, so an interrupted comparison resumes.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from agents.commands.study_units import CompareUnits, Progress
from agents.policies.rules import PolicyId
from agents.study.config import StudyConfig
from agents.study.pads import PadSet
from agents.study.ranking import rank_policies
from agents.study.results import CompareResult, Timing, Tuning
from agents.study.tuning import id_life, tune
from brake_env.model.atlas import Atlas
from brake_env.prognostics.protocol import Predictor
from brake_env.prognostics.registry import fit_predictors
from brake_env.runner import Runner


def run_compare(
    config: StudyConfig,
    atlas: Atlas,
    out_dir: str | Path,
    seed: int = 0,
    *,
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
        runner: Where the pads and agents run (default: in this process; the same
            figures anywhere).
        resume: Keep finished units in ``out_dir/units``, reuse those already there.

    Raises:
        ValueError: ``out_dir/units`` holds the units of other settings, or is in use.
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
    t0 = time.perf_counter()
    sensitivity = {
        r: rank_policies(config, eval_set, tuning, runs.outcomes, r, seed) for r in config.ratios()
    }
    evaluate_s = time.perf_counter() - t0
    timing = Timing(fit_s, pads_s, eval_set.seconds, tune_s, runs.seconds, evaluate_s,
                    time.perf_counter() - t_start)  # fmt: skip
    return CompareResult(
        seed=seed,
        config=config,
        failure_to_planned=config.costs.failure_to_planned,
        tune_pads=_count(tune_set),
        eval_pads=_count(eval_set),
        sensitivity=sensitivity,
        tuning=tuning,
        skipped={**runs.skipped, **_untuned(config, tuning)},
        timing=timing,
        learning_curves=runs.curves,
    )


def _fitted(
    config: StudyConfig, atlas: Atlas, seed: int, fitted: Mapping[str, Predictor] | None
) -> tuple[dict[str, Predictor], dict[str, float]]:
    """Every predictor the comparison uses, those not given fitted here; the fits' seconds."""
    names = tuple(dict.fromkeys((*config.predictors, *config.agent_predictors, "oracle")))
    have = dict(fitted or {})
    todo = tuple(n for n in names if n not in have)
    new, fit_s = fit_predictors(todo, atlas, seed, config.n_train_runs, config.wear)
    have.update(new)
    return {n: have[n] for n in names}, fit_s


def _untuned(config: StudyConfig, tuning: Tuning) -> dict[PolicyId, str]:
    """The tuned families, and why they have no figure, when there were too few pads."""
    if tuning.enough:
        return {}
    why = (
        f"not tuned: {tuning.n_pads} tuning pads is too small a budget"
        f" (it needs {config.min_tune_pads} or more)"
    )
    return dict.fromkeys(tuning.parameters, why)


def _count(pads: PadSet) -> dict[str, int]:
    return {k: int(v.size) for k, v in pads.strata().items()}
