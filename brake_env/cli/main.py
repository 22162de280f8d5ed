"""brakewear: brake-pad wear simulation and predictive-maintenance testbed."""

from __future__ import annotations

import argparse
import importlib
import sys
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from brake_env.cli import demo, simulate
from brake_env.cli.common import Parser, plugins
from brake_env.data.plausibility import PlausibilityWarning
from brake_env.output import check_output, mark_output
from brake_env.prognostics.commands import backtest, evaluate, fit_predict


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
    args = build_parser().parse_args(argv)
    run = command(args.func)
    out = getattr(args, "out", None)
    try:
        if out is not None:  # a folder another command wrote is refused before any work
            check_output(out, args.command)
        before = _entries(out)
        done = False
        try:
            run(args)
            done = True
        finally:  # interrupted too, once it wrote: the folder then holds its units
            if out is not None and (done or _entries(out) != before):
                mark_output(out, args.command)
    except (ValueError, FileNotFoundError) as e:
        print(f"brakewear {args.command}: error: {e}", file=sys.stderr)
        return 2
    return 0


def _entries(out: str | None) -> set[str] | None:
    """The names in ``out`` (None: no such directory)."""
    path = Path(out) if out is not None else None
    return {p.name for p in path.iterdir()} if path is not None and path.is_dir() else None


if __name__ == "__main__":
    raise SystemExit(main())
