"""The sim-to-real package's ``brakewear`` subcommands as a plug-in of the parser:
``diagnose``, ``validate-gap`` and ``simulate --effect``. Light on purpose: each command is
named by its function's path (``"module:function"``), imported only when it runs
(:func:`brake_env.cli.main.main`), so building the parser loads no diagnosis (scipy)."""

from __future__ import annotations

import argparse
from typing import Any

from brake_env.cli.common import (
    add_common_args,
    add_runner_args,
    add_strict_arg,
    float_in,
    int_at_least,
    nonempty,
    predictor_list,
)
from sim2real.commands.simulate import add_effect_args

_FMT = argparse.ArgumentDefaultsHelpFormatter


def register(sub: argparse._SubParsersAction[Any]) -> None:
    """Add this package's subcommands to the ``brakewear`` parser."""
    sim = sub.choices.get("simulate")
    if sim is not None:
        add_effect_args(sim)
    _add_diagnose(sub)
    _add_validate_gap(sub)


def _add_diagnose(sub: argparse._SubParsersAction[Any]) -> None:
    d = sub.add_parser(
        "diagnose", formatter_class=_FMT, help="diagnose the sim-to-real gap of an event log"
    )
    add_common_args(d, "out/diagnose")
    d.add_argument("--real", required=True, help="event log (.parquet or .csv) to diagnose")
    d.add_argument("--model", default=None, help="the nominal model's atlas .npz")
    d.add_argument(
        "--candidates", nargs="+", type=nonempty, default=None, help="candidate effect names"
    )
    d.add_argument(
        "--calibration-fraction",
        type=float_in(0.1, 0.9),
        default=0.5,
        help="share of runs used to fit candidate parameters",
    )
    d.add_argument("--no-rul", action="store_true", help="skip the twin's RUL error")
    d.add_argument(
        "--backtest",
        action="store_true",
        help="after the diagnosis, what the fix is worth: back-test the predictors on this"
        " log (its pads run to failure, one left out at a time), nominal and with the named"
        " effect fed back at its refined value (NAME+effect); not for a between-events effect",
    )
    d.add_argument(
        "--backtest-predictors",
        type=predictor_list,
        default=("twin", "window"),
        help="with --backtest: the predictors back-tested",
    )
    d.add_argument(
        "--backtest-fed-back",
        type=predictor_list,
        default=("twin",),
        help="with --backtest: the predictors scored a second time with the effect fed back"
        " (the window model needs no physics)",
    )
    add_strict_arg(d)
    d.set_defaults(func="sim2real.commands.cli:cmd_diagnose")


def _add_validate_gap(sub: argparse._SubParsersAction[Any]) -> None:
    v = sub.add_parser(
        "validate-gap",
        formatter_class=_FMT,
        help="withheld-effect validation of the diagnosis (confusion matrix)",
    )
    add_common_args(v, "out/validate-gap")
    v.add_argument(
        "--seeds", type=int_at_least(1), default=3, help="seeds per effect at mid magnitude"
    )
    v.add_argument("--controls", type=int_at_least(0), default=4, help="no-effect control cases")
    v.add_argument(
        "--out-of-library",
        type=int_at_least(0),
        default=2,
        help="cases of the out-of-library effect (pad glazing)",
    )
    v.add_argument("--runs", type=int_at_least(2), default=8, help="truth runs per case")
    v.add_argument(
        "--low", action="store_true", help="also each effect once at half its mid magnitude"
    )
    v.add_argument("--no-rul", action="store_true", help="skip the twin's RUL error")
    v.add_argument(
        "--only", nargs="+", type=nonempty, default=None, help="run only cases containing these"
    )
    v.add_argument(
        "--route-block-events",
        type=int_at_least(0),
        default=0,
        help="0: independent operating conditions; N: haul-road and pit blocks of N events",
    )
    add_runner_args(v)
    # Deprecated alias of --workers, kept for old scripts (README's examples used it).
    v.add_argument("--jobs", type=int_at_least(1), default=None, help=argparse.SUPPRESS)
    v.set_defaults(func="sim2real.commands.cli:cmd_validate_gap")
