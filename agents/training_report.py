"""``brakewear train``: train an agent, draw its learning curve and set it against the tuned
rules and the oracle on held-out pads (the cost study's machinery on one predictor: its pads
and the agent are units of the runner of ``--workers``/``--ray``, kept in ``out/units`` so
that an interrupted run resumes)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING, Any

from agents.compare import CompareConfig, fit_predictors, id_life, tune
from agents.pad_study import PadDraws, PadSet
from agents.policies.rules import PolicyId
from agents.ranking import rank_policies
from agents.report import cost_rows
from agents.results import RatioResult
from agents.units import (
    UNITS,
    agent_key,
    agent_unit,
    join_pads,
    open_store,
    pad_chunks,
    pad_key,
    pad_progress,
    pad_units,
    write_trained,
)
from brake_env.cli.common import load_atlas, make_runner, wear_regime
from brake_env.env.config import CostWeights, EnvConfig
from brake_env.output import table, write_json

if TYPE_CHECKING:
    from agents.train import TrainResult
    from brake_env.model.atlas import Atlas
    from brake_env.prognostics.protocol import Predictor

STAGES = {"curve": 3, "held-out": 4}  # seed keys of the curve's and the held-out pads


def train_and_report(
    args: argparse.Namespace, env_kwargs: dict[str, Any], progress: Any
) -> dict[str, Any]:
    """Fit, collect the curve's and the held-out pads, train, evaluate; write
    ``evaluation.json`` and ``figures/learning_curve.png``; print the table."""
    from agents.learned import agent_outcomes
    from agents.plots import plot_learning_curve
    from agents.train import TrainedAgent, agent_fields

    atlas = load_atlas(args)
    units = _TrainUnits(args, env_kwargs, atlas)
    names = tuple(dict.fromkeys((args.predictor, "oracle")))
    print(f"fitting {', '.join(names)} on {args.n_train_runs} simulated training pads")
    fitted, _ = fit_predictors(names, atlas, args.seed, args.n_train_runs, wear_regime(args))
    curve_pads, held_out, res = units.run(atlas, fitted, progress)
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


class _TrainUnits:
    """The units of ``brakewear train``: the curve's pads; then the agent, trained while the
    held-out pads are simulated (on the runner of ``--workers``/``--ray``), finished units
    kept in ``out/units``. The store is opened (and other settings refused) first."""

    def __init__(self, args: argparse.Namespace, env_kwargs: dict[str, Any], atlas: Atlas):
        from agents.hyperparameters import load_hyperparams

        self.args, self.env_kwargs = args, env_kwargs
        self.env_config = EnvConfig.from_kwargs(**env_kwargs)
        per_label = {"curve": args.curve_pads, "held-out": args.eval_pads}
        self.draws = {
            s: PadDraws.stratified(self.env_config.pad_regime, per_label[s], [args.seed, key])
            for s, key in STAGES.items()
        }
        self.hp = load_hyperparams(args.predictor, args.algo, args.hyperparams)
        settings = {
            **{k: getattr(args, k) for k in ("seed", "predictor", "algo", "timesteps")},
            **{k: getattr(args, k) for k in ("n_train_runs", "curve_pads", "eval_pads")},
            "env_kwargs": env_kwargs,
            "hyperparams": self.hp,
            "atlas": atlas.content_hash,
        }
        keys = [
            pad_key(s, i) for s, d in self.draws.items() for i in range(len(pad_chunks(len(d))))
        ]
        self.out = Path(args.out)
        keys = [*keys, agent_key(args.predictor)]
        self.store = open_store(self.out / UNITS, settings, keys, "train")

    def run(
        self, atlas: Atlas, fitted: dict[str, Predictor], progress: Any
    ) -> tuple[PadSet, PadSet, TrainResult]:
        """The curve's pads, the held-out pads and the agent, written to ``out``."""
        args, draws, store = self.args, self.draws, self.store
        with make_runner(args) as runner:
            atlas_ref, used = runner.share(atlas), runner.share(fitted)

            def bar(stage: str) -> Any:
                return pad_progress(progress, stage, f"{stage} pads", len(draws[stage]))

            units = {s: pad_units(s, draws[s], atlas_ref, self.env_config, used) for s in draws}
            curve = runner.run(units["curve"], store, bar("curve"))
            curve_pads = join_pads("curve", draws["curve"], curve)
            train = agent_unit(
                args.predictor, used, atlas_ref, runner.share(curve_pads), args.algo,
                args.timesteps, args.seed, self.env_kwargs, self.hp,
                not args.quiet and not runner.on_ray,
            )  # fmt: skip
            done = runner.start([train, *units["held-out"]], store)(bar("held-out"))
        held_out = join_pads("held-out", draws["held-out"], done)
        return curve_pads, held_out, write_trained(done[train.key], self.out)


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
