"""brakewear: brake-pad wear simulation and predictive-maintenance testbed."""

from __future__ import annotations

import argparse
import contextlib
import importlib
import sys
import warnings
from collections.abc import Callable, Sequence
from typing import Any

from brake_env.cli import demo, simulate
from brake_env.cli.common import Parser, plugins
from brake_env.data.plausibility import PlausibilityWarning
from brake_env.prognostics.commands import backtest, evaluate, fit_predict
from brake_env.run_lock import hold_output


def build_parser() -> argparse.ArgumentParser:
    fmt = argparse.ArgumentDefaultsHelpFormatter
    p = Parser(prog="brakewear", description=__doc__, formatter_class=fmt)
    sub = p.add_subparsers(dest="command", required=True)
    simulate.register(sub)
    demo.register(sub)
    evaluate.register(sub)
    fit_predict.register(sub)
    backtest.register(sub)
    # Commands of the downstream packages (twin, baselines, agents, sim2real) register
    # themselves as plug-ins, so brake_env never imports them (imports flow one way:
    # docs/architecture.md).
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


def _format_warning(message: Any, category: type[Warning], *rest: Any, **kw: Any) -> str:
    """Plausibility warnings as one line for the terminal; others as Python prints them."""
    if issubclass(category, PlausibilityWarning):
        return f"brakewear {message} (warning; --strict makes it an error)\n"
    return _PYTHON_FORMAT(message, category, *rest, **kw)


_PYTHON_FORMAT = warnings.formatwarning


def main(argv: Sequence[str] | None = None) -> int:
    warnings.formatwarning = _format_warning
    argv = list(sys.argv[1:] if argv is None else argv)
    args = build_parser().parse_args(argv)
    args.argv = argv  # what a result records as its command (common.command_line)
    run = command(args.func)
    out = getattr(args, "out", None)
    # --out is refused before any work when another command (or a running one) holds it,
    # else marked as this command's for as long as it runs, and after (brake_env.run_lock)
    held = hold_output(out, args.command, argv) if out is not None else contextlib.nullcontext()
    try:
        with held:
            run(args)
    except (ValueError, FileNotFoundError, PermissionError) as e:
        # PermissionError: a read-only --out, cache or input, named by the error
        print(f"brakewear {args.command}: error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
