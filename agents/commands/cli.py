"""``brakewear train`` and ``brakewear compare`` (registered as a plug-in of the CLI).

The ``brakewear`` parser loads this module to register the commands, so it imports only
what parsing needs; the training and the comparison (torch, SB3) are imported by the
commands that run them (README "Architecture"; ``brakewear --help`` stays fast).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

from tqdm import tqdm

from agents.commands.report import cost_rows, markdown_section, print_report, write_figures
from agents.commands.units import AgentJob
from agents.learning.hyperparameters import ALGOS, hyperparams_file, load_hyperparams, rl_zoo_file
from agents.study.config import StudyConfig
from brake_env.cli.common import (
    NONNEGATIVE,
    POSITIVE,
    add_common_args,
    add_runner_args,
    add_wear_args,
    int_at_least,
    load_atlas,
    make_runner,
    name_list,
    nonempty,
    wear_regime,
)
from brake_env.env.config import REGIMES, EnvConfig
from brake_env.output import table, write_json
from brake_env.prognostics.registry import predictor_names
from brake_env.runner import Runner, ray_available

if TYPE_CHECKING:
    from brake_env.cli.demo import DemoContext
    from brake_env.model.atlas import Atlas


_names = name_list(predictor_names)  # at least one
_agents = name_list(predictor_names, allow_empty=True)  # '' for no agent


def _env_args(sp: argparse.ArgumentParser) -> None:
    sp.add_argument("--regime", choices=REGIMES, default="mixed", help="wear regime of new pads")
    sp.add_argument("--decision-interval", type=int_at_least(1), default=500, help="events/step")
    sp.add_argument(
        "--episode-events", type=int_at_least(2), default=500_000, help="per training episode"
    )
    add_wear_args(sp)


def _env(
    args: argparse.Namespace, regime: Literal["id", "ood", "mixed"] | None = None
) -> EnvConfig:
    """BrakeWear-v0's settings from the options of :func:`_env_args` (the demo has only the
    wear options: the env's defaults in a ``regime``)."""
    wear = wear_regime(args)
    if regime is not None:
        return EnvConfig(
            regime=regime,
            k_mean=wear.k_mean,
            k_std=wear.k_std,
            ood_shift_sigma=wear.ood_shift_sigma,
        )
    return EnvConfig(
        regime=args.regime,
        decision_interval=args.decision_interval,
        episode_events=args.episode_events,
        k_mean=wear.k_mean,
        k_std=wear.k_std,
        ood_shift_sigma=wear.ood_shift_sigma,
    )


def _bar(quiet: bool) -> Any:
    """``progress(label, total)`` for the study: a tqdm bar per stage."""

    def progress(label: str, total: int) -> Any:
        return tqdm(total=total, desc=label, unit="pad", disable=quiet).update

    return progress


# ---------------------------------------------------------------------- train
def cmd_train(args: argparse.Namespace) -> dict[str, Any]:
    from agents.commands.train import TrainRun, train_and_report  # matplotlib, SB3

    hp = load_hyperparams(args.predictor, args.algo, args.hyperparams)
    job = AgentJob(args.predictor, args.algo, args.timesteps, args.seed, _env(args), hp,
                   progress_bar=not args.quiet)  # fmt: skip
    run = TrainRun(job, args.n_train_runs, args.curve_pads, args.eval_pads, Path(args.out))
    atlas = load_atlas(args)
    with make_runner(args) as runner:
        return train_and_report(run, atlas, runner, _bar(args.quiet))


# ---------------------------------------------------------------------- compare
def cmd_compare(args: argparse.Namespace) -> dict[str, Any]:
    config = StudyConfig(
        env=_env(args),
        predictors=args.predictors,
        agent_predictors=args.agents,
        algo=args.algo,
        timesteps=args.timesteps,
        n_train_runs=args.n_train_runs,
        tune_pads=args.tune_pads,
        eval_pads=args.eval_pads,
        n_resamples=args.resamples,
    )
    atlas = load_atlas(args)
    with make_runner(args) as runner:
        return compare_and_report(config, atlas, Path(args.out), args.seed, runner,
                                  quiet=args.quiet)  # fmt: skip


def compare_and_report(
    config: StudyConfig,
    atlas: Atlas,
    out: Path,
    seed: int,
    runner: Runner,
    *,
    quiet: bool = False,
    hyperparams: dict[str, dict[str, Any]] | None = None,
    resume: bool = True,
) -> dict[str, Any]:
    """Run the comparison with progress bars; write ``costs.json`` and the figures, print
    the table and the ranking under each cost ratio. Returns the content of ``costs.json``.

    ``resume``: keep the units in ``out/units`` and reuse those a run with the same settings
    finished."""
    from agents.commands.compare import run_compare  # SB3 (the agents' learning curve)

    result = run_compare(
        config, atlas, out, seed, progress=_bar(quiet), hyperparams=hyperparams, runner=runner,
        resume=resume,
    )  # fmt: skip
    summary = result.to_dict()
    write_json(summary, out / "costs.json")
    figures = write_figures(result, out / "figures")
    print_report(result, table(cost_rows(summary)))
    print(f"wrote {out}/costs.json, " + ", ".join(f"figures/{f.name}" for f in figures))
    return summary


# ---------------------------------------------------------------------- demo
DEMO_TUNE_PADS, DEMO_EVAL_PADS = 34, 70  # per label: 102 tuning and 210 held-out pads
DEMO_PREDICTORS = ("none", "physics", "data", "twin", "oracle")  # the paper's three
DEMO_WORKERS = 2  # a local Ray's CPUs for the demo's pads (in this process without Ray)


def demo_compare(ctx: DemoContext) -> tuple[dict[str, Any], str]:
    """The comparison on a budget the demo can afford that still ranks: 210 held-out pads
    (70 of each label), thresholds and the fixed interval tuned on 102 others; no agent
    (too small a budget to train one: the report says so)."""
    args = ctx.args
    config = StudyConfig(
        env=_env(args, regime="mixed"),
        predictors=DEMO_PREDICTORS,
        n_train_runs=max(3, args.n_train),
        tune_pads=DEMO_TUNE_PADS,
        eval_pads=DEMO_EVAL_PADS,
        timesteps=1,
        n_resamples=2000,
    )
    out = ctx.out / "compare"
    atlas = load_atlas(args)
    # Not resumed: a demo run with other settings rewrites its stages' outputs.
    with Runner(DEMO_WORKERS) if ray_available() else Runner(0) as runner:
        summary = compare_and_report(
            config, atlas, out, args.seed, runner, quiet=args.quiet, resume=False
        )
    return summary, markdown_section(summary, "compare")


# ---------------------------------------------------------------------- fleet study
def cmd_fleet_study(args: argparse.Namespace) -> dict[str, Any]:
    from agents.commands.fleet_study import config_from_args, study_and_report

    config = config_from_args(args)
    with make_runner(args) as runner:
        return study_and_report(config, load_atlas(args), Path(args.out), runner,
                                quiet=args.quiet)  # fmt: skip


def demo_fleet(ctx: DemoContext) -> tuple[dict[str, Any], str]:
    """The fleet study on the small fleet at a budget the demo can afford: the demo's
    predictors, two heuristics tuned on few trials, the reference, 180-shift episodes; no
    agent (a MaskablePPO seed trains in 400-450 s on a quiet 2-core machine; the report
    says so)."""
    from agents.commands.fleet_config import FleetStudyConfig
    from agents.commands.fleet_study import report, study_and_report

    args, d = ctx.args, DEMO_FLEET
    config = FleetStudyConfig(
        predictors=DEMO_PREDICTORS, heuristics=d["heuristics"], shifts=d["shifts"],
        trials=d["trials"], trials_best=d["trials"], tune_episodes=2,
        eval_episodes=d["episodes"], n_train_runs=max(3, args.n_train), seed=args.seed,
    )  # fmt: skip
    out = ctx.out / "fleet"
    with Runner(DEMO_WORKERS) if ray_available() else Runner(0) as runner:
        summary = study_and_report(config, load_atlas(args), out, runner, quiet=args.quiet,
                                   resume=False)  # fmt: skip
    figs = "\n".join(f"![{Path(f).stem}](fleet/{f})" for f in summary["figures"])
    section = f"""## The fleet study (BrakeWearFleet-v0, small fleet)

A small budget: {d["shifts"]}-shift episodes, {", ".join(d["heuristics"])} tuned with
{d["trials"]} Optuna trials on 2 tuning episodes, {d["episodes"]} evaluation episodes, no
best combination and no agent (a MaskablePPO training seed takes 400-450 s on a quiet
2-core machine, the study trains 10). At this budget
the heuristics are under-tuned and the intervals wide: the ranking below is what this
budget shows, not the study's result (README "The fleet study" has the full run and its
command). On episodes this short a tuned heuristic can come out below the reference (a
ratio under 1): the reference plans 200 shifts past the episode's end, the heuristics
are tuned on the episode alone.

{report(summary, markdown=True)}

{figs}
"""
    return summary, section


# The demo's fleet study (README "The fleet study" has the full budget).
DEMO_FLEET: dict[str, Any] = {
    "heuristics": ("threshold", "(n, N)"), "shifts": 180, "trials": 6, "episodes": 16,
}  # fmt: skip


# ---------------------------------------------------------------------- hyperparams
def cmd_hyperparams(args: argparse.Namespace) -> dict[str, Any]:
    """Print where the installed package keeps a hyperparameter file (a pip user has no
    repository to point ``--conf-file`` or ``--hyperparams`` at)."""
    path = rl_zoo_file(args.algo) if args.zoo else hyperparams_file(args.predictor)
    if not path.exists():
        raise FileNotFoundError(f"no hyperparameter file for predictor {args.predictor!r}")
    print(path)
    return {"path": str(path)}


# ---------------------------------------------------------------------- parser
def register(sub: argparse._SubParsersAction[Any]) -> None:
    """Add ``train``, ``compare`` and ``hyperparams`` to the ``brakewear`` parser."""
    fmt = argparse.ArgumentDefaultsHelpFormatter
    h = sub.add_parser(
        "hyperparams",
        formatter_class=fmt,
        help="print the path of a shipped hyperparameter file (--zoo: RL Zoo's --conf-file)",
    )
    h.add_argument("--zoo", action="store_true", help="the RL Zoo file of --algo")
    h.add_argument("--algo", choices=ALGOS, default="ppo")
    h.add_argument("--predictor", choices=predictor_names(), default="twin")
    h.set_defaults(func=cmd_hyperparams)
    t = sub.add_parser(
        "train",
        formatter_class=fmt,
        help="train an SB3 agent on BrakeWear-v0 with a predictor's RUL estimates",
    )
    add_common_args(t, "out/train")
    t.add_argument("--predictor", choices=predictor_names(), default="twin")
    t.add_argument("--algo", choices=ALGOS, default="ppo")
    t.add_argument("--timesteps", type=int_at_least(1), default=100_000)
    t.add_argument(
        "--hyperparams", default=None, help="TOML file (default agents/learning/hyperparams/)"
    )
    t.add_argument("--n-train-runs", type=int_at_least(1), default=10, help="pads to fit on")
    t.add_argument(
        "--curve-pads", type=int_at_least(1), default=40, help="learning-curve pads per label"
    )
    t.add_argument("--eval-pads", type=int_at_least(1), default=100, help="held-out per label")
    add_runner_args(t, workers=2)  # the agent trains on one while pads are simulated
    t.add_argument("--atlas", default=None, help="atlas .npz instead of the cache")
    _env_args(t)
    t.set_defaults(func=cmd_train)

    c = sub.add_parser(
        "compare",
        formatter_class=fmt,
        help="rank predictors by the maintenance cost their policies lead to",
    )
    add_common_args(c, "out/compare")
    c.add_argument("--timesteps", type=int_at_least(1), default=100_000, help="per agent")
    c.add_argument("--algo", choices=ALGOS, default="ppo")
    c.add_argument("--predictors", type=_names, default=predictor_names(), help="comma-separated")
    c.add_argument(
        "--agents",
        type=_agents,
        default=("twin", "oracle"),
        help="predictors given an agent ('': none)",
    )
    c.add_argument("--n-train-runs", type=int_at_least(1), default=10, help="pads to fit on")
    c.add_argument("--tune-pads", type=int_at_least(1), default=100, help="per wear label")
    c.add_argument("--eval-pads", type=int_at_least(1), default=1000, help="per wear label")
    c.add_argument("--resamples", type=int_at_least(100), default=4000, help="bootstrap")
    add_runner_args(c, workers=2)
    c.add_argument("--atlas", default=None, help="atlas .npz instead of the cache")
    _env_args(c)
    c.set_defaults(func=cmd_compare)
    _register_fleet_study(sub, fmt)


# The fleet study's choices as the parser shows them (agents.commands.fleet_config holds the
# same, tested equal; importing it here would load scipy and Optuna for ``--help``). A
# heuristic name is checked by FleetStudyConfig, which names the valid ones.
FLEET_SIZES = ("small", "default")
FLEET_PREDICTORS = ("none", "physics", "data", "twin", "window", "oracle")
FLEET_HEURISTICS = ("threshold", "(n, N)", "best combination")


def _register_fleet_study(sub: argparse._SubParsersAction[Any], fmt: Any) -> None:
    f = sub.add_parser(
        "fleet-study",
        formatter_class=fmt,
        help="every policy x predictor on BrakeWearFleet-v0: heuristics tuned, the reference,"
        " MaskablePPO over training seeds, on the same evaluation episodes",
    )
    add_common_args(f, "out/fleet-study")
    f.add_argument(
        "--size", choices=FLEET_SIZES, default="small", help="small: 2 vehicles (reference)"
    )
    f.add_argument("--shifts", type=int_at_least(2), default=365, help="an episode")
    f.add_argument("--predictors", type=_names, default=FLEET_PREDICTORS, help="comma-separated")
    f.add_argument(
        "--heuristics", nargs="+", type=nonempty, default=FLEET_HEURISTICS, metavar="NAME",
        help="heuristics to tune, each quoted (agents.study.fleet_tuning.SPACES: threshold,"
        " time-to-window, '(n, N)', capacity greedy, duty rule, '(s, S)', standby, best"
        " combination)",
    )  # fmt: skip
    f.add_argument("--trials", type=int_at_least(1), default=15, help="Optuna, per heuristic")
    f.add_argument("--trials-best", type=int_at_least(1), default=45, help="the combination's")
    f.add_argument("--tune-episodes", type=int_at_least(1), default=3)
    f.add_argument("--eval-episodes", type=int_at_least(2), default=40)
    f.add_argument("--n-train-runs", type=int_at_least(1), default=10, help="pads to fit on")
    f.add_argument("--agents", type=_agents, default=(), help="predictors given MaskablePPO")
    f.add_argument(
        "--agent-seeds", type=int_at_least(0), default=10,
        help="training seeds of MaskablePPO (one policy for the fleet) per agent",
    )  # fmt: skip
    f.add_argument(
        "--shared-seeds", type=int_at_least(0), default=0,
        help="training seeds of the parameter-shared PPO (one policy per vehicle) per agent",
    )  # fmt: skip
    f.add_argument("--timesteps", type=int_at_least(1), default=20_000, help="PPO, per agent")
    f.add_argument("--dagger", type=int_at_least(0), default=1, help="DAgger rounds of cloning")
    f.add_argument("--learning-rate", type=POSITIVE, default=1e-4, help="PPO's, after cloning")
    f.add_argument("--ent-coef", type=NONNEGATIVE, default=0.0, help="PPO's entropy coefficient")
    f.add_argument(
        "--imitate", type=int_at_least(0), default=20,
        help="episodes of the predictor's best heuristic each agent clones before PPO (0: none)",
    )  # fmt: skip
    f.add_argument("--curve-every", type=int_at_least(1), default=10_000, help="shifts")
    add_runner_args(f, workers=2)
    f.add_argument("--atlas", default=None, help="atlas .npz instead of the cache")
    f.set_defaults(func=cmd_fleet_study)
