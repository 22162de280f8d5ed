"""``brakewear evaluate``: the prognostics evaluation (registered as a plug-in)."""

from __future__ import annotations

import argparse
from typing import Any


def register(sub: argparse._SubParsersAction[Any]) -> None:
    """Add ``evaluate`` to the ``brakewear`` parser."""
