"""``brakewear train`` and ``brakewear compare`` (registered as a plug-in of the CLI).

The ``brakewear`` parser loads this module to register the commands, so it imports only
what parsing needs; the training and the comparison (torch, SB3) are imported by the
commands that run them (docs/architecture.md; ``brakewear --help`` stays fast).
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
    add_common_args,
    add_runner_args,
    add_wear_args,
    agent_list,
    int_at_least,
    load_atlas,
    make_runner,
    predictor_list,
    wear_regime,
)
from brake_env.cli.demo import DEMO_PREDICTORS, demo_runner
from brake_env.env.config import REGIMES, EnvConfig
from brake_env.output import table, write_json
from brake_env.prognostics.registry import predictor_names
from brake_env.runner import Runner

if TYPE_CHECKING:
    from brake_env.cli.demo import DemoContext
    from brake_env.model.atlas import Atlas


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
# Per label: 30 tuning pads (90 in all, the fewest the study tunes on: fewer tune nothing)
# and 24 held-out pads (72).
DEMO_TUNE_PADS = -(-StudyConfig.min_tune_pads // 3)
DEMO_EVAL_PADS = 24


def demo_compare(ctx: DemoContext) -> tuple[dict[str, Any], str]:
    """The comparison on a budget the demo can afford: 72 held-out pads (24 of each
    label), thresholds and the fixed interval tuned on 90 others; no agent (too small a
    budget to train one: the report says so); `n.s.` where the budget does not rank."""
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
    with demo_runner(args) as runner:
        summary = compare_and_report(
            config, atlas, out, args.seed, runner, quiet=args.quiet, resume=False
        )
    return summary, markdown_section(summary, "compare")


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
    c.add_argument(
        "--predictors", type=predictor_list, default=predictor_names(), help="comma-separated"
    )
    c.add_argument(
        "--agents",
        type=agent_list,
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
