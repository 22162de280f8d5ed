"""``brakewear fleet-study`` (its parser is :mod:`agents.fleet.commands.parser`) and the
demo's fleet stage: the settings from the command line, the study run and reported."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from tqdm import tqdm

from agents.fleet.policies.lagrangian import BoundModel
from agents.fleet.settings import FleetStudyConfig, FleetTraining
from agents.fleet.study.build import truth_atlas
from agents.fleet.study.fits import check_models
from agents.fleet.study.run import report, run_fleet_study
from brake_env.cli.common import load_atlas, make_runner
from brake_env.cli.demo import DemoContext, demo_runner
from brake_env.model.atlas import Atlas
from brake_env.model.effects import canonical_effects
from brake_env.model.params import BrakeModel
from brake_env.runner import Runner


def cmd_fleet_study(args: argparse.Namespace) -> dict[str, Any]:
    config = config_from_args(args)
    atlas = load_atlas(args)
    truth = truth_atlas(config, atlas, args.cache_dir)  # with --effect: built on a cache miss
    check_models(config, atlas, truth)  # --model fitted on other physics: refused here
    if config.bound_iterations:  # a bound too large for memory, refused before any unit runs
        BoundModel.build(config.fleet, truth, 20, 1.0, True)  # the relaxed slack is < 1 shift
    with make_runner(args) as runner:
        return study_and_report(config, atlas, Path(args.out), runner, quiet=args.quiet,
                                truth=truth)  # fmt: skip


def demo_stage(ctx: DemoContext) -> tuple[dict[str, Any], str]:
    """The fleet study on the small fleet at a budget the demo can afford: no prognostics,
    the twin and the oracle, two heuristics tuned on few trials, the reference, 120-shift
    episodes; no agent (a MaskablePPO seed trains in 400-450 s on a quiet 2-core machine;
    the report says so)."""
    args, d = ctx.args, DEMO_FLEET
    config = FleetStudyConfig(
        predictors=DEMO_FLEET_PREDICTORS, heuristics=d["heuristics"], shifts=d["shifts"],
        trials=d["trials"], trials_best=d["trials"], tune_episodes=2,
        eval_episodes=d["episodes"], n_train_runs=max(3, args.n_train), seed=args.seed,
    )  # fmt: skip
    out = ctx.out / "fleet"
    with demo_runner(args) as runner:
        summary = study_and_report(config, load_atlas(args), out, runner, quiet=args.quiet,
                                   resume=False)  # fmt: skip
    figs = "\n".join(f"![{Path(f).stem}](fleet/{f})" for f in summary["figures"])
    section = f"""## The fleet study (BrakeWearFleet-v2, `small` fleet)

The benchmark's env (`BrakeWearFleet-v2`) on its shipped `small` fleet (2 vehicles), at a
small budget: the predictors {", ".join(DEMO_FLEET_PREDICTORS)} only (the comparison
above has every one; `brakewear fleet-study` runs them all), episodes cut to {d["shifts"]}
shifts (the benchmark's: 365), {", ".join(d["heuristics"])} tuned with {d["trials"]}
Optuna trials on 2 tuning episodes, {d["episodes"]} evaluation episodes, no best
combination and no agent (a MaskablePPO training seed takes 400-450 s on a quiet 2-core
machine, the study trains 10). At this
budget the heuristics are under-tuned and the intervals wide: the ranking below is what this
budget shows, not the study's result (docs/results/fleet.md has the full run and its
command). On episodes this short a tuned heuristic can come out below the reference (a
ratio under 1): the reference plans 200 shifts past the episode's end, the heuristics
are tuned on the episode alone.

{report(summary, markdown=True)}

{_separated(summary["ranking"])}

{figs}
"""
    return summary, section


def _separated(rk: dict[str, Any]) -> str:
    """Which predictors this budget ranks against the head (the twin): those whose paired
    interval of the difference excludes 0; the others are not ranked."""
    head, apart, tied = rk["head"], [], []
    if not rk["head_minus"]:  # one predictor: nothing to rank
        return ""
    for p, v in rk["head_minus"].items():
        d = v["difference"]
        if d["high"] < 0:
            apart.append(f"{head} below {p}")
        elif d["low"] > 0:
            apart.append(f"{head} above {p}")
        else:
            tied.append(p)
    said = [f"Separated at this budget (95% interval of the difference excludes 0): "
            f"{'; '.join(apart)}." if apart else "No predictor is separated from the "
            f"{head} at this budget (every interval of the difference includes 0)."]  # fmt: skip
    if tied and apart:
        said.append(f"Not ranked against the {head} at this budget: {', '.join(tied)}.")
    return " ".join(said)


# The demo's fleet study (docs/results/fleet.md has the full budget): no prognostics, the
# twin and the oracle, the span the other predictors fall in (each one fitted and tuned
# would cost the demo about as much as the rest of the stage).
DEMO_FLEET_PREDICTORS = ("none", "twin", "oracle")
DEMO_FLEET: dict[str, Any] = {
    "heuristics": ("threshold", "(n, N)"), "shifts": 120, "trials": 4, "episodes": 8,
}  # fmt: skip


def config_from_args(args: argparse.Namespace) -> FleetStudyConfig:
    training = FleetTraining(
        timesteps=args.timesteps, n_envs=args.n_envs, normalize_reward=not args.raw_reward,
        imitation_episodes=args.imitate, imitation_epochs=args.imitation_epochs,
        imitation_lr=args.imitation_lr, imitation_rounds=args.dagger,
        learning_rate=args.learning_rate, ent_coef=args.ent_coef, clip_range=args.clip_range,
        reorder=None if args.reorder is None else (args.reorder[0], args.reorder[1]),
    )  # fmt: skip
    return FleetStudyConfig(
        size=args.size, shifts=args.shifts, predictors=args.predictors,
        heuristics=tuple(args.heuristics), trials=args.trials, trials_best=args.trials_best,
        tune_episodes=args.tune_episodes, eval_episodes=args.eval_episodes,
        episodes_from=args.episodes_from,
        n_train_runs=args.n_train_runs, agent_predictors=args.agents,
        agent_seeds=args.agent_seeds, shared_seeds=args.shared_seeds, training=training,
        curve_episodes=args.curve_episodes, curve_every=args.curve_every, tail=args.tail,
        seed=args.seed, rollout_predictors=args.rollout, rollout_horizon=args.rollout_horizon,
        rollout_samples=args.rollout_samples, rollout_chunk=args.rollout_chunk,
        bound_iterations=args.bound_iterations, objective=args.objective,
        effects=_effects(args), models=tuple(getattr(args, "model", None) or ()),
    )  # fmt: skip


def _effects(args: argparse.Namespace) -> tuple[str, ...]:
    """``--effect``'s texts, canonical (an unknown one, or one an atlas cannot hold, refused
    by name before any work)."""
    texts = getattr(args, "effect", None) or []
    return canonical_effects(texts, BrakeModel.preset(args.preset)) if texts else ()


def study_and_report(
    config: FleetStudyConfig, atlas: Atlas, out: Path, runner: Runner, quiet: bool = False,
    resume: bool = True, *, truth: Atlas | None = None,
) -> dict[str, Any]:  # fmt: skip
    def progress(label: str, total: int) -> Any:
        return tqdm(total=total, desc=label, unit="unit", disable=quiet)

    summary = run_fleet_study(config, atlas, out, runner, progress=progress, resume=resume,
                              truth=truth)  # fmt: skip
    print(report(summary))
    print(f"wrote {out / 'costs.json'}, " + ", ".join(summary["figures"]))
    return summary
