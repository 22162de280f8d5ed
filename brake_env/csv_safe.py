"""User-given text (pad ids, run ids, file names) made inert where people read it: CSV
cells a spreadsheet opens, and figure labels matplotlib draws.

A spreadsheet runs a cell that begins with ``=``, ``+``, ``-`` or ``@`` as a formula
(``=cmd|' /C calc'!A0``, ``+HYPERLINK(...)``), and one that begins with a tab or a carriage
return after stripping it; :func:`safe_csv` writes such a text cell with a leading ``'``, as
spreadsheet-safe exporters do (OWASP, "CSV Injection"), so it is shown as the text it is.
Numbers are never changed: a negative number stays a number. A program reading the CSV back
sees the quote; the JSON outputs hold the text as given. :func:`write_csv` also ends lines
with CRLF (RFC 4180), so that a cell holding a carriage return is quoted: with ``\n`` line
ends pandas leaves it bare and every reader splits the row there.

matplotlib parses text between two ``$`` as mathtext: a pad id such as ``$\\x$`` makes the
figure fail and ``$x$`` is drawn as an italic x. :func:`plain_text` escapes it.
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import pandas as pd

from brake_env.output import atomic_path

FORMULA_START = ("=", "+", "-", "@", "\t", "\r")


def safe_cell(value: Any) -> Any:
    """``value`` with a leading ``'`` when it is text that begins with one of
    :data:`FORMULA_START`; anything else (numbers, None, other text) as it is."""
    if isinstance(value, str) and value.startswith(FORMULA_START):
        return "'" + value
    return value


def safe_csv(frame: pd.DataFrame, columns: Iterable[str] | None = None) -> pd.DataFrame:
    """A copy of ``frame`` to write as CSV, its text cells through :func:`safe_cell`.

    Args:
        frame: The table (not changed).
        columns: The columns holding user-given text; default: every column of text
            (object, string or categorical dtype). Numeric columns are never changed.

    Raises:
        KeyError: A column in ``columns`` that ``frame`` lacks.

    Example:
        >>> write_csv(fleet, out / "fleet.csv")  # doctest: +SKIP
    """
    names = list(frame.columns) if columns is None else list(columns)
    missing = [c for c in names if c not in frame.columns]
    if missing:
        raise KeyError(f"safe_csv: no column {missing} in the table (it has {list(frame.columns)})")
    out = frame.copy()
    for name in names:
        col = out[name]
        if isinstance(col.dtype, pd.CategoricalDtype):
            out[name] = col.astype(object).map(safe_cell)
        elif col.dtype == object or isinstance(col.dtype, pd.StringDtype):
            out[name] = col.map(safe_cell, na_action="ignore")
    return out


def write_csv(
    frame: pd.DataFrame, path: str | os.PathLike[str], columns: Iterable[str] | None = None
) -> Path:
    """Write ``frame`` (no index) as CSV to ``path`` atomically, its text cells through
    :func:`safe_cell` (:func:`safe_csv`, ``columns`` as there), lines ended with CRLF."""
    with atomic_path(path) as tmp:
        safe_csv(frame, columns).to_csv(tmp, index=False, lineterminator="\r\n")
    return Path(path)


def plain_text(text: Any) -> str:
    """``text`` as matplotlib draws it literally: every ``$`` escaped (no mathtext, the
    only markup matplotlib parses without usetex), and a leading ``_`` preceded by a
    zero-width space (a legend leaves out labels that begin with ``_``)."""
    s = str(text).replace("$", r"\$")
    return "\u200b" + s if s.startswith("_") else s
