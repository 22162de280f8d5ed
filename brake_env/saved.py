"""The header of a saved directory (a fitted predictor, a trained agent): one JSON file
that names its format and version and vouches for the arrays beside it. One reader, so
that every saved thing is refused the same way (docs/results/prognostics.md)."""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any


@dataclass(frozen=True)
class SavedFormat:
    """What a saved directory's header must say.

    Attributes:
        what: Starts each message with the directory ("model", "agent").
        kind: What the header describes ("predictor", "agent").
        header: The header's file name in the directory.
        format: The header's ``format`` value.
        version: The ``format_version`` this code reads.
        required: Keys the header must hold.
        redo: What to do with a directory of an older version ("refit").
    """

    what: str
    kind: str
    header: str
    format: str
    version: int
    required: tuple[str, ...]
    redo: str = "refit"


def read_saved_header(
    path: str | os.PathLike[str], fmt: SavedFormat, missing_hint: str = ""
) -> dict[str, Any]:
    """The checked header of the directory ``path`` (reads no arrays).

    Args:
        path: The saved directory.
        fmt: Its format.
        missing_hint: Appended to the message when the header is not there.

    Raises:
        FileNotFoundError: No header in ``path``.
        ValueError: Not valid JSON, not a header of ``fmt``, another format version (newer:
            upgrade; older: ``fmt.redo``), or required keys missing.
    """
    path = Path(path)
    head = path / fmt.header
    where = f"{fmt.what} {path}"
    if not head.is_file():
        raise FileNotFoundError(f"{where}: no {fmt.header}{missing_hint}")
    try:
        header = json.loads(head.read_bytes())
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise ValueError(f"{where}: {fmt.header} is not valid JSON ({e})") from None
    if not isinstance(header, dict) or header.get("format") != fmt.format:
        raise ValueError(f"{where}: {fmt.header} is not a brakewear {fmt.kind} header")
    got = header.get("format_version")
    if got != fmt.version:
        hint = "upgrade brakewear" if isinstance(got, int) and got > fmt.version else fmt.redo
        raise ValueError(
            f"{where}: format version {got!r}, this brakewear reads version {fmt.version} ({hint})"
        )
    missing = [k for k in fmt.required if k not in header]
    if missing:
        raise ValueError(f"{where}: {fmt.header} lacks {missing}")
    return header
