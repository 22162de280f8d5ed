"""Train a PPO agent on the digital twin's RUL estimates and compare it with rule-based
policies and the oracle by the maintenance cost they lead to.

Run: ``python examples/train_and_compare.py [OUT_DIR]`` (a few minutes on 2 cores). Every
policy is evaluated on the same held-out pads, with paired bootstrap intervals over pads;
prints the cost table and writes ``costs.json`` and the figures to OUT_DIR
(default out/example_compare). Fast-wearing pads (K five times the paper's) keep it short;
``brakewear compare`` is the same with every predictor at the full budget
(docs/results/single-pad.md).
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

from agents.commands.cli import compare_and_report
from agents.study.config import StudyConfig
from brake_env.env.config import EnvConfig
from brake_env.model.atlas import AtlasSpec, cached_atlas
from brake_env.model.params import BrakeModel
from brake_env.model.regime import WearRegime
from brake_env.runner import Runner, ray_available


def main(
    out_dir: str = "out/example_compare",
    timesteps: int = 100_000,
    k_mean: float = 1e-5,
    tune_pads: int = 40,
    eval_pads: int = 100,
    predictors: tuple[str, ...] = ("none", "physics", "twin", "oracle"),
    agent: str = "twin",
    workers: int = 0,
) -> dict[str, Any]:
    """Fit, tune, train and evaluate; return the content of ``costs.json``.

    Args:
        out_dir: Where ``costs.json``, the figures and the agent go.
        timesteps: PPO's training steps (fewer than 50,000 train no agent: the table says
            the budget is too small).
        k_mean: Mean wear coefficient of new pads (a pad lasts ~2.4e4 events at 1e-5) [-].
        tune_pads, eval_pads: Tuning and held-out pads of each wear-regime label.
        predictors: Predictors whose threshold policies are tuned.
        agent: The predictor PPO acts on.
        workers: CPUs of a local Ray that runs the pads and the training beside each other
            (0: all in this process; docs/cluster.md).
    """
    config = StudyConfig(
        env=EnvConfig.from_kwargs(
            regime="mixed",
            decision_interval=100,  # ~240 decisions a pad life, as at the paper's K with 500
            episode_events=100_000,
            **WearRegime(k_mean, k_mean / 10).env_kwargs(),
        ),
        predictors=predictors,
        agent_predictors=(agent,),
        timesteps=timesteps,
        min_timesteps=50_000,
        tune_pads=tune_pads,
        eval_pads=eval_pads,
    )
    atlas = cached_atlas(AtlasSpec(model=BrakeModel.preset("hot-duty")))
    with Runner(workers) if workers and ray_available() else Runner(0) as runner:
        # resume=False: an example is rerun with other parameters; nothing to pick up from.
        return compare_and_report(config, atlas, Path(out_dir), 0, runner, resume=False)


if __name__ == "__main__":
    main(*sys.argv[1:2])
