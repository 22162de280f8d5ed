"""The event-log schema (README "Event-log schema"), a public contract for CSV and Parquet files.

One row per braking event. Required: ``run_id`` (str), ``event`` (int, 0-based, strictly
increasing within a run) and the measured channels. Optional: event time, ambient
temperature, line pressure and ground truth. Unknown columns are kept. Bad input raises one
:class:`EventLogError` naming the column and row; nothing is silently dropped or repaired.
"""

from __future__ import annotations

import csv
import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.csv as pa_csv
import pyarrow.parquet as pq


@dataclass(frozen=True)
class Column:
    """One schema column.

    Attributes:
        name: Column name in the file.
        kind: ``str``, ``int``, ``float`` or ``bool``.
        unit: Physical unit, for documentation.
        lo, hi: Physically possible range; values outside, and infinities, are rejected.
        lo_open: The lower bound itself is impossible (a mass of 0 kg).
        nan_ok: Missing values allowed (a sensor dropout), else rejected.
        description: One line for the docs.
    """

    name: str
    kind: str
    unit: str
    lo: float = -math.inf
    hi: float = math.inf
    nan_ok: bool = False
    description: str = ""
    lo_open: bool = False


REQUIRED = (
    Column("run_id", "str", "-", description="pad/run identifier"),
    Column("event", "int", "-", 0, math.inf, description="braking event index, 0-based"),
    Column("speed_kmh", "float", "km/h", 0, 200, True, "wheel speed at brake onset"),
    Column("mass_kg", "float", "kg", 0, 1e6, True, "vehicle mass", lo_open=True),
    Column("slope_rad", "float", "rad", -math.pi / 2, math.pi / 2, True, "downhill slope"),
    Column("energy_j", "float", "J", 0, math.inf, True, "kinetic energy at brake onset"),
    Column("temp_c", "float", "deg C", -273.15, 3000, True, "mean brake temperature of the event"),
    Column("stop_dist_m", "float", "m", 0, math.inf, True, "stopping distance"),
)
OPTIONAL = (
    Column("time_s", "float", "s", -math.inf, math.inf, False, "event start time"),
    Column("ambient_c", "float", "deg C", -100, 100, True, "ambient temperature"),
    Column("pressure_pa", "float", "Pa", 0, 1e9, True, "brake line pressure"),
    Column("volume_frac", "float", "-", 0, 1, False, "true pad volume at event start (truth)"),
    Column("wear_coeff", "float", "-", 0, 1, False, "true Archard coefficient K (truth)"),
    Column("rul_events", "int", "-", 0, math.inf, False, "true events left after this (truth)"),
    Column("failed", "bool", "-", description="this event took the pad below failure (truth)"),
)
COLUMNS = {c.name: c for c in REQUIRED + OPTIONAL}
SENSOR_CHANNELS = tuple(c.name for c in REQUIRED if c.nan_ok)
GROUND_TRUTH = ("volume_frac", "wear_coeff", "rul_events", "failed")


class EventLogError(ValueError):
    """An event log that breaks the schema; the message names the column and row."""


def _where(df: pd.DataFrame, i: int, source: str) -> str:
    has_run = "run_id" in df and pd.notna(df["run_id"].iloc[i])
    run = f", run '{df['run_id'].iloc[i]}'" if has_run else ""
    line = f" (CSV line {i + 2})" if source.endswith(".csv") else ""
    return f"row {i}{line}{run}"


def validate_event_log(df: pd.DataFrame, source: str = "") -> pd.DataFrame:
    """Check ``df`` against the schema and return it with canonical dtypes.

    Raises:
        EventLogError: the first problem found, naming column and row.
    """
    pre = f"{source}: " if source else ""
    missing = [c.name for c in REQUIRED if c.name not in df.columns]
    if missing:
        raise EventLogError(f"{pre}missing required column(s) {missing}")
    if df.columns.duplicated().any():
        raise EventLogError(
            f"{pre}duplicate column(s) {sorted(df.columns[df.columns.duplicated()])}"
        )
    out = df.copy()
    for col in (c for c in REQUIRED + OPTIONAL if c.name in df.columns):
        out[col.name] = _coerce(out[col.name], col, df, pre, source)

    # Within each run (runs may interleave): events strictly increasing, times not falling.
    codes = pd.factorize(out["run_id"])[0]
    order = np.argsort(codes, kind="stable")
    same = codes[order][1:] == codes[order][:-1]
    for name, strict in (("event", True), ("time_s", False)):
        if name not in out:
            continue
        x = out[name].to_numpy()[order]
        step_bad = (x[1:] <= x[:-1]) if strict else (x[1:] < x[:-1])
        bad = np.flatnonzero(same & step_bad)
        if bad.size:
            i = int(order[bad[0] + 1])
            what = "does not increase" if strict else "goes back in time"
            raise EventLogError(
                f"{pre}column '{name}', {_where(out, i, source)}: {x[bad[0] + 1]:g} {what}"
                f" (previous value in this run is {x[bad[0]]:g})"
            )
    return out


def _coerce(s: pd.Series, col: Column, df: pd.DataFrame, pre: str, source: str) -> pd.Series:
    """Convert one column to its kind, then check missing values and range."""
    name = col.name
    if col.kind == "str":
        isna = s.isna().to_numpy()
        if isna.any():
            i = int(np.argmax(isna))
            raise EventLogError(f"{pre}column '{name}', {_where(df, i, source)}: missing value")
        if isinstance(s.dtype, pd.CategoricalDtype):
            return s.cat.rename_categories([str(c) for c in s.cat.categories])
        return s.astype(str)

    if col.kind == "bool":
        if s.dtype == bool:
            return s
        mapping = {"true": True, "false": False, "1": True, "0": False, "1.0": True, "0.0": False}
        low = s.astype(str).str.strip().str.lower()
        bad = ~low.isin(list(mapping)).to_numpy()
        if bad.any():
            i = int(np.argmax(bad))
            raise EventLogError(
                f"{pre}column '{name}', {_where(df, i, source)}: expected a boolean,"
                f" got '{s.iloc[i]}'"
            )
        return low.map(mapping).astype(bool)

    if s.dtype == bool:
        raise EventLogError(f"{pre}column '{name}': expected numbers, got a boolean column")
    num = pd.to_numeric(s, errors="coerce")
    not_number = (num.isna() & s.notna()).to_numpy()
    if not_number.any():
        i = int(np.argmax(not_number))
        raise EventLogError(
            f"{pre}column '{name}', {_where(df, i, source)}: expected a number, got '{s.iloc[i]}'"
        )
    x = num.to_numpy(dtype=np.float64, na_value=np.nan)
    nan = np.isnan(x)
    if nan.any() and not col.nan_ok:
        i = int(np.argmax(nan))
        raise EventLogError(f"{pre}column '{name}', {_where(df, i, source)}: missing value (NaN)")
    below = (x <= col.lo) if col.lo_open else (x < col.lo)
    bad = np.isinf(x) | below | (x > col.hi)
    if bad.any():
        i = int(np.argmax(bad))
        lo = "(" if col.lo_open else "["
        raise EventLogError(
            f"{pre}column '{name}', {_where(df, i, source)}: value {float(x[i]):g} is outside the"
            f" physically possible range {lo}{col.lo:g}, {col.hi:g}] {col.unit}"
        )
    if col.kind == "int":
        frac = ~nan & ((x != np.round(x)) | (np.abs(x) > 2.0**53))
        if frac.any():
            i = int(np.argmax(frac))
            raise EventLogError(
                f"{pre}column '{name}', {_where(df, i, source)}: expected an integer,"
                f" got {float(x[i])!r}"
            )
        return pd.Series(x.astype(np.int64), index=s.index, name=name)
    return pd.Series(x, index=s.index, name=name)


def read_event_log(path: str | os.PathLike[str]) -> pd.DataFrame:
    """Read and validate a ``.parquet`` or ``.csv`` event log.

    Raises:
        FileNotFoundError: no such file.
        EventLogError: anything wrong with its content, naming the column and row or line.
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"event log {path} does not exist")
    suffix = path.suffix.lower()
    if suffix == ".parquet":
        df = _read_parquet(path)
    elif suffix == ".csv":
        df = _read_csv(path)
    else:
        raise EventLogError(f"{path}: unsupported file type {suffix!r}; use .parquet or .csv")
    return validate_event_log(df, str(path))


def _check_header(path: Path, names: list[str]) -> None:
    if not names:
        raise EventLogError(f"{path}: no columns (empty file?)")
    dup = sorted({c for c in names if names.count(c) > 1})
    if dup:
        raise EventLogError(f"{path}: duplicate column(s) {dup}")


def _read_parquet(path: Path) -> pd.DataFrame:
    try:
        names = list(pq.read_schema(path).names)
    except (pa.ArrowException, OSError) as e:
        raise EventLogError(f"{path}: not a readable Parquet file ({e})") from None
    _check_header(path, names)
    try:
        return pq.read_table(path).to_pandas()
    except (pa.ArrowException, OSError) as e:  # a readable footer over damaged data pages
        raise EventLogError(f"{path}: damaged Parquet data ({e})") from None


def _read_csv(path: Path) -> pd.DataFrame:
    """Every column as text, so a stray word is reported by column and row; only empty
    fields are missing, so a run called "NA" stays a run called "NA"."""
    with open(path, newline="") as f:
        header = next(csv.reader(f), [])
    _check_header(path, header)
    opts = pa_csv.ConvertOptions(
        column_types={c: pa.string() for c in header}, null_values=[""], strings_can_be_null=True
    )
    try:
        table = pa_csv.read_csv(path, convert_options=opts)
    except pa.ArrowInvalid as e:
        raise EventLogError(f"{path}: {_ragged_line(path, len(header)) or e}") from None
    return table.to_pandas()


def _ragged_line(path: Path, n_fields: int) -> str | None:
    """Where a CSV parse error is: the first line whose field count differs from the header."""
    with open(path, newline="") as f:
        for line_no, row in enumerate(csv.reader(f), start=1):
            if len(row) != n_fields:
                return (
                    f"CSV line {line_no} (row {line_no - 2}) has {len(row)} fields,"
                    f" the header has {n_fields}"
                )
    return None


def write_event_log(df: pd.DataFrame, path: str | os.PathLike[str]) -> Path:
    """Write an event log as Parquet (zstd) or CSV, chosen by the file suffix."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    table = pa.Table.from_pandas(df, preserve_index=False)
    suffix = path.suffix.lower()
    if suffix == ".parquet":
        pq.write_table(table, path, compression="zstd")
    elif suffix == ".csv":
        pa_csv.write_csv(table, path)
    else:
        raise ValueError(f"unsupported file type {suffix!r}; use .parquet or .csv")
    return path
