"""brakewear: brake-pad wear simulation and predictive-maintenance testbed."""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Callable, Sequence
from typing import Any

from brake_env.cli import demo, simulate
from brake_env.cli.common import plugins
from brake_env.prognostics.commands import evaluate, fit_predict


def build_parser() -> argparse.ArgumentParser:
    fmt = argparse.ArgumentDefaultsHelpFormatter
    p = argparse.ArgumentParser(prog="brakewear", description=__doc__, formatter_class=fmt)
    sub = p.add_subparsers(dest="command", required=True)
    simulate.register(sub)
    demo.register(sub)
    evaluate.register(sub)
    fit_predict.register(sub)
    # Commands of the downstream packages (twin, baselines, agents, sim2real) register
    # themselves as plug-ins, so brake_env never imports them (imports flow one way: README
    # "Architecture").
    for ep in plugins("brakewear.commands"):
        ep.load()(sub)
    return p


def command(func: Callable[[argparse.Namespace], Any] | str) -> Callable[..., Any]:
    """A subcommand's function: given, or named ``"module:function"`` by a parser that
    keeps its implementation (and what that imports) out of ``brakewear --help``."""
    if not isinstance(func, str):
        return func
    module, _, name = func.partition(":")
    return getattr(importlib.import_module(module), name)


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    run = command(args.func)
    try:
        run(args)
    except (ValueError, FileNotFoundError) as e:
        print(f"brakewear {args.command}: error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
