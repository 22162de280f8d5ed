"""Score a new RUL predictor on a suite (``brakewear fleet-score --predictor MODULE:FACTORY``):
the suite's rule family tuned on the dev side with its RUL, run on the test split, paired
with the shipped baselines (the rules tuned the same way on the shipped predictors' RUL).

The protocol is the shipped rules' own, so that the predictor is the only difference:
``FACTORY(atlas, seed)`` makes the unfitted predictor (the signature of the
``brakewear.predictors`` entry points, e.g. ``twin.twin:make_twin``), fitted on the suite's
``n_train_runs`` simulated run-to-failure pads (its seed); the rule family the shipped rules
were chosen from (``best combination``) tuned with Optuna on the suite's tuning episodes
with the shipped file's budget (``trials_best``) and sampler seed, then run on the test
episodes. With the registry's own factory of a shipped predictor it gives that predictor's
shipped per-episode figures.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from agents.fleet.benchmark.score import compare, load_factory
from agents.fleet.benchmark.suite import Suite
from agents.fleet.evaluation.costs import run_episodes
from agents.fleet.evaluation.tuning import tune
from agents.fleet.study.build import layout
from brake_env.data.datasets import DatasetSpec, make_dataset
from brake_env.env.fleet.family import make_env
from brake_env.env.fleet.route_rul import ROUTE_NAMES
from brake_env.env.fleet.wrappers import FleetRULObservation
from brake_env.model.atlas import Atlas
from brake_env.model.regime import WearRegime

FAMILY = "best combination"  # the rule family every shipped rule baseline was chosen from
DEFAULT_TRIALS = 45  # fleet-baselines' --trials-best, where no baselines are shipped


def fit_new(spec: str, atlas: Atlas, n_train_runs: int, seed: int) -> Any:
    """``FACTORY(atlas, seed)`` fitted on the suite's simulated training pads.

    Raises:
        ValueError: The factory cannot be loaded, or does not give a predictor (named).
    """
    try:
        factory: Any = load_factory(spec)  # FACTORY(atlas, seed), not a policy's FACTORY(env)
    except ValueError as e:  # its message names --policy, the option it usually reads
        raise ValueError(str(e).replace("--policy", "--predictor", 1)) from None
    pred = factory(atlas, seed)
    if not callable(getattr(pred, "fit", None)) or not callable(getattr(pred, "update", None)):
        got = type(pred).__name__
        raise ValueError(f"--predictor {spec}: FACTORY(atlas, seed) gave {got}, not a RUL"
                         " predictor (fit, reset, update)")  # fmt: skip
    data = DatasetSpec(n_train=n_train_runs, n_id=0, n_ood_slow=0, n_ood_fast=0,
                       wear=WearRegime())  # fmt: skip
    return pred.fit(make_dataset(atlas, data, seed).logs["train"])


def score_predictor(
    suite: Suite, spec: str, atlas: Atlas, *, shipped: dict[str, Any] | None,
    episodes_from: int | None = None, episodes: int | None = None, trials: int | None = None,
) -> dict[str, Any]:  # fmt: skip
    """``score.json``'s content for a new predictor (module docstring)."""
    config = suite.study_config("test", episodes_from)
    if episodes is not None:
        if not 2 <= episodes <= config.eval_episodes:
            raise ValueError(f"--episodes must be in [2, {config.eval_episodes}], got {episodes}")
        config = replace(config, eval_episodes=episodes)
    budget = trials or int(((shipped or {}).get("config") or {}).get("trials_best", DEFAULT_TRIALS))
    fitted = fit_new(spec, atlas, config.n_train_runs, config.seed)
    env = FleetRULObservation(make_env(config.fleet, atlas), fitted,
                              fields=("rul_mean",), routes=ROUTE_NAMES, atlas=atlas)  # fmt: skip
    tuned = tune(FAMILY, env, layout(config), config.tune_seeds(), budget,
                 sampler_seed=config.seed, objective=config.objective)  # fmt: skip
    seeds = config.eval_seeds()
    eps = run_episodes(env, tuned.rule, seeds, check_masks=True)
    net = [e.net for e in eps]
    out: dict[str, Any] = {
        "policy": f"{FAMILY} tuned on {spec}'s RUL", "predictor": spec, "params": tuned.params,
        "trials": budget, "tuning_net": tuned.tuning_cost, "suite": suite.name,
        "suite_digest": suite.digest, "objective": suite.objective, "observe": spec,
        "net": float(np.mean(net)), "cost": float(np.mean([e.per_vehicle_shift for e in eps])),
        "episodes": {"seed": seeds, "net": net, "cost": [e.per_vehicle_shift for e in eps]},
    }  # fmt: skip
    out.update(compare(seeds, net, shipped))
    return out
