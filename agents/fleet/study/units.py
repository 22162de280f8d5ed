"""The fleet study's units, and their run on a :class:`~brake_env.runner.Runner` (in this
process or on Ray, the same figures), each kept in ``<out>/units`` as it finishes so that an
interrupted study resumes.

Units, each a module-level function of its arguments alone:

- :func:`~agents.fleet.study.fits.fit_unit`: one predictor fitted on freshly simulated
  training pads (not stored: refitting is cheaper than keeping a fitted MLP; only
  predictors with work left are fit), or a user's saved model loaded (``config.models``,
  :mod:`agents.fleet.study.fits`). With effects (``config.effects``) the pads wear on the
  truth's atlas, as a real history would, and the predictor is made on the nominal atlas
  (``NAME+effect``: on the truth's);
- :func:`heuristic_unit`: one heuristic tuned with Optuna on the tuning episodes with one
  predictor's RUL, then run on the evaluation episodes;
- :func:`reference_unit`: the perfect-information reference (the exact program of
  :mod:`agents.fleet.policies.reference`, small fleet only) on the evaluation episodes;
- :func:`agent_unit`: MaskablePPO trained with one predictor's RUL from one training seed
  (learning curve on separate episodes), then run on the evaluation episodes.

A graph, not rounds (:func:`study_graph`): each unit starts as soon as what it needs is in
(a predictor's heuristics its fit; the reference, whose spares are the oracle's best
heuristic's (s, S), the oracle's heuristics; an agent, warm-started from its predictor's
best heuristic when ``training.imitation_episodes`` > 0, that predictor's fit and
heuristics), so no stage waits for its slowest unit.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, replace
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from agents.fleet.evaluation.costs import run_episodes
from agents.fleet.evaluation.tuning import tune
from agents.fleet.learning.agent import FleetAgent, train_fleet_agent
from agents.fleet.policies.reference import ReferenceModel, ReferencePolicy, solve
from agents.fleet.policies.rules import FleetRuleParams
from agents.fleet.settings import TRAIN_SEED0, UNFITTED, FleetStudyConfig
from agents.fleet.study.build import (
    Fitted,
    episodes_dict,
    layout,
    rebuild_rule,
    rul_env,
    single_thread,
)
from agents.fleet.study.curve import LearningCurve, mean_cost
from agents.fleet.study.fits import fit_args as fit_args  # re-exported: its home before
from agents.fleet.study.fits import fit_job
from agents.fleet.study.fits import fit_unit as fit_unit
from agents.fleet.study.fits import study_fit as study_fit
from agents.fleet.study.planners import bound_unit, rollout_unit
from brake_env.model.atlas import Atlas
from brake_env.prognostics.registry import ORACLE
from brake_env.runner import Later, Runner, Unit
from brake_env.units import open_store

UNITS = "units"
# (label, total) -> a bar with update(n) and close(), e.g. tqdm's
Progress = Callable[[str, int], Any]


def study_keys(config: FleetStudyConfig) -> list[str]:
    """Every stored unit's key, in the order they run."""
    keys = [config.heuristic_key(p, h) for p in config.predictors for h in config.heuristics]
    if config.has_reference:
        keys.append(config.reference_key())
    keys += [config.agent_key(p, s, kind) for kind, p, s in config.agent_runs()]
    keys += [config.rollout_key(p, i) for p in config.rollout_predictors
             for i in range(len(config.rollout_chunks()))]  # fmt: skip
    if config.bound_iterations:
        keys.append(config.bound_key())
    return keys


def best_heuristic(config: FleetStudyConfig, heuristics: dict[str, Any], predictor: str) -> str:
    """The heuristic of least tuning cost with ``predictor``'s RUL (chosen on the tuning
    episodes, never on the evaluation ones)."""
    return min(
        config.heuristics,
        key=lambda h: heuristics[config.heuristic_key(predictor, h)]["tuning_cost"],
    )


def run_units(
    config: FleetStudyConfig,
    atlas: Atlas,
    out: Path,
    runner: Runner,
    progress: Progress | None = None,
    resume: bool = True,
    *,
    truth: Atlas | None = None,
) -> dict[str, Any]:
    """Every stored unit's result by key (:func:`study_keys`), run as a graph
    (:meth:`~brake_env.runner.Runner.run_graph`): a unit starts as soon as the units it
    needs are in, the heaviest first (:func:`weights`). ``atlas`` is the physics the
    predictors are made on, ``truth`` the one the fleet wears on (default ``atlas``; with
    ``config.effects``, :func:`~agents.fleet.study.build.truth_atlas`).

    Raises:
        ValueError: ``out/units`` holds units of other settings, or is in use.
    """
    keys = study_keys(config)
    truth = truth or atlas
    settings = {**config.settings(), "atlas": atlas.content_hash}
    if config.effects:
        settings["truth_atlas"] = truth.content_hash
    store = open_store(out / UNITS, settings, keys, "fleet-study") if resume else None
    kept = set(keys)
    bar = progress("fleet study units", len(keys)) if progress else None
    shared = runner.share(truth)
    nominal = shared if truth is atlas else runner.share(atlas)
    try:
        return runner.run_graph(
            study_graph(config, runner, shared, nominal), store,
            (lambda k, r: bar.update(1) if k in kept else None) if bar else None,
            kept=kept.__contains__,
        )  # fmt: skip
    finally:
        if bar is not None:
            bar.close()


def weights(config: FleetStudyConfig) -> dict[str, float]:
    """Each unit's expected cost in episode-shifts simulated (a unit of PPO training about
    3 of them), for the schedule only: no result depends on it."""
    n_eval = config.eval_episodes * config.shifts
    w: dict[str, float] = {
        config.heuristic_key(p, h): config.trials_of(h) * config.tune_episodes * config.shifts
        + n_eval for p in config.predictors for h in config.heuristics
    }  # fmt: skip
    w[config.reference_key()] = 3.0 * n_eval
    st = config.training
    cloned = st.imitation_episodes * (st.imitation_rounds + 1) * config.shifts
    for kind, p, s in config.agent_runs():
        w[config.agent_key(p, s, kind)] = 3.0 * (st.timesteps + cloned) + n_eval
    for p in config.rollout_predictors:  # ~100 env shifts of model work a decision
        for i, seeds in enumerate(config.rollout_chunks()):
            w[config.rollout_key(p, i)] = 100.0 * len(seeds) * config.shifts
    w[config.bound_key()] = 3.0 * n_eval
    return w


def study_graph(
    config: FleetStudyConfig, runner: Runner, atlas: Any, nominal: Any = None
) -> list[Unit | Later]:
    """The study's units on ``atlas`` (the truth), each after what it needs: the predictors'
    fits (not stored; made on ``nominal``, default ``atlas``); each predictor x heuristic (its
    fit); the reference (the oracle's heuristics; its spares the oracle's best one's (s, S));
    the agents (their predictor's fit and heuristics; cloned from the best one if asked)."""
    w = weights(config)
    shared: dict[str, Any] = {}  # each fitted predictor put in Ray's object store once

    def fitted(p: str, r: Mapping[str, Any]) -> Any:
        if p in UNFITTED:
            return None
        if p not in shared:
            shared[p] = runner.share(r[f"fit-{p}"])
        return shared[p]

    def fit_of(p: str) -> tuple[str, ...]:
        return () if p in UNFITTED else (f"fit-{p}",)

    def h_keys(p: str) -> tuple[str, ...]:
        return tuple(config.heuristic_key(p, h) for h in config.heuristics)

    def heuristic(r: Mapping[str, Any], p: str, h: str) -> Unit:
        k = config.heuristic_key(p, h)
        return Unit(k, heuristic_unit, (config, atlas, p, fitted(p, r), h), w[k])

    def reference(r: Mapping[str, Any]) -> Unit:
        best = best_heuristic(config, dict(r), ORACLE) if ORACLE in config.predictors else None
        k = config.reference_key()
        return Unit(k, reference_unit, (config, atlas, *_spares(config, dict(r), best)), w[k])

    def agent(r: Mapping[str, Any], kind: str, p: str, s: int) -> Unit:
        h = best_heuristic(config, dict(r), p)
        job = AgentRun(p, s, kind, (h, r[config.heuristic_key(p, h)]["params"]))
        k = config.agent_key(p, s, kind)
        return Unit(k, agent_unit, (config, atlas, fitted(p, r), job), w[k])

    # A fit weighs what waits on it, so that it starts before any ready unit lighter than
    # that (with weight 1 it ran last: two predictors' tuning waited for ten rollouts).
    def waiting(p: str) -> float:
        keys = [*h_keys(p), *(config.agent_key(q, s, kind) for kind, q, s in config.agent_runs()
                              if q == p)]  # fmt: skip
        if p in config.rollout_predictors:
            keys += [config.rollout_key(p, i) for i in range(len(config.rollout_chunks()))]
        return sum(w[k] for k in keys)

    nodes: list[Unit | Later] = [
        Unit(f"fit-{p}", *fit_job(config, p, nominal or atlas, atlas), waiting(p))
        for p in config.predictors if p not in UNFITTED
    ]  # fmt: skip
    nodes += [Later(config.heuristic_key(p, h), fit_of(p), partial(heuristic, p=p, h=h))
              for p in config.predictors for h in config.heuristics]  # fmt: skip
    if config.has_reference:
        oracle = h_keys(ORACLE) if ORACLE in config.predictors else ()
        nodes.append(Later(config.reference_key(), oracle, reference))
    nodes += [Later(config.agent_key(p, s, kind), fit_of(p) + h_keys(p),
                    partial(agent, kind=kind, p=p, s=s))
              for kind, p, s in config.agent_runs()]  # fmt: skip
    return nodes + _planners(config, w, atlas, fitted, fit_of, h_keys)


def _planners(
    config: FleetStudyConfig, w: dict[str, float], atlas: Any, fitted: Any, fit_of: Any,
    h_keys: Any,
) -> list[Unit | Later]:  # fmt: skip
    """The bound (with the price-directed policy) and the rollout planner's chunks, each
    after its predictor's fit and heuristics (its base is the best of them)."""

    def rollout(r: Mapping[str, Any], p: str, i: int, seeds: list[int]) -> Unit:
        h = best_heuristic(config, dict(r), p)
        base = (h, r[config.heuristic_key(p, h)]["params"])
        k = config.rollout_key(p, i)
        return Unit(k, rollout_unit, (config, atlas, p, fitted(p, r), base, seeds), w[k])

    nodes: list[Unit | Later] = [
        Later(config.rollout_key(p, i), fit_of(p) + h_keys(p),
              partial(rollout, p=p, i=i, seeds=seeds))
        for p in config.rollout_predictors for i, seeds in enumerate(config.rollout_chunks())
    ]  # fmt: skip
    if config.bound_iterations:
        k = config.bound_key()
        nodes.append(Unit(k, bound_unit, (config, atlas), w[k]))
    return nodes


def _spares(config: FleetStudyConfig, results: dict[str, Any], best: str | None) -> tuple[int, int]:
    """The reference's reorder rule: the oracle's best heuristic's (s, S) (the rules' default
    when the oracle is not in the study)."""
    params = None if best is None else results[config.heuristic_key(ORACLE, best)]["params"]
    return rule_spares(config, best, params)


def rule_spares(
    config: FleetStudyConfig, policy: str | None, params: dict[str, Any] | None
) -> tuple[int, int]:
    """The (s, S) of a rule rebuilt from its name and parameters (the rules' default: None)."""
    if policy is None or params is None:
        p = FleetRuleParams()
        return p.s, p.S
    rule = rebuild_rule(config, policy, params)
    return int(rule.params.s), int(rule.params.S)


def heuristic_unit(
    config: FleetStudyConfig, atlas: Atlas, predictor: str, fitted: Fitted | None,
    heuristic: str,
) -> dict[str, Any]:  # fmt: skip
    """Tune ``heuristic`` on the tuning episodes with ``predictor``'s RUL, then run it on
    the evaluation episodes."""
    t0 = time.perf_counter()
    env = rul_env(config, atlas, predictor, fitted)
    tuned = tune(heuristic, env, layout(config), config.tune_seeds(),
                 config.trials_of(heuristic), sampler_seed=config.seed,
                 objective=config.objective)  # fmt: skip
    t1 = time.perf_counter()
    eps = run_episodes(env, tuned.rule, config.eval_seeds(), check_masks=True)
    return {
        "predictor": predictor, "policy": heuristic, "params": tuned.params,
        "tuning_cost": tuned.tuning_cost, "trials": tuned.trials,
        "best_so_far": np.array(tuned.best_so_far),
        "episodes": episodes_dict(eps),
        "seconds": {"tune": t1 - t0, "evaluate": time.perf_counter() - t1},
    }  # fmt: skip


def reference_policy(
    config: FleetStudyConfig, atlas: Atlas, s: int, S: int
) -> tuple[Any, ReferencePolicy]:
    """(the env on the truth, the perfect-information reference): the exact program with
    ``config.tail`` shifts beyond the episode, spares by (s, S)."""
    env = rul_env(config, atlas, ORACLE, None)
    model = ReferenceModel.build(config.fleet, atlas)
    return env, ReferencePolicy(env, model, solve(model, config.tail), s, S)


def reference_unit(config: FleetStudyConfig, atlas: Atlas, s: int, S: int) -> dict[str, Any]:
    """The perfect-information reference on the evaluation episodes, spares by (s, S)."""
    t0 = time.perf_counter()
    env, policy = reference_policy(config, atlas, s, S)
    model, solution = policy.model, policy.solution
    eps = run_episodes(env, policy, config.eval_seeds(), check_masks=True)
    predicted = [_predicted(env, model, solution, seed) for seed in config.eval_seeds()]
    return {"predictor": ORACLE, "policy": "perfect-information reference", "s": s, "S": S,
            "episodes": episodes_dict(eps), "predicted": np.array(predicted),
            "seconds": time.perf_counter() - t0}  # fmt: skip


def _predicted(env: Any, model: Any, solution: Any, seed: int) -> float:
    """The reference's own forecast of an episode's cost per vehicle-shift (its model's
    terms: no order nor holding cost), from the first pads' true state: its realised
    cost on those terms is checked against it."""
    env.reset(seed=seed)
    truth = env.unwrapped.truth()
    h = model.state(truth["volume_frac"], truth["wear_coeff"])
    c = model.config
    return solution.predicted(model, h) / (c.n_vehicles * c.episode_shifts)


@dataclass(frozen=True)
class AgentRun:
    """One agent of the study.

    Attributes:
        predictor: Whose RUL it acts on.
        seed: Training seed (its episodes from 30,000 + 100 seed).
        kind: ``central``: one policy decides the fleet, warm-started by cloning the
            teacher when ``training.imitation_episodes`` > 0; ``shared``: one policy shared
            by the vehicles (:mod:`agents.fleet.learning.shared`), cloned from the teacher's
            duties likewise, spares by the teacher's (s, S).
        teacher: The predictor's best tuned heuristic: (name, parameters).
    """

    predictor: str
    seed: int
    kind: str
    teacher: tuple[str, dict[str, Any]]


def agent_unit(
    config: FleetStudyConfig, atlas: Atlas, fitted: Fitted | None, run: AgentRun
) -> dict[str, Any]:
    """MaskablePPO trained with the predictor's RUL from the run's training seed; its
    learning curve and its costs on the evaluation episodes."""
    return single_thread(_agent, config, atlas, fitted, run)


def _agent(
    config: FleetStudyConfig, atlas: Atlas, fitted: Fitted | None, run: AgentRun
) -> dict[str, Any]:
    predictor, seed, kind, teacher = run.predictor, run.seed, run.kind, run.teacher
    # Here, not at the top: importing agents.fleet.learning.shared loads Stable-Baselines3.
    from agents.fleet.learning.shared import SharedFleetAgent, train_shared_agent

    t0 = time.perf_counter()
    settings = replace(config.training, seed=TRAIN_SEED0 + 100 * seed)
    curve_env = rul_env(config, atlas, predictor, fitted)
    lay, rule = layout(config), rebuild_rule(config, *teacher)
    s, S = int(rule.params.s), int(rule.params.S)

    def make_env() -> Any:
        return rul_env(config, atlas, predictor, fitted)

    clone = rule if settings.imitation_episodes > 0 else None
    if kind == "shared":  # SB3 counts a sample per vehicle; the curve counts shifts
        curve = LearningCurve(config.curve_every, lambda m, mean, var: mean_cost(
            curve_env, SharedFleetAgent(m, lay, mean, var, s=s, S=S), config),
            lay.n_vehicles)  # fmt: skip
        agent: Any = train_shared_agent(
            make_env, lay, settings, s=s, S=S, callback=curve.callback(), teacher=clone
        )
    else:
        reorder = settings.reorder
        curve = LearningCurve(config.curve_every, lambda m, mean, var: mean_cost(
            curve_env, FleetAgent(m, lay, mean, var, reorder=reorder), config))  # fmt: skip
        agent = train_fleet_agent(make_env, lay, settings, callback=curve.callback(), teacher=clone)
    train_s = time.perf_counter() - t0
    eps = run_episodes(rul_env(config, atlas, predictor, fitted), agent, config.eval_seeds(),
                       check_masks=True)  # fmt: skip
    return {
        "predictor": predictor, "policy": "MaskablePPO", "kind": kind, "seed": seed,
        "teacher": teacher[0] if settings.imitation_episodes else None,
        "spares": [s, S],
        "imitation": _imitation(agent),
        "curve": {"timesteps": np.array([p[0] for p in curve.points], dtype=float),
                  "cost": np.array([p[1] for p in curve.points], dtype=float)},
        "episodes": episodes_dict(eps),
        "seconds": {"train": train_s, "evaluate": time.perf_counter() - t0 - train_s},
    }  # fmt: skip


def _imitation(agent: Any) -> dict[str, Any]:
    """How the cloning went (agreement with the teacher, seconds), if there was one."""
    done = getattr(agent, "imitation", None)
    return asdict(done) if done is not None else {}
