"""``brakewear train``: train an agent, draw its learning curve and set it against the tuned
rules and the oracle on held-out pads (the cost study's machinery on one predictor)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING, Any

from agents.compare import CompareConfig, fit_predictors, id_life, tune
from agents.pad_study import PadDraws
from agents.policies import PolicyId
from agents.ranking import rank_policies
from agents.report import cost_rows
from agents.results import RatioResult
from agents.workers import Workers
from brake_env.cli.common import load_atlas, wear_regime
from brake_env.env.config import CostWeights, EnvConfig
from brake_env.output import table, write_json

if TYPE_CHECKING:
    from agents.train import TrainResult


def train_and_report(
    args: argparse.Namespace, env_kwargs: dict[str, Any], progress: Any
) -> dict[str, Any]:
    """Fit, collect the curve's and the held-out pads, train, evaluate; write
    ``evaluation.json`` and ``figures/learning_curve.png``; print the table."""
    from agents.hyperparameters import load_hyperparams
    from agents.learned import agent_outcomes
    from agents.plots import plot_learning_curve
    from agents.train import TrainedAgent, agent_fields, train_agent

    atlas = load_atlas(args)
    names = tuple(dict.fromkeys((args.predictor, "oracle")))
    print(f"fitting {', '.join(names)} on {args.n_train_runs} simulated training pads")
    fitted, _ = fit_predictors(names, atlas, args.seed, args.n_train_runs, wear_regime(args))
    env_config = EnvConfig.from_kwargs(**env_kwargs)
    draws = [
        PadDraws.stratified(env_config.pad_regime, n, [args.seed, key])
        for n, key in ((args.curve_pads, 3), (args.eval_pads, 4))
    ]
    hp = load_hyperparams(args.predictor, args.algo, args.hyperparams) if args.hyperparams else None
    # One worker simulates the held-out pads while this process trains.
    with Workers(args.workers) as workers:
        curve_pads = workers.collect(
            draws[0], atlas, env_config, fitted, progress("curve pads", len(draws[0]))
        )
        held_later = workers.collect_later(draws[1], atlas, env_config, fitted)
        res = train_agent(
            fitted[args.predictor],
            atlas,
            args.out,
            algo=args.algo,
            timesteps=args.timesteps,
            seed=args.seed,
            env_kwargs=env_kwargs,
            hyperparams=hp,
            curve_pads=curve_pads,
            progress_bar=not args.quiet,
        )
        held_out = held_later(progress("held-out pads", len(draws[1])))
    config = CompareConfig(
        predictors=(args.predictor,),
        agent_predictors=(),
        min_tune_pads=1,
        **{k: env_kwargs[k] for k in ("regime", "decision_interval", "episode_events")},
        wear=wear_regime(args),
    )
    tuning = tune(config, curve_pads, id_life(config, atlas))
    agent = PolicyId("agent", args.predictor, algo=args.algo)
    fields = agent_fields(fitted[args.predictor])
    trained = TrainedAgent(res.out_dir)
    outs = {agent: agent_outcomes(trained, held_out, fields, config.episode_events)}
    ranked = rank_policies(config, held_out, tuning, outs, CostWeights().failure_to_planned)
    out = Path(args.out)
    refs = {
        f"{p.label} (tuned on the curve's pads; held-out)": row.ratio_to_oracle.point
        for p, row in ranked.policies.items()
        if p.kind in ("threshold", "lower-threshold")
    }
    plot_learning_curve({agent.label: res.curve}, out / "figures" / "learning_curve.png", refs)
    return _write(out, res, len(curve_pads), len(held_out), ranked)


def _write(
    out: Path, res: TrainResult, n_curve: int, n_held: int, ranked: RatioResult
) -> dict[str, Any]:
    """``evaluation.json`` and the printed table."""
    summary = {
        "train_seconds": res.seconds,
        "timesteps": res.timesteps,
        "best_step": res.best_step,
        "pads": {"curve": n_curve, "held_out": n_held},
        "learning_curve": res.curve,
        **ranked.to_dict(),
    }
    write_json(summary, out / "evaluation.json")
    print(table(cost_rows(summary)))
    print(
        f"trained in {res.seconds:.0f} s (kept the agent of step {res.best_step:,});"
        f" wrote {out}/model.zip, vecnormalize.pkl, obs_normalization.npz, train.json,"
        " learning_curve.json, evaluation.json, figures/learning_curve.png, tb/"
    )
    return summary
