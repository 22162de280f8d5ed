"""``brakewear train``: train an agent, draw its learning curve and set it against the tuned
rules and the oracle on held-out pads (the cost study's machinery on one predictor: its pads
and the agent are units of the runner of ``--workers``/``--ray``, kept in ``out/units`` so
that an interrupted run resumes)."""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from agents.commands.plots import plot_learning_curve
from agents.commands.report import cost_rows
from agents.commands.units import (
    UNITS,
    AgentJob,
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
from agents.learning.curve import agent_outcomes
from agents.learning.train import TrainedAgent, TrainResult, agent_fields
from agents.policies.rules import PolicyId
from agents.study.config import StudyConfig
from agents.study.pads import PadDraws, PadSet
from agents.study.ranking import rank_policies
from agents.study.results import RatioResult
from agents.study.tuning import id_life, tune
from brake_env.env.config import EnvConfig
from brake_env.model.atlas import Atlas
from brake_env.output import table, write_json
from brake_env.prognostics.protocol import Predictor
from brake_env.prognostics.registry import fit_predictors
from brake_env.runner import Runner

STAGES = {"curve": 3, "held-out": 4}  # seed keys of the curve's and the held-out pads


@dataclass(frozen=True)
class TrainRun:
    """What ``brakewear train`` runs.

    Attributes:
        job: The agent to train (predictor, algorithm, steps, seed, env, hyperparameters).
        n_train_runs: Run-to-failure pads the predictors are fitted on.
        curve_pads: Learning-curve pads of each wear label (the rules are tuned on them).
        eval_pads: Held-out pads of each wear label.
        out: Output folder.
    """

    job: AgentJob
    n_train_runs: int
    curve_pads: int
    eval_pads: int
    out: Path

    @property
    def env(self) -> EnvConfig:
        return self.job.env


def train_and_report(run: TrainRun, atlas: Atlas, runner: Runner, progress: Any) -> dict[str, Any]:
    """Fit, collect the curve's and the held-out pads, train, evaluate; write
    ``evaluation.json`` and ``figures/learning_curve.png``; print the table."""
    job = run.job
    units = _TrainUnits(run, atlas)
    names = tuple(dict.fromkeys((job.predictor, "oracle")))
    print(f"fitting {', '.join(names)} on {run.n_train_runs} simulated training pads")
    fitted, _ = fit_predictors(names, atlas, job.seed, run.n_train_runs, run.env.wear)
    curve_pads, held_out, res = units.run(atlas, fitted, runner, progress)
    config = StudyConfig(env=run.env, predictors=(job.predictor,), agent_predictors=(),
                         min_tune_pads=1)  # fmt: skip
    tuning = tune(config, curve_pads, id_life(config, atlas))
    agent = PolicyId("agent", job.predictor, algo=job.algo)
    fields = agent_fields(fitted[job.predictor])
    trained = TrainedAgent(res.out_dir)
    outs = {agent: agent_outcomes(trained, job.predictor, held_out, fields, config.episode_events)}
    ranked = rank_policies(config, held_out, tuning, outs, config.costs.failure_to_planned)
    refs = {
        f"{p.label} (tuned on the curve's pads; held-out)": row.ratio_to_oracle.point
        for p, row in ranked.policies.items()
        if p.kind in ("threshold", "lower-threshold")
    }
    plot_learning_curve({agent.label: res.curve}, run.out / "figures" / "learning_curve.png", refs)
    return _write(run.out, res, len(curve_pads), len(held_out), ranked)


class _TrainUnits:
    """The units of ``brakewear train``: the curve's pads; then the agent, trained while the
    held-out pads are simulated, finished units kept in ``out/units``. The store is opened
    (and other settings refused) first."""

    def __init__(self, run: TrainRun, atlas: Atlas):
        self.run_ = run
        per_label = {"curve": run.curve_pads, "held-out": run.eval_pads}
        self.draws = {
            s: PadDraws.stratified(run.env.pad_regime, per_label[s], [run.job.seed, key])
            for s, key in STAGES.items()
        }
        job = run.job
        settings = {
            "seed": job.seed, "predictor": job.predictor, "algo": job.algo,
            "timesteps": job.timesteps, "n_train_runs": run.n_train_runs,
            "curve_pads": run.curve_pads, "eval_pads": run.eval_pads,
            "env_kwargs": run.env.to_kwargs(), "hyperparams": job.hyperparams,
            "atlas": atlas.content_hash,
        }  # fmt: skip
        keys = [
            pad_key(s, i) for s, d in self.draws.items() for i in range(len(pad_chunks(len(d))))
        ]
        keys = [*keys, agent_key(job.predictor)]
        self.store = open_store(run.out / UNITS, settings, keys, "train")

    def run(
        self, atlas: Atlas, fitted: dict[str, Predictor], runner: Runner, progress: Any
    ) -> tuple[PadSet, PadSet, TrainResult]:
        """The curve's pads, the held-out pads and the agent, written to ``out``."""
        draws, store, run = self.draws, self.store, self.run_
        atlas_ref, used = runner.share(atlas), runner.share(fitted)

        def bar(stage: str) -> Any:
            return pad_progress(progress, stage, f"{stage} pads", len(draws[stage]))

        units = {s: pad_units(s, draws[s], atlas_ref, run.env, used) for s in draws}
        curve = runner.run(units["curve"], store, bar("curve"))
        curve_pads = join_pads("curve", draws["curve"], curve)
        job = run.job if not runner.on_ray else _quiet(run.job)
        train = agent_unit(job, used, atlas_ref, runner.share(curve_pads))
        done = runner.start([train, *units["held-out"]], store)(bar("held-out"))
        held_out = join_pads("held-out", draws["held-out"], done)
        return curve_pads, held_out, write_trained(done[train.key], run.out)


def _quiet(job: AgentJob) -> AgentJob:
    """``job`` without SB3's progress bar (a Ray worker's would interleave with ours)."""
    return replace(job, progress_bar=False)


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
