"""Train a PPO agent on the digital twin's RUL estimates and compare it with rule-based
policies and the oracle by the maintenance cost they lead to.

Run: ``python examples/train_and_compare.py [OUT_DIR]`` (a few minutes on 2 cores). Prints
the cost table and writes ``costs.json`` and the figures to OUT_DIR (default
out/example_compare). ``brakewear compare`` is the same with every predictor and a larger
budget.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from agents.cli import compare_and_report
from agents.compare import CompareConfig
from agents.hyperparameters import load_hyperparams
from brake_env.model.atlas import cached_atlas
from brake_env.model.regime import WearRegime
from brake_env.model.wear import WearModel


def main(
    out_dir: str = "out/example_compare",
    timesteps: int = 20_000,
    k_mean: float = 2e-6,
    episode_events: int = 300_000,
    pad_pool: int = 16,
    predictors: tuple[str, ...] = ("none", "physics", "twin", "oracle"),
    agent: str = "twin",
) -> dict[str, Any]:
    life = float(WearModel.from_atlas(cached_atlas()).life(k_mean))  # expected pad life
    config = CompareConfig(
        predictors=predictors,
        agent_predictors=(agent,),
        timesteps=timesteps,
        episode_events=episode_events,
        tune_seeds=2,
        eval_seeds=4,
        thresholds=(0, 1, 2, 4, 8, 16, 32, 64),
        fixed_intervals=tuple(int(f * life) for f in (0.4, 0.5, 0.6, 0.7, 0.8)),
        wear=WearRegime(k_mean, k_mean / 10),
    )
    # Train on a small pool of pads: each is run through the twin once (~3 s a pad).
    hp = {agent: {**load_hyperparams(agent, "ppo"), "pad_pool": pad_pool}}
    args = argparse.Namespace(seed=0, quiet=False, preset="hot-duty", cache_dir=None, atlas=None)
    return compare_and_report(config, args, Path(out_dir), hp)


if __name__ == "__main__":
    main(*sys.argv[1:2])
