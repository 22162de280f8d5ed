"""``brakewear fleet-study`` as a plug-in of the parser. Light on purpose: the command is
named by its function's path (``"module:function"``), imported only when it runs
(:func:`brake_env.cli.main.main`), so building the parser loads no study (scipy, Optuna,
torch)."""

from __future__ import annotations

import argparse
from typing import Any

from agents.fleet.commands import benchmark
from agents.fleet.settings import (
    DEFAULT_HEURISTICS,
    FIXED_INTERVAL,
    HEURISTICS,
    OBJECTIVES,
    check_model,
    study_predictor_names,
)
from brake_env.cli.common import (
    NONNEGATIVE,
    POSITIVE,
    add_common_args,
    add_runner_args,
    int_at_least,
    int_range,
    name_list,
)
from brake_env.env.fleet.fleet_file import fleet_path, shipped_fleets
from brake_env.prognostics.registry import predictor_names

# The registry's predictors and NAME+effect (NAME made on the physics with --effect)
predictor_list = name_list(study_predictor_names)
agent_list = name_list(study_predictor_names, allow_empty=True)


def fleet_name(text: str) -> str:
    """``--fleet``: a shipped fleet's name or an existing file (read when the study starts)."""
    try:
        fleet_path(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None
    return text


def model_arg(text: str) -> tuple[str, str]:
    """``--model NAME=DIR``: a saved model (``brakewear fit --out DIR``) under a name of its
    own; its atlas is checked when the study's is loaded, before any unit."""
    name, sep, path = text.partition("=")
    if not sep or not path:
        raise argparse.ArgumentTypeError(f"{text!r}: give NAME=DIR (a model from brakewear fit)")
    try:
        check_model(name, path)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None
    return name, path


def register(sub: argparse._SubParsersAction[Any]) -> None:
    """Add ``fleet-study`` to the ``brakewear`` parser."""
    fmt = argparse.ArgumentDefaultsHelpFormatter
    f = sub.add_parser(
        "fleet-study",
        formatter_class=fmt,
        help="every policy x predictor on BrakeWearFleet-v0: heuristics tuned, the reference,"
        " MaskablePPO over training seeds, on the same evaluation episodes",
    )
    add_common_args(f, "out/fleet-study")
    f.add_argument(
        "--fleet", "--size", dest="size", type=fleet_name, default="small", metavar="NAME|FILE",
        help=f"a shipped fleet ({', '.join(shipped_fleets())}; small: 2 vehicles, with the"
        " reference) or a fleet file (TOML; docs/benchmark.md); --size is its old name",
    )  # fmt: skip
    f.add_argument("--shifts", type=int_range(2, 100_000), default=365, help="an episode")
    _add_predictor_args(f)
    f.add_argument(
        "--heuristics", nargs="+", choices=HEURISTICS, default=DEFAULT_HEURISTICS, metavar="NAME",
        help="heuristics to tune, each quoted",
    )  # fmt: skip
    f.add_argument("--trials", type=int_at_least(1), default=15, help="Optuna, per heuristic")
    f.add_argument("--trials-best", type=int_at_least(1), default=45, help="the combination's")
    f.add_argument("--tune-episodes", type=int_at_least(1), default=3)
    f.add_argument(
        "--objective", choices=OBJECTIVES, default="cost",
        help="what the heuristics are tuned on and the predictors ranked by: the headline"
        " cost or the net cost (less the pad life left at the end)",
    )  # fmt: skip
    f.add_argument("--eval-episodes", type=int_range(2, 100_000), default=40)
    f.add_argument(
        "--episodes-from", type=int_range(0, 2**31), default=0, metavar="N",
        help="the first evaluation episode's seed (0: the episodes of every earlier study)",
    )  # fmt: skip
    f.add_argument("--n-train-runs", type=int_at_least(1), default=10, help="pads to fit on")
    f.add_argument(
        "--tail", type=int_at_least(0), default=200,
        help="shifts past the episode the reference plans for",
    )  # fmt: skip
    _add_agent_args(f)
    _add_planner_args(f)
    add_runner_args(f, workers=2)
    f.add_argument("--atlas", default=None, help="atlas .npz instead of the cache")
    f.set_defaults(func="agents.fleet.commands.cli:cmd_fleet_study")
    _register_distil(sub)
    benchmark.register(sub)


def _add_predictor_args(f: argparse.ArgumentParser) -> None:
    """The predictors ranked: the registry's, a user's saved models, and the effects."""
    f.add_argument(
        "--predictors", type=predictor_list, default=(*predictor_names(), FIXED_INTERVAL),
        help="comma-separated; NAME+effect: NAME made on the physics with the --effect(s);"
        f" {FIXED_INTERVAL}: replacement by pad age alone, the baseline of the money table",
    )  # fmt: skip
    f.add_argument(
        "--model", action="append", type=model_arg, default=[], metavar="NAME=DIR",
        help="a model of your own (brakewear fit --out DIR), ranked beside the predictors"
        " under NAME: loaded, not fitted; fitted on the study's atlas (repeatable)",
    )  # fmt: skip
    f.add_argument(
        "--effect", action="append", default=[], metavar="NAME:P=V[,...]",
        help="the fleet's pads (and the predictors' training pads) wear with this unmodelled"
        " effect (the syntax of simulate --effect; repeatable; in-event and sensor effects);"
        " the predictors are made on the nominal physics, NAME+effect on the effect's",
    )  # fmt: skip


def _add_planner_args(f: argparse.ArgumentParser) -> None:
    """The bound's and the rollout planner's options (FleetStudyConfig's)."""
    f.add_argument(
        "--rollout", type=agent_list, default=(),
        help="predictors given the rollout planner on their best heuristic ('': none)",
    )  # fmt: skip
    f.add_argument("--rollout-horizon", type=int_range(1, 100_000), default=28, help="shifts")
    f.add_argument("--rollout-samples", type=int_range(1, 1_000_000), default=16, help="futures")
    f.add_argument(
        "--rollout-chunk", type=int_at_least(1), default=5, help="evaluation episodes a unit"
    )
    f.add_argument(
        "--bound-iterations", type=int_at_least(0), default=0,
        help="price vectors of the Lagrangian bound's search (0: no bound, no price-directed"
        " policy)",
    )  # fmt: skip


def _add_agent_args(f: argparse.ArgumentParser) -> None:
    """The agents' options (FleetTraining's, where the study sets them)."""
    f.add_argument(
        "--agents", type=agent_list, default=(), help="predictors given MaskablePPO ('': none)"
    )
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
    f.add_argument(
        "--imitation-epochs", type=int_at_least(1), default=30, help="passes of the cloning"
    )
    f.add_argument("--imitation-lr", type=POSITIVE, default=1e-3, help="Adam's, for the cloning")
    f.add_argument("--n-envs", type=int_at_least(1), default=4, help="PPO's parallel envs")
    f.add_argument("--clip-range", type=POSITIVE, default=0.2, help="PPO's")
    f.add_argument(
        "--raw-reward", action="store_true",
        help="no running normalisation of the rewards (VecNormalize's norm_reward)",
    )  # fmt: skip
    f.add_argument(
        "--reorder", type=int_at_least(0), nargs=2, metavar=("s", "S"), default=None,
        help="spares by this (s, S) rule: the agents decide duties only",
    )  # fmt: skip
    f.add_argument("--curve-every", type=int_at_least(1), default=10_000, help="shifts")
    f.add_argument(
        "--curve-episodes", type=int_at_least(1), default=2, help="episodes of each curve point"
    )


def _register_distil(sub: argparse._SubParsersAction[Any]) -> None:
    """Add ``fleet-distil``: a finished study's rollout planner distilled into a policy."""
    f = sub.add_parser(
        "fleet-distil",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
        help="distil a fleet study's rollout planner into a central MaskablePPO (DAgger"
        " labels shared by the training seeds), compared on the study's episodes",
    )  # fmt: skip
    add_common_args(f, "out/fleet-distil")
    f.add_argument("--study", required=True, help="a finished fleet-study's --out")
    f.add_argument(
        "--predictor", choices=predictor_names(), default="twin",
        help="whose RUL the planner and the policy read (the study must have tuned it)",
    )  # fmt: skip
    f.add_argument("--seeds", type=int_range(0, 10_000), default=10, help="central policy's seeds")
    f.add_argument(
        "--shared-seeds", type=int_range(0, 10_000), default=0,
        help="seeds of the policy shared by the vehicles (TorchRL), from the same labels",
    )  # fmt: skip
    f.add_argument("--label-episodes", type=int_range(1, 999), default=16, help="per round")
    f.add_argument(
        "--label-rounds", type=int_range(0, 999), default=2,
        help="DAgger rounds after the planner's own episodes (a clone drives, it labels)",
    )  # fmt: skip
    f.add_argument(
        "--label-chunk", type=int_at_least(1), default=8,
        help="episodes a unit (each unit of a DAgger round refits the round's clone)",
    )  # fmt: skip
    f.add_argument("--timesteps", type=int_at_least(0), default=0, help="PPO after cloning")
    f.add_argument("--imitation-epochs", type=int_at_least(1), default=120)
    f.add_argument("--imitation-lr", type=POSITIVE, default=3e-3, help="Adam's, for the cloning")
    f.add_argument("--learning-rate", type=POSITIVE, default=1e-4, help="PPO's")
    f.add_argument("--ent-coef", type=NONNEGATIVE, default=0.0, help="PPO's entropy coefficient")
    f.add_argument("--n-envs", type=int_at_least(1), default=4, help="PPO's parallel envs")
    add_runner_args(f, workers=2)
    f.add_argument("--atlas", default=None, help="atlas .npz instead of the cache")
    f.set_defaults(func="agents.fleet.commands.distil:cmd_fleet_distil")
