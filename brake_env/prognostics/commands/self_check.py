"""The predictor's test of its own model, as ``fit`` and ``predict`` report it.

A predictor whose physics can be wrong for a log says so (:meth:`Predictor.self_check`; the
twin's is :mod:`twin.misfit`): the finding is printed as one warning line, recorded in the
command's outputs (``predictor.json``'s ``info``, ``fleet.json``), and with ``--strict`` it
is an error (exit 2) before anything is written.
"""

from __future__ import annotations

import sys
from collections.abc import Mapping
from typing import Any

import pandas as pd

from brake_env.prognostics.protocol import Predictor


def self_check(pred: Predictor, log: pd.DataFrame, command: str, strict: bool) -> dict[str, Any]:
    """Run ``pred``'s self-check on ``log``; print a warning if it warns (an error with
    ``strict``). Returns what to record (``{}`` when the predictor has no check)."""
    found: Mapping[str, Any] | None = pred.self_check(log)
    if found is None:
        return {}
    if found.get("warns"):
        if strict:
            raise ValueError(f"{found['message']} (--strict)")
        print(f"brakewear {command}: warning: {found['message']}", file=sys.stderr)
    return dict(found)
