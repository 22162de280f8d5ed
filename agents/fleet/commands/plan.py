"""``brakewear plan``'s options (the command is :func:`agents.fleet.operate.run.cmd_plan`,
imported only when it runs): the decision for a fleet's pads in service (docs/plan.md)."""

from __future__ import annotations

import argparse
from typing import Any

from brake_env.cli.common import SEED, int_range, out_dir

SUITE_DEFAULT = "default"


def register(sub: argparse._SubParsersAction[Any]) -> None:
    """Add ``plan`` to the ``brakewear`` parser."""
    p = sub.add_parser(
        "plan",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
        help="the decision for your fleet's pads in service (duties, replacements, spares)",
        description="From the log of the pads in service (one run_id per vehicle) and a saved"
        " model: the coming shift's duties, the pads to change by the next window, the spares"
        " to order, each pad's route RUL and risk, and the cost over the horizon with its"
        " interval over simulated futures. Writes plan.csv, plan.json and plan.png.",
    )
    p.add_argument("--model", required=True, help="a saved model (brakewear fit --out)")
    p.add_argument("--log", required=True, help="event log of the pads in service")
    p.add_argument(
        "--fleet",
        default="default",
        metavar="NAME|FILE",
        help="a shipped fleet or a fleet file (TOML)",
    )
    p.add_argument("--out", type=out_dir, default="out/plan", help="output directory")
    p.add_argument(
        "--shifts-to-window",
        type=int_range(0, 10_000),
        required=True,
        help="shifts before the next maintenance window (0: the coming shift is one)",
    )
    _shop_args(p)
    p.add_argument("--suite", default=SUITE_DEFAULT, help="whose tuned rule (--policy rule)")
    p.add_argument(
        "--shifts",
        type=int_range(1, 1_000),
        default=None,
        help="horizon (default: through the next window)",
    )
    p.add_argument(
        "--futures",
        type=int_range(2, 100_000),
        default=200,
        help="simulated futures the plan is judged on",
    )
    p.add_argument("--seed", type=SEED, default=0, help="the futures' seed (same seed, same plan)")
    p.add_argument("--atlas", default=None, help="the model's atlas .npz instead of the cache")
    p.add_argument("--cache-dir", type=out_dir, default=None, help="atlas cache")
    p.add_argument("--quiet", action="store_true", help="no table")
    p.set_defaults(func="agents.fleet.operate.run:cmd_plan")


def _shop_args(p: argparse.ArgumentParser) -> None:
    """The shop today: stock, orders in transit, vehicles down; and the policy."""
    p.add_argument(
        "--stock",
        type=int_range(0, 10_000),
        default=None,
        help="spare pad sets in stock (default: the fleet file's initial_stock)",
    )
    p.add_argument(
        "--on-order",
        action="append",
        default=[],
        metavar="PADS@SHIFTS",
        help="pads arriving in SHIFTS shifts (1: at the next shift's start); repeatable",
    )
    p.add_argument(
        "--down",
        action="append",
        default=[],
        metavar="RUN_ID:SHIFTS",
        help="a vehicle in the shop for SHIFTS more shifts; repeatable",
    )
    p.add_argument(
        "--policy",
        default="rule",
        metavar="rule|rollout|MODULE:FACTORY",
        help="the suite's tuned rule for the model's predictor, the rollout planner on it"
        " (seconds a shift: use few --futures), or a scored policy",
    )
