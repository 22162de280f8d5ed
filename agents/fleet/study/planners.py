"""The fleet study's planners (issue 30): the Lagrangian lower bound with the price-directed
policy (:func:`bound_unit`), and the rollout planner on a predictor's best tuned heuristic
(:func:`rollout_unit`, ``rollout_chunk`` evaluation episodes a unit so that Ray spreads
them), each a unit of :func:`agents.fleet.study.units.study_graph`.

The bound is on the cost net of the pad life left at the episode's end
(:attr:`~agents.fleet.evaluation.costs.EpisodeCost.net`; its program credits that life as
the policies' figure does): without the credit it would plan to run the pads down for an
episode that stops, which no policy of a mine that goes on does. The bound's prices are
searched once for the mean of the evaluation episodes' starting
states (a bound at any prices is valid), then each episode's bound is evaluated at its own
start: a lower bound on the expected cost on that episode of every non-anticipative policy
(one that decides on what has happened so far, the pads' volumes and K included; not one
that reads the breakdowns or conditions the env draws ahead), its model a relaxation
(:meth:`BoundModel.relaxed`: a slack that 99% of pads' realised wear stays within; mild
wear by the pad's layer is an option, off: it did not move the bound). The price-directed
policy reads the env's truth (a reference, not deployable) and acts on the uncredited
program at the searched prices.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from agents.fleet.evaluation.costs import run_episodes
from agents.fleet.policies.lagrangian import BoundModel, bound, solve, start_counts
from agents.fleet.policies.lagrangian_search import SearchResult, search
from agents.fleet.policies.planning import PlanningModel
from agents.fleet.policies.priced import PricedPolicy
from agents.fleet.policies.rollout import RolloutPolicy, program_value
from agents.fleet.policies.view import FleetLayout
from agents.fleet.settings import FleetStudyConfig
from agents.fleet.study.build import Fitted, episodes_dict, rebuild_rule, rul_env
from brake_env.env.fleet.family import make_env
from brake_env.model.atlas import Atlas
from brake_env.prognostics.registry import ORACLE

BOUND = "Lagrangian bound"
PRICED = "price-directed (truth)"
INTERVAL = ("rul_mean", "rul_lower", "rul_upper")


def study_bound(
    config: FleetStudyConfig, atlas: Atlas, iterations: int, orders: bool = True
) -> tuple[SearchResult, list[float]]:
    """The price search for the evaluation episodes' mean start (``iterations`` steps), and
    each episode's bound at the best prices [per vehicle-shift]. With ``orders`` (the
    study's bound) each service beyond the initial stock pays its least share of an order
    (:mod:`agents.fleet.policies.lagrangian`): still a relaxation, and 0.039 higher on the
    default suite's dev episodes (1.5402 against 1.5014;
    ``benchmarks/analysis/fleet_bound_relaxation.py --models relaxed,relaxed+orders``)."""
    cfg = config.fleet
    env = make_env(cfg, atlas)
    model = BoundModel.relaxed(cfg, atlas, credit=True, orders=orders)
    states, excess = [], []
    for seed in config.eval_seeds():
        env.reset(seed=seed)
        truth = env.truth()
        states.append(model.state(truth["volume_frac"], truth["wear_coeff"]))
        excess.append(model.excess(truth["volume_frac"], truth["wear_coeff"]))
    result = search(model, start_counts(model, np.array(states)), iterations)
    per = cfg.n_vehicles * cfg.episode_shifts
    bounds = [bound(model, result.program, result.prices, start_counts(model, s), x) / per
              for s, x in zip(states, excess, strict=True)]  # fmt: skip
    return result, bounds


def bound_unit(config: FleetStudyConfig, atlas: Atlas) -> dict[str, Any]:
    """The bound on each evaluation episode [per vehicle-shift], and the price-directed
    policy's episodes."""
    t0 = time.perf_counter()
    cfg = config.fleet
    result, bounds = study_bound(config, atlas, config.bound_iterations)
    per = cfg.n_vehicles * cfg.episode_shifts
    t1 = time.perf_counter()
    env, policy = priced_policy(config, atlas, result)
    eps = run_episodes(env, policy, config.eval_seeds(), check_masks=True)
    return {
        "bound": np.array(bounds), "zero_prices_bound": result.zero_bound / per,
        "iterations": result.iterations, "priced": episodes_dict(eps),
        "seconds": {"bound": t1 - t0, "priced": time.perf_counter() - t1},
    }  # fmt: skip


def priced_policy(
    config: FleetStudyConfig, atlas: Atlas, result: SearchResult | None = None
) -> tuple[Any, PricedPolicy]:
    """(the truth's env, the price-directed policy) at the prices of the bound's search on
    ``config``'s evaluation episodes (``result``, or searched here): the policy acts on the
    uncredited program at those prices (the credit's values make its services worse: 3.489
    against 2.852 on the default fleet's episodes 0-19)."""
    cfg = config.fleet
    if result is None:
        result, _ = study_bound(config, atlas, config.bound_iterations)
    plain = BoundModel.build(cfg, atlas)
    env = make_env(cfg, atlas)
    return env, PricedPolicy(env, plain, result.prices, solve(plain, result.prices))


def planner_fields(predictor: str) -> tuple[str, ...]:
    """The RUL fields the planner reads: the interval where the predictor has one."""
    return ("rul_mean",) if predictor == ORACLE else INTERVAL


def study_planner(config: FleetStudyConfig, atlas: Atlas, base: Any) -> RolloutPolicy:
    """The rollout planner on ``base`` with the study's horizon, samples and seed, its
    terminal value the per-vehicle programs' (:func:`~agents.fleet.policies.rollout.program_value`,
    as it was measured on the dev split); the linear value of pad life where the programs
    cannot be built (a wear regime other than ``id``)."""
    cfg = config.fleet
    terminal = program_value(cfg, atlas) if cfg.regime == "id" else None
    model = PlanningModel.build(cfg, atlas)
    return RolloutPolicy(base, model, config.rollout_horizon, config.rollout_samples,
                         config.planner_seed, terminal=terminal)  # fmt: skip


def rollout_unit(
    config: FleetStudyConfig, atlas: Atlas, predictor: str, fitted: Fitted | None,
    base: tuple[str, dict[str, Any]], seeds: list[int],
) -> dict[str, Any]:  # fmt: skip
    """The rollout planner on ``base`` (the predictor's best heuristic: name, parameters)
    on the evaluation episodes ``seeds``; with the decision time per shift."""
    fields = planner_fields(predictor)
    env = rul_env(config, atlas, predictor, fitted, fields)
    name, params = base
    rule = rebuild_rule(config, name, params, FleetLayout.of(config.fleet, fields=fields))
    policy = study_planner(config, atlas, rule)
    t0 = time.perf_counter()
    eps = run_episodes(env, policy, seeds, check_masks=True)
    seconds = time.perf_counter() - t0
    return {
        "predictor": predictor, "policy": policy.name, "base": name,
        "episodes": episodes_dict(eps), "seconds": seconds,
        "seconds_per_shift": seconds / sum(e.shifts for e in eps),
    }  # fmt: skip
