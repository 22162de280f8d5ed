"""The event-log schema (DESIGN 4), a public contract for CSV and Parquet files.

One row per braking event. Required: ``run_id`` (str), ``event`` (int, 0-based, strictly
increasing within a run) and the measured channels. Optional: event time, ambient
temperature, line pressure and ground truth. Unknown columns are kept. Bad input raises one
:class:`EventLogError` naming the column and row; nothing is silently dropped or repaired.
"""

from __future__ import annotations

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
        lo, hi: Physically possible range (inclusive); values outside are rejected.
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


REQUIRED = (
    Column("run_id", "str", "-", description="pad/run identifier"),
    Column("event", "int", "-", 0, math.inf, description="braking event index, 0-based"),
    Column("speed_kmh", "float", "km/h", 0, 200, True, "wheel speed at brake onset"),
    Column("mass_kg", "float", "kg", 0, 1e6, True, "vehicle mass"),
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
    run = (
        f", run {df['run_id'].iloc[i]!r}" if "run_id" in df and df["run_id"].dtype != float else ""
    )
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

    # Events strictly increasing within each run (runs may interleave).
    ev = out["event"].to_numpy()
    codes = pd.factorize(out["run_id"])[0]
    order = np.argsort(codes, kind="stable")
    same = codes[order][1:] == codes[order][:-1]
    bad = np.flatnonzero(same & (ev[order][1:] <= ev[order][:-1]))
    if bad.size:
        i = int(order[bad[0] + 1])
        raise EventLogError(
            f"{pre}column 'event', {_where(out, i, source)}: event {ev[i]} does not increase"
            f" (previous event of this run is {ev[order][bad[0]]})"
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
                f" got {s.iloc[i]!r}"
            )
        return low.map(mapping).astype(bool)

    num = pd.to_numeric(s, errors="coerce")
    not_number = (num.isna() & s.notna()).to_numpy()
    if not_number.any():
        i = int(np.argmax(not_number))
        raise EventLogError(
            f"{pre}column '{name}', {_where(df, i, source)}: expected a number, got {s.iloc[i]!r}"
        )
    x = num.to_numpy(dtype=np.float64, na_value=np.nan)
    nan = np.isnan(x)
    if nan.any() and not col.nan_ok:
        i = int(np.argmax(nan))
        raise EventLogError(f"{pre}column '{name}', {_where(df, i, source)}: missing value (NaN)")
    bad = ~nan & ((x < col.lo) | (x > col.hi))
    if bad.any():
        i = int(np.argmax(bad))
        raise EventLogError(
            f"{pre}column '{name}', {_where(df, i, source)}: value {x[i]!r} is outside the"
            f" physically possible range [{col.lo}, {col.hi}] {col.unit}"
        )
    if col.kind == "int":
        frac = ~nan & (x != np.round(x))
        if frac.any():
            i = int(np.argmax(frac))
            raise EventLogError(
                f"{pre}column '{name}', {_where(df, i, source)}: expected an integer, got {x[i]!r}"
            )
        return pd.Series(x.astype(np.int64), index=s.index, name=name)
    return pd.Series(x, index=s.index, name=name)


def read_event_log(path: str | os.PathLike[str]) -> pd.DataFrame:
    """Read and validate a ``.parquet`` or ``.csv`` event log."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"event log {path} does not exist")
    suffix = path.suffix.lower()
    if suffix == ".parquet":
        df = pq.read_table(path).to_pandas()
    elif suffix == ".csv":
        # Everything as text first, so a stray word is reported by column and row.
        df = pd.read_csv(path, dtype=str, keep_default_na=True)
    else:
        raise EventLogError(f"{path}: unsupported file type {suffix!r}; use .parquet or .csv")
    return validate_event_log(df, str(path))


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
