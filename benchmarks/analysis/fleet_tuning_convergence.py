"""Are the fleet's heuristics tuned hard enough? (issue 30: "tuned hard enough that more
trials no longer move them"). Tunes one heuristic with one predictor's RUL on the study's
tuning episodes for ``2 x --trials`` Optuna trials (TPE, seeded: its first ``--trials``
trials are the study's own run), prints the best tuning objective after each quarter, and
runs the rule tuned at ``--trials`` and at ``2 x --trials`` on the evaluation episodes
(paired interval of their difference).

Run: ``.venv/bin/python benchmarks/analysis/fleet_tuning_convergence.py [--predictor oracle]
[--trials 90] [--tune-episodes 3] [--objective cost]``
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from agents.fleet.evaluation.costs import evaluate, paired_interval
from agents.fleet.evaluation.tuning import tune
from agents.fleet.settings import OBJECTIVES, FleetStudyConfig
from agents.fleet.study.build import layout, rul_env
from agents.fleet.study.units import fit_unit
from brake_env.env.atlases import default_atlas
from brake_env.prognostics.registry import ORACLE


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--predictor", default=ORACLE)
    p.add_argument("--heuristic", default="best combination")
    p.add_argument("--trials", type=int, default=90)
    p.add_argument("--tune-episodes", type=int, default=3)
    p.add_argument("--eval-episodes", type=int, default=20)
    p.add_argument("--size", default="default", choices=("small", "default"))
    p.add_argument("--objective", default="cost", choices=OBJECTIVES, help="as fleet-study's")
    a = p.parse_args()
    config = FleetStudyConfig(
        size=a.size, predictors=(a.predictor,), tune_episodes=a.tune_episodes,
        eval_episodes=a.eval_episodes,
    )  # fmt: skip
    atlas = default_atlas()
    fitted = None if a.predictor == ORACLE else fit_unit(a.predictor, atlas, 0, 10)
    env = rul_env(config, atlas, a.predictor, fitted)
    t0 = time.perf_counter()
    rules = {}
    for n in (a.trials, 2 * a.trials):
        tuned = tune(a.heuristic, env, layout(config), config.tune_seeds(), n,
                     objective=a.objective)  # fmt: skip
        rules[n] = tuned.rule
        curve = np.array(tuned.best_so_far)
    quarters = [max(1, (2 * a.trials * q) // 4) for q in (1, 2, 3, 4)]
    print(f"{a.heuristic} with the {a.predictor}'s RUL ({a.size} fleet, {a.tune_episodes} tuning"
          f" episodes, {a.objective} cost): best tuning objective after "
          + ", ".join(f"{q} trials {curve[q - 1]:.4f}" for q in quarters)
          + f" ({time.perf_counter() - t0:.0f} s)")  # fmt: skip
    x, y = (evaluate(env, rules[n], config.eval_seeds(), objective=a.objective)
            for n in (a.trials, 2 * a.trials))  # fmt: skip
    print(f"on {a.eval_episodes} evaluation episodes: tuned with {a.trials} trials {x.mean():.4f},"
          f" with {2 * a.trials} {y.mean():.4f}; difference (2x minus 1x)"
          f" {paired_interval(y, x)}")  # fmt: skip


if __name__ == "__main__":
    main()
