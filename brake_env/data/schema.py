"""The event-log schema (docs/schema.md), a public contract for CSV and Parquet files.

One row per braking event. Required: ``run_id`` (str), ``event`` (int, counted from the
pad's installation, strictly increasing within a run) and the measured channels. Optional:
event time, ambient temperature, line pressure, the run's outcome (``failed``), measured
pad volumes and ground truth. Unknown columns are kept. Bad input raises one
:class:`EventLogError` naming the file, the column and the row (and CSV line); nothing is
silently dropped or repaired.
"""

from __future__ import annotations

import csv
import math
import os
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.csv as pa_csv
import pyarrow.parquet as pq

from brake_env.output import atomic_path, parquet_footer_ok, write_parquet


@dataclass(frozen=True)
class Column:
    """One schema column.

    Attributes:
        name: Column name in the file.
        kind: ``str``, ``int``, ``float`` or ``bool``.
        unit: Physical unit, for documentation.
        lo, hi: Physically possible range (finite); values outside are rejected.
        nan_ok: Missing values allowed (a sensor dropout, no measurement), else rejected.
        description: One line for the docs.
        lo_open: The lower bound itself is impossible (a mass of 0 kg).
    """

    name: str
    kind: str
    unit: str
    lo: float = -math.inf
    hi: float = math.inf
    nan_ok: bool = False
    description: str = ""
    lo_open: bool = False


_MAX_EVENTS = 1e9  # braking events: a pad lives ~1e5; 1e9 is no pad's history
REQUIRED = (
    Column("run_id", "str", "-", description="pad/run identifier"),
    Column("event", "int", "-", 0, _MAX_EVENTS, description="events since pad installation"),
    Column("speed_kmh", "float", "km/h", 0, 200, True, "wheel speed at brake onset"),
    Column("mass_kg", "float", "kg", 0, 1e6, True, "vehicle mass", lo_open=True),
    Column("slope_rad", "float", "rad", -math.pi / 2, math.pi / 2, True, "downhill slope"),
    # 1e6 kg at 200 km/h carries 1.5e9 J: ten times that is no vehicle's.
    Column("energy_j", "float", "J", 0, 1.5e10, True, "kinetic energy at brake onset"),
    Column("temp_c", "float", "deg C", -273.15, 3000, True, "mean brake temperature of the event"),
    # Stopping from 200 km/h at 0.1 m/s^2 takes 15 km: 1e5 m is no stop.
    Column("stop_dist_m", "float", "m", 0, 1e5, True, "stopping distance"),
)
OPTIONAL = (
    Column("time_s", "float", "s", -1e10, 1e10, False, "event start time (+-317 years)"),
    Column("ambient_c", "float", "deg C", -100, 100, True, "ambient temperature"),
    Column("pressure_pa", "float", "Pa", 0, 1e9, True, "brake line pressure"),
    Column("volume_frac", "float", "-", 0, 1, False, "true pad volume at event start (truth)"),
    Column("wear_coeff", "float", "-", 0, 1, False, "true Archard coefficient K (truth)"),
    Column("rul_events", "int", "-", 0, _MAX_EVENTS, False, "true events left after this"),
    Column("failed", "bool", "-", description="the pad failed at this event (a run's last)"),
    Column("measured_volume_frac", "float", "-", 0, 1, True, "volume measured after the event"),
)
COLUMNS = {c.name: c for c in REQUIRED + OPTIONAL}
SENSOR_CHANNELS = tuple(c.name for c in REQUIRED if c.nan_ok)
FAILED = "failed"
TRUTH = ("volume_frac", "wear_coeff", "rul_events")  # only in simulation: the true state
# The columns a simulated log adds; ``failed`` is an observed outcome in a fleet log too.
GROUND_TRUTH = (*TRUTH, FAILED)
MEASURED_VOLUME = "measured_volume_frac"


class EventLogError(ValueError):
    """An event log that breaks the schema; the message names the file, column and row."""


@dataclass(frozen=True)
class _Where:
    """Names rows in messages: index, CSV line and run."""

    df: pd.DataFrame
    source: str
    line_of: Callable[[int], int | None] | None = None

    @property
    def pre(self) -> str:
        return f"{self.source}: " if self.source else ""

    def row(self, i: int) -> str:
        r = self.df["run_id"].iloc[i] if "run_id" in self.df else None
        run = f", run {_show(r)}" if pd.notna(r) and str(r).strip() else ""
        n = self.line_of(i) if self.line_of else None
        return f"row {i}{f' (CSV line {n})' if n else ''}{run}"

    def error(self, col: str, i: int, what: str) -> EventLogError:
        return EventLogError(f"{self.pre}column '{col}', {self.row(i)}: {what}")


def validate_event_log(
    df: pd.DataFrame, source: str = "", line_of: Callable[[int], int | None] | None = None
) -> pd.DataFrame:
    """Check ``df`` against the schema and return it with canonical dtypes.

    Args:
        df: The log.
        source: The file it came from, for messages.
        line_of: Row index -> CSV line number, for messages.

    Raises:
        EventLogError: the first problem found, naming column and row.
    """
    at = _Where(df, source, line_of)
    missing = [c.name for c in REQUIRED if c.name not in df.columns]
    if missing:
        raise EventLogError(f"{at.pre}missing required column(s) {missing}")
    if dup := sorted(df.columns[df.columns.duplicated()]):
        raise EventLogError(f"{at.pre}duplicate column(s) {dup}")
    out = df.copy()
    for col in (c for c in REQUIRED + OPTIONAL if c.name in df.columns):
        out[col.name] = _coerce(out[col.name], col, at)
    at = _Where(out, source, line_of)
    _check_order(out, at)
    return out


def _check_order(out: pd.DataFrame, at: _Where) -> None:
    """Within each run (runs may interleave): events strictly increasing, times not
    falling, and ``failed`` only on the run's last event."""
    codes = pd.factorize(out["run_id"])[0]
    order = np.argsort(codes, kind="stable")
    same = codes[order][1:] == codes[order][:-1]
    for name, strict in (("event", True), ("time_s", False)):
        if name not in out:
            continue
        x = out[name].to_numpy()[order]
        bad = np.flatnonzero(same & ((x[1:] <= x[:-1]) if strict else (x[1:] < x[:-1])))
        if bad.size:
            j, what = bad[0], "does not increase" if strict else "goes back in time"
            msg = f"{x[j + 1]:g} {what} (previous value in this run is {x[j]:g})"
            raise at.error(name, int(order[j + 1]), msg)
    early = out[FAILED].to_numpy(dtype=bool)[order] & np.append(same, False) if FAILED in out else 0
    if np.any(early):
        j = int(np.argmax(early))
        msg = f"true, but the run goes on to event {out['event'].to_numpy()[order][j + 1]}"
        raise at.error(FAILED, int(order[j]), msg + " (failed marks a run's last event)")


def _coerce(s: pd.Series, col: Column, at: _Where) -> pd.Series:
    """Convert one column to its kind, then check missing values and range."""
    if isinstance(s.dtype, pd.CategoricalDtype) and col.kind != "str":
        s = s.astype(object)
    if col.kind == "str":
        return _coerce_str(s, col, at)
    if col.kind == "bool":
        return _coerce_bool(s, col, at)
    if s.dtype == bool or s.dtype.kind in "mMcSV":
        raise EventLogError(f"{at.pre}column '{col.name}': expected numbers, got {s.dtype} values")
    num = pd.to_numeric(s, errors="coerce")
    not_number = np.flatnonzero((num.isna() & s.notna()).to_numpy())
    if not_number.size:  # the text "NaN" is a missing value, like an empty field
        text = s.iloc[not_number].astype(str).str.strip().str.lower()
        other = not_number[(text != "nan").to_numpy()]
        if other.size:
            i = int(other[0])
            raise at.error(col.name, i, f"expected a number, got {_show(s.iloc[i])}")
    x = num.to_numpy(dtype=np.float64, na_value=np.nan)
    nan = np.isnan(x)
    if nan.any() and not col.nan_ok:
        raise at.error(col.name, int(np.argmax(nan)), "missing value (NaN)")
    below = (x <= col.lo) if col.lo_open else (x < col.lo)
    bad = np.isinf(x) | below | (x > col.hi)
    if bad.any():
        i, lo = int(np.argmax(bad)), "(" if col.lo_open else "["
        rng = f"{lo}{col.lo:g}, {col.hi:g}] {col.unit}"
        raise at.error(
            col.name, i, f"value {x[i]:g} is outside the physically possible range {rng}"
        )
    if col.kind == "int":
        frac = ~nan & (x != np.round(x))
        if frac.any():
            i = int(np.argmax(frac))
            raise at.error(col.name, i, f"expected an integer, got {float(x[i])!r}")
        return pd.Series(x.astype(np.int64), index=s.index, name=col.name)
    return pd.Series(x, index=s.index, name=col.name)


def _show(v: object) -> str:
    text = repr(v) if isinstance(v, bytes) or not str(v).isprintable() else f"'{v}'"
    return text if len(text) <= 40 else text[:37] + "...'"  # not a whole multi-line field


def _coerce_str(s: pd.Series, col: Column, at: _Where) -> pd.Series:
    isna = s.isna().to_numpy()
    if isna.any():
        raise at.error(col.name, int(np.argmax(isna)), "missing value")
    if s.dtype.kind == "f" or s.dtype == bool:
        raise EventLogError(f"{at.pre}column '{col.name}': expected text, got {s.dtype} values")
    if isinstance(s.dtype, pd.CategoricalDtype):
        cat = s.cat.rename_categories([str(c) for c in s.cat.categories])
        blank = cat.cat.categories.str.strip() == ""
        empty = np.isin(cat.cat.codes.to_numpy(), np.flatnonzero(blank))
        out: pd.Series = cat
    else:
        out = s.astype(str)
        empty = (out.astype(str).str.strip() == "").to_numpy()
    if empty.any():
        raise at.error(col.name, int(np.argmax(empty)), "empty value")
    return out


def _coerce_bool(s: pd.Series, col: Column, at: _Where) -> pd.Series:
    if s.dtype == bool:
        return s
    mapping = {"true": True, "false": False, "1": True, "0": False, "1.0": True, "0.0": False}
    low = s.astype(str).str.strip().str.lower()
    bad = ~low.isin(list(mapping)).to_numpy()
    if bad.any():
        i = int(np.argmax(bad))
        raise at.error(col.name, i, f"expected a boolean, got {_show(s.iloc[i])}")
    return low.map(mapping).astype(bool)


def read_event_log(path: str | os.PathLike[str]) -> pd.DataFrame:
    """Read and validate a ``.parquet`` or ``.csv`` event log.

    A CSV must be UTF-8 text whose last line ends with a line break (else it may be cut
    off); empty lines are skipped. A Parquet file written by :func:`write_event_log`
    carries page and footer checksums, which are verified.

    Raises:
        FileNotFoundError: no such file.
        EventLogError: anything wrong with it, naming the file, column and row or line.
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"event log {path} does not exist")
    if not path.is_file():
        raise EventLogError(f"{path}: not a file; give one event log (.parquet or .csv)")
    suffix, line_of = path.suffix.lower(), None
    if suffix not in (".parquet", ".csv"):
        raise EventLogError(f"{path}: unsupported file type {suffix!r}; use .parquet or .csv")
    if suffix == ".parquet":
        df = _read_parquet(path)
    else:
        df, line_of = _read_csv(path), _CsvLines(path)
    if len(df) == 0:
        raise EventLogError(f"{path}: no rows (an empty log; only a header?)")
    return validate_event_log(df, str(path), line_of)


def _check_header(path: Path, names: list[str]) -> None:
    if not names:
        raise EventLogError(f"{path}: no columns (empty file?)")
    if dup := sorted({c for c in names if names.count(c) > 1}):
        raise EventLogError(f"{path}: duplicate column(s) {dup}")


# ---------------------------------------------------------------------- Parquet
def _type_ok(kind: str, t: pa.DataType) -> bool:
    t = t.value_type if pa.types.is_dictionary(t) else t
    text = pa.types.is_string(t) or pa.types.is_large_string(t) or pa.types.is_string_view(t)
    if text or pa.types.is_null(t) or pa.types.is_integer(t):
        return True
    if kind == "bool":
        return bool(pa.types.is_boolean(t))
    return kind != "str" and bool(pa.types.is_floating(t) or pa.types.is_decimal(t))


def _read_parquet(path: Path) -> pd.DataFrame:
    try:
        pf = pq.ParquetFile(path, page_checksum_verification=True)
        schema = pf.schema_arrow
    except (pa.ArrowException, OSError, ValueError) as e:
        raise EventLogError(f"{path}: not a readable Parquet file ({e})") from None
    _check_header(path, list(schema.names))
    for f in schema:
        col = COLUMNS.get(f.name)
        if col is not None and not _type_ok(col.kind, f.type):
            want = {"str": "text", "bool": "booleans"}.get(col.kind, f"numbers in {col.unit}")
            raise EventLogError(
                f"{path}: column '{f.name}': Parquet type {f.type} where the schema wants {want}"
            )
    damaged = (pa.ArrowException, OSError, ValueError, KeyError, TypeError, IndexError)
    try:
        table = pf.read()
    except damaged as e:
        raise EventLogError(f"{path}: damaged Parquet data ({e})") from None
    if not parquet_footer_ok(pf.metadata.metadata, table):
        raise EventLogError(f"{path}: damaged Parquet file (the footer fails its checksum)")
    try:
        return table.to_pandas()
    except damaged as e:
        raise EventLogError(f"{path}: damaged Parquet data ({e})") from None


# ---------------------------------------------------------------------- CSV
def _records(path: Path) -> Iterator[tuple[int, int, list[str]]]:
    """(row, first line, fields) of every CSV record, header row -1, as pyarrow reads
    them: empty lines skipped, a quoted field may span lines; bytes that are not UTF-8
    arrive as lone surrogates."""
    with open(path, encoding="utf-8-sig", errors="surrogateescape", newline="") as f:
        reader, end, row = csv.reader(f), 0, -2
        for rec in reader:
            start, end = end + 1, reader.line_num
            if rec:
                row += 1
                yield row, start, rec


def _not_utf8(text: str) -> int | None:
    """The first byte of ``text`` that was not UTF-8, or None."""
    bad = next((c for c in text if "\udc80" <= c <= "\udcff"), None)
    return None if bad is None else ord(bad) - 0xDC00


class _CsvLines:
    """Row -> first CSV line of the row, computed once when an error needs it."""

    def __init__(self, path: Path) -> None:
        self.path, self.lines = path, np.empty(0, dtype=np.int64)

    def __call__(self, i: int) -> int | None:
        if not self.lines.size:
            try:
                self.lines = np.array([ln for r, ln, _ in _records(self.path) if r >= 0])
            except csv.Error:  # a field over csv.field_size_limit(): name no line
                return None
        return int(self.lines[i]) if i < self.lines.size else None


def _csv_problem(path: Path, header: list[str]) -> str | None:
    """The first record that is not UTF-8 or has the wrong number of fields."""
    try:
        for row, line, rec in _records(path):
            bad = next(((j, b) for j, v in enumerate(rec) if (b := _not_utf8(v)) is not None), None)
            if bad is not None:
                j, b = bad
                name = f"column '{header[j]}', " if row >= 0 and j < len(header) else ""
                return f"{name}row {row} (CSV line {line}): not UTF-8 text (byte 0x{b:02x})"
            if len(rec) != len(header):
                n = f"{len(rec)} fields, the header has {len(header)}"
                return f"CSV line {line} (row {row}) has {n}"
    except csv.Error as e:
        return f"not readable as CSV ({e})"
    return None


def _read_csv(path: Path) -> pd.DataFrame:
    """Every column as text, so a stray word is reported by column and row; only empty
    fields are missing, so a run called "NA" stays a run called "NA"."""
    try:
        header = next((rec for row, _, rec in _records(path) if row == -1), [])
    except csv.Error as e:
        raise EventLogError(f"{path}: not readable as CSV ({e})") from None
    if any(_not_utf8(c) is not None for c in header):
        raise EventLogError(f"{path}: the header is not UTF-8 text; save the file as UTF-8")
    _check_header(path, header)
    with open(path, "rb") as f:
        f.seek(-1, os.SEEK_END)
        if f.read(1) not in b"\r\n":
            raise EventLogError(
                f"{path}: the last line has no line end, so the file may be cut off; if it"
                " is complete, end it with a line break"
            )
    opts = pa_csv.ConvertOptions(
        column_types={c: pa.string() for c in header}, null_values=[""], strings_can_be_null=True
    )
    try:  # newlines_in_values: a quoted field may span lines (RFC 4180)
        table = pa_csv.read_csv(
            path, parse_options=pa_csv.ParseOptions(newlines_in_values=True), convert_options=opts
        )
    except pa.ArrowException as e:
        raise EventLogError(f"{path}: {_csv_problem(path, header) or e}") from None
    return table.to_pandas()


def write_event_log(df: pd.DataFrame, path: str | os.PathLike[str]) -> Path:
    """Write an event log as Parquet (:func:`brake_env.output.write_parquet`: zstd, page
    and footer checksums) or CSV, chosen by the file suffix, atomically."""
    path, suffix = Path(path), Path(path).suffix.lower()
    if suffix not in (".parquet", ".csv"):
        raise ValueError(f"unsupported file type {suffix!r}; use .parquet or .csv")
    table = pa.Table.from_pandas(df, preserve_index=False)
    if suffix == ".parquet":
        return write_parquet(table, path)
    with atomic_path(path) as tmp:
        pa_csv.write_csv(table, tmp)
    return path
