"""Malformed event logs from a seeded generator, each with what it means (docs/schema.md):
the reader must either load it with that meaning or raise one EventLogError naming
the file and, where a cell is at fault, its column and row.

Used by ``scripts/probes/fuzz_reader.py`` (which prints the counts) and
``tests/brake_env/data/test_reader_fuzz.py``.
"""

from __future__ import annotations

import atexit
import csv
import io
import shutil
import tempfile
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from unittest import mock

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from brake_env.data.schema import COLUMNS, EventLogError, read_event_log, write_event_log

SENSORS = ("speed_kmh", "mass_kg", "slope_rad", "energy_j", "temp_c", "stop_dist_m")
REQUIRED = ("run_id", "event", *SENSORS)
OPTIONAL = ("time_s", "ambient_c", "failed", "measured_volume_frac", "rul_events", "note")


@dataclass
class Case:
    """One generated log.

    Attributes:
        kind: The mutation.
        fmt: ``csv`` or ``parquet``.
        content: The file's bytes.
        meaning: What the file says when it is valid; None when it must be refused.
        must_load: The file is valid: refusing it is a failure too.
        column, row: The cell an error must name (None: not checked).
        line: The CSV line an error must name (None: not checked).
    """

    kind: str
    fmt: str
    content: bytes
    meaning: pd.DataFrame | None
    must_load: bool = False
    column: str | None = None
    row: int | None = None
    line: int | None = None


# ---------------------------------------------------------------------- a valid log
def base_log(rng: np.random.Generator) -> pd.DataFrame:
    """1-3 runs of 2-7 events in the schema, some starting mid-life, some dropouts."""
    sizes = rng.integers(2, 8, int(rng.integers(1, 4)))
    n, ends = int(sizes.sum()), np.cumsum(sizes)
    names = [str(rng.choice(["pad-", "NA", "Rad ", "x,y "])) + str(r) for r in range(sizes.size)]
    event = np.concatenate(
        [
            s0 + np.cumsum(rng.integers(1, 3, k)) - 1
            for s0, k in zip(rng.choice([0, 0, 30_000], sizes.size), sizes, strict=True)
        ]
    )
    failed = np.zeros(n, bool)
    failed[ends - 1] = rng.random(sizes.size) < 0.5
    d = {
        "run_id": np.repeat(names, sizes),
        "event": event,
        "speed_kmh": rng.uniform(1, 60, n),
        "mass_kg": rng.uniform(2e4, 6e4, n),
        "slope_rad": rng.uniform(-0.2, 0.2, n),
        "energy_j": rng.uniform(1e4, 1e6, n),
        "temp_c": rng.uniform(20, 600, n),
        "stop_dist_m": rng.uniform(0, 50, n),
        "time_s": event * 60.0 + rng.uniform(0, 30, n),
        "ambient_c": rng.uniform(-20, 40, n),
        "failed": failed,
        "measured_volume_frac": np.where(rng.random(n) < 0.3, rng.uniform(0, 1, n), np.nan),
        "rul_events": np.repeat(ends, sizes) - np.arange(n) + int(rng.integers(0, 100)),
        "note": rng.choice(["ok", "x", "a b"], n),
    }
    for ch in SENSORS:  # dropouts
        d[ch][rng.random(n) < 0.08] = np.nan
    keep = set(REQUIRED) | {c for c in OPTIONAL if rng.random() < 0.5}
    return pd.DataFrame({k: v for k, v in d.items() if k in keep})


def _cell(v: object) -> str:
    if isinstance(v, bool | np.bool_):
        return "true" if v else "false"
    if isinstance(v, float | np.floating):
        return "" if np.isnan(v) else repr(float(v))
    return str(v)


@dataclass
class CsvText:
    """A CSV as records (the header first) and blank lines before records, to be edited."""

    records: list[list[str]]
    blank_before: dict[int, int] = field(default_factory=dict)
    crlf: bool = False

    @classmethod
    def of(cls, df: pd.DataFrame) -> CsvText:
        rows = [[_cell(v) for v in r] for r in df.itertuples(index=False)]
        return cls([list(df.columns), *rows])

    def render(self) -> tuple[bytes, list[int]]:
        """The bytes, and the first line of each data row."""
        out, lines, line = [], [], 1
        for k, rec in enumerate(self.records):
            nb = self.blank_before.get(k, 0)
            out.append("\n" * nb)
            line += nb
            buf = io.StringIO()
            csv.writer(buf, lineterminator="\n").writerow(rec)
            if k:
                lines.append(line)
            out.append(buf.getvalue())
            line += buf.getvalue().count("\n")
        text = "".join(out)
        return (text.replace("\n", "\r\n") if self.crlf else text).encode(), lines


_SCRATCH: list[Path] = []


def _parquet(df: pd.DataFrame, checksums: bool = True) -> bytes:
    """Through the project's writer (page and footer checksums), or a plain pyarrow file."""
    if checksums:
        if not _SCRATCH:
            _SCRATCH.append(Path(tempfile.mkdtemp(prefix="fuzz-")))
            atexit.register(shutil.rmtree, _SCRATCH[0], ignore_errors=True)
        with mock.patch("brake_env.output._fsync"):  # durability is not the point here
            return write_event_log(df, _SCRATCH[0] / "w.parquet").read_bytes()
    buf = io.BytesIO()
    pq.write_table(pa.Table.from_pandas(df, preserve_index=False), buf)
    return buf.getvalue()


# ---------------------------------------------------------------------- mutations
Mutation = Callable[[pd.DataFrame, np.random.Generator, str], Case]


def _row(df: pd.DataFrame, rng: np.random.Generator) -> int:
    return int(rng.integers(len(df)))


def _num_col(df: pd.DataFrame, rng: np.random.Generator, sensors_only: bool = False) -> str:
    cols = [c for c in df.columns if COLUMNS.get(c) and COLUMNS[c].kind in ("int", "float")]
    if sensors_only:
        cols = [c for c in cols if c in SENSORS]
    return str(rng.choice(cols))


def _emit(kind: str, df: pd.DataFrame, fmt: str, **kw: object) -> Case:
    """A Case of the frame ``df`` written as is (valid or not)."""
    if fmt == "csv":
        content, lines = CsvText.of(df).render()
        row = kw.get("row")
        kw.setdefault("line", lines[row] if isinstance(row, int) and row < len(lines) else None)
    else:
        content = _parquet(df)
    return Case(kind, fmt, content, **kw)  # type: ignore[arg-type]


def m_valid(df: pd.DataFrame, rng: np.random.Generator, fmt: str) -> Case:
    return _emit("valid", df, fmt, meaning=df, must_load=True)


def m_drop_column(df: pd.DataFrame, rng: np.random.Generator, fmt: str) -> Case:
    col = str(rng.choice(list(df.columns)))
    out = df.drop(columns=col)
    if col in REQUIRED:
        return _emit("drop-required", out, fmt, meaning=None, column=col)
    return _emit("drop-optional", out, fmt, meaning=out, must_load=True)


def m_rename_column(df: pd.DataFrame, rng: np.random.Generator, fmt: str) -> Case:
    col = str(rng.choice(list(df.columns)))
    out = df.rename(columns={col: col + "_x"})
    if col in REQUIRED:
        return _emit("rename-required", out, fmt, meaning=None, column=col)
    return _emit("rename-optional", out, fmt, meaning=out, must_load=True)


def m_word(df: pd.DataFrame, rng: np.random.Generator, fmt: str) -> Case:
    col, i = _num_col(df, rng), _row(df, rng)
    out = df.assign(**{col: [None if pd.isna(v) else _cell(v) for v in df[col]]})  # text
    out.loc[i, col] = str(rng.choice(["hot", "1,5", "12 m", "0x1F", "--"]))
    return _emit("wrong-type", out, fmt, meaning=None, column=col, row=i)


def m_huge(df: pd.DataFrame, rng: np.random.Generator, fmt: str) -> Case:
    col, i = _num_col(df, rng), _row(df, rng)
    out = df.astype({col: np.float64})
    out.loc[i, col] = float(rng.choice([1e300, -1e300, 1e12, -1e12]))
    return _emit("huge", out, fmt, meaning=None, column=col, row=i)


def m_infinite(df: pd.DataFrame, rng: np.random.Generator, fmt: str) -> Case:
    col, i = _num_col(df, rng), _row(df, rng)
    out = df.astype({col: np.float64})
    out.loc[i, col] = float(rng.choice([np.inf, -np.inf]))
    if fmt == "csv":  # text spellings of infinity
        t = CsvText.of(df)
        t.records[i + 1][list(df.columns).index(col)] = str(rng.choice(["inf", "-Infinity"]))
        content, lines = t.render()
        return Case("infinite", fmt, content, None, column=col, row=i, line=lines[i])
    return _emit("infinite", out, fmt, meaning=None, column=col, row=i)


def m_nan(df: pd.DataFrame, rng: np.random.Generator, fmt: str) -> Case:
    col, i = _num_col(df, rng), _row(df, rng)
    out = df.astype({col: np.float64})
    out.loc[i, col] = np.nan
    ok = COLUMNS[col].nan_ok
    if fmt == "csv":  # NaN written as text, as spreadsheets do
        t = CsvText.of(df)
        t.records[i + 1][list(df.columns).index(col)] = str(rng.choice(["NaN", "nan", ""]))
        content, lines = t.render()
        if ok:
            return Case("nan-dropout", fmt, content, out, must_load=True)
        return Case("nan-required", fmt, content, None, column=col, row=i, line=lines[i])
    if ok:
        return _emit("nan-dropout", out, fmt, meaning=out, must_load=True)
    return _emit("nan-required", out, fmt, meaning=None, column=col, row=i)


def m_fraction_event(df: pd.DataFrame, rng: np.random.Generator, fmt: str) -> Case:
    i = _row(df, rng)
    out = df.astype({"event": np.float64})
    out.loc[i, "event"] += 0.5
    return _emit("fractional-event", out, fmt, meaning=None, column="event", row=i)


def m_duplicate_row(df: pd.DataFrame, rng: np.random.Generator, fmt: str) -> Case:
    i = _row(df, rng)
    out = pd.concat([df.iloc[: i + 1], df.iloc[i : i + 1], df.iloc[i + 1 :]], ignore_index=True)
    return _emit("duplicate-event", out, fmt, meaning=None, column="event", row=i + 1)


def m_swap_rows(df: pd.DataFrame, rng: np.random.Generator, fmt: str) -> Case:
    pairs = [i for i in range(len(df) - 1) if df.run_id[i] == df.run_id[i + 1]]
    i = int(rng.choice(pairs))
    out = df.iloc[[*range(i), i + 1, i, *range(i + 2, len(df))]].reset_index(drop=True)
    return _emit("events-decrease", out, fmt, meaning=None, column="event", row=i + 1)


def m_interleave(df: pd.DataFrame, rng: np.random.Generator, fmt: str) -> Case:
    """Runs interleaved, each in order: valid."""
    keys = rng.random(len(df))
    for r in pd.unique(df.run_id):  # sorted keys within a run keep its order
        idx = np.flatnonzero(df.run_id == r)
        keys[idx] = np.sort(keys[idx])
    out = df.iloc[np.argsort(keys, kind="stable")].reset_index(drop=True)
    return _emit("interleaved", out, fmt, meaning=out, must_load=True)


def m_empty_run(df: pd.DataFrame, rng: np.random.Generator, fmt: str) -> Case:
    i = _row(df, rng)
    out = df.copy()
    out.loc[i, "run_id"] = str(rng.choice(["", " ", "  "]))
    return _emit("empty-run-id", out, fmt, meaning=None, column="run_id", row=i)


def m_failed_early(df: pd.DataFrame, rng: np.random.Generator, fmt: str) -> Case:
    pairs = [i for i in range(len(df) - 1) if df.run_id[i] == df.run_id[i + 1]]
    i = int(rng.choice(pairs))
    out = df.assign(failed=np.arange(len(df)) == i)
    return _emit("failed-not-last", out, fmt, meaning=None, column="failed", row=i)


def m_volume_range(df: pd.DataFrame, rng: np.random.Generator, fmt: str) -> Case:
    i = _row(df, rng)
    out = df.assign(measured_volume_frac=np.nan)
    out.loc[i, "measured_volume_frac"] = float(rng.choice([1.2, -0.1]))
    return _emit(
        "volume-out-of-range", out, fmt, meaning=None, column="measured_volume_frac", row=i
    )


# ---------------------------------------------------------------------- CSV text
def _text(kind: str, t: CsvText, meaning: pd.DataFrame | None, **kw: object) -> Case:
    content, lines = t.render()
    row = kw.get("row")
    if isinstance(row, int) and "line" not in kw:
        kw["line"] = lines[row]
    return Case(kind, "csv", content, meaning, **kw)  # type: ignore[arg-type]


def c_blank_lines(df: pd.DataFrame, rng: np.random.Generator) -> Case:
    """Empty lines anywhere (skipped), then maybe a bad cell named by its true line."""
    t = CsvText.of(df)
    for k in rng.choice(np.arange(1, len(t.records) + 1), size=3):
        t.blank_before[int(k)] = int(rng.integers(1, 3))
    if rng.random() < 0.5:
        return _text("blank-lines", t, df, must_load=True)
    col, i = _num_col(df, rng), _row(df, rng)
    t.records[i + 1][list(df.columns).index(col)] = "oops"
    return _text("blank-lines-then-bad-cell", t, None, column=col, row=i)


def c_multiline(df: pd.DataFrame, rng: np.random.Generator) -> Case:
    """A quoted run name over two lines (valid), then maybe a bad cell after it."""
    out = df.assign(run_id=df.run_id.str.replace(" ", "\n", regex=False) + "\nz")
    t = CsvText.of(out)
    if rng.random() < 0.5:
        return _text("multiline-field", t, out, must_load=True)
    col, i = _num_col(df, rng), _row(df, rng)
    t.records[i + 1][list(df.columns).index(col)] = "oops"
    return _text("multiline-then-bad-cell", t, None, column=col, row=i)


def c_bad_encoding(df: pd.DataFrame, rng: np.random.Generator) -> Case:
    """A Latin-1 byte (not UTF-8) in a cell or in the header."""
    t = CsvText.of(df)
    if rng.random() < 0.2:
        content = t.render()[0].replace(b"run_id", b"run_\xe9d", 1)
        return Case("non-utf8-header", "csv", content, None)
    i, j = _row(df, rng), int(rng.integers(len(df.columns)))
    t.records[i + 1][j] += "QQ8QQ"
    content, lines = t.render()
    content = content.replace(b"QQ8QQ", bytes([int(rng.choice([0xE9, 0xFC, 0x80, 0xFF]))]))
    col = str(df.columns[j])
    return Case("non-utf8-cell", "csv", content, None, column=col, row=i, line=lines[i])


def c_bom_crlf(df: pd.DataFrame, rng: np.random.Generator) -> Case:
    """A byte-order mark and Windows line ends: valid."""
    t = CsvText.of(df)
    t.crlf = bool(rng.random() < 0.7)
    content = t.render()[0]
    if rng.random() < 0.7:
        content = b"\xef\xbb\xbf" + content
    return Case("bom-crlf", "csv", content, df, must_load=True)


def c_quoted_numbers(df: pd.DataFrame, rng: np.random.Generator) -> Case:
    """Every field quoted, numbers too: valid."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n", quoting=csv.QUOTE_ALL)
    for rec in CsvText.of(df).records:
        w.writerow(rec)
    return Case("quoted-numbers", "csv", buf.getvalue().encode(), df, must_load=True)


def c_ragged(df: pd.DataFrame, rng: np.random.Generator) -> Case:
    t = CsvText.of(df)
    i = _row(df, rng)
    if rng.random() < 0.5:
        t.records[i + 1] = t.records[i + 1][:-1]
    else:
        t.records[i + 1] = [*t.records[i + 1], "9"]
    return _text("ragged-row", t, None, row=i)


def c_truncate(df: pd.DataFrame, rng: np.random.Generator) -> Case:
    """Cut at a random byte: refused unless the cut falls at a line end after a data row,
    which leaves a valid, shorter log (its first rows)."""
    content = CsvText.of(df).render()[0]
    cut = int(rng.integers(1, len(content)))
    if rng.random() < 0.3:  # right after a line end, which random bytes rarely hit
        cut = int(rng.choice([k + 1 for k in range(len(content)) if content[k] == 10]))
    part = content[:cut]
    if part.endswith(b"\n"):
        n = part.count(b"\n") - 1  # data rows kept (no blank lines, no multi-line fields)
        if n > 0:
            return Case("truncated-at-line-end", "csv", part, df.iloc[:n], must_load=True)
    return Case("truncated", "csv", part, None)


def c_header_only(df: pd.DataFrame, rng: np.random.Generator) -> Case:
    content = CsvText.of(df).render()[0]
    choice = int(rng.integers(3))
    if choice == 0:
        return Case("header-only", "csv", content.split(b"\n")[0] + b"\n", None)
    if choice == 1:
        return Case("empty-file", "csv", b"", None)
    dup = content.replace(b"temp_c", b"stop_dist_m", 1)
    return Case("duplicate-header", "csv", dup, None, column="stop_dist_m")


def c_event_text(df: pd.DataFrame, rng: np.random.Generator) -> Case:
    """Integers written as 3.0 and numbers padded with spaces: valid, same values."""
    t = CsvText.of(df)
    j = list(df.columns).index("event")
    for rec in t.records[1:]:
        rec[j] = rec[j] + ".0"
    return _text("event-as-float-text", t, df, must_load=True)


# ---------------------------------------------------------------------- Parquet bytes
def p_bit_flip(df: pd.DataFrame, rng: np.random.Generator) -> Case:
    """1-3 flipped bits anywhere: if it still loads, it must say the same."""
    raw = bytearray(_parquet(df))
    for _ in range(int(rng.integers(1, 4))):
        k = int(rng.integers(len(raw)))
        raw[k] ^= 1 << int(rng.integers(8))
    return Case("bit-flip", "parquet", bytes(raw), df)


def p_garble(df: pd.DataFrame, rng: np.random.Generator) -> Case:
    raw = bytearray(_parquet(df))
    k = int(rng.integers(len(raw) - 16))
    raw[k : k + 16] = rng.integers(0, 256, 16, dtype=np.uint8).tobytes()
    return Case("garbled-bytes", "parquet", bytes(raw), df)


def p_truncate(df: pd.DataFrame, rng: np.random.Generator) -> Case:
    raw = _parquet(df)
    return Case("truncated", "parquet", raw[: int(rng.integers(0, len(raw)))], None)


def p_types(df: pd.DataFrame, rng: np.random.Generator) -> Case:
    """Column types: some carry the same meaning (text numbers, dictionaries, int run ids,
    a plain pyarrow file), others not (timestamps, booleans, bytes, float run ids)."""
    choice = int(rng.integers(7))
    if choice == 0:
        t = df.assign(time_s=pd.to_datetime(np.arange(len(df)), unit="s"))
        return Case("timestamp-time", "parquet", _parquet(t, False), None, column="time_s")
    if choice == 1:
        t = df.assign(event=df.event > 0)
        return Case("bool-event", "parquet", _parquet(t, False), None, column="event")
    if choice == 2:
        t = df.assign(run_id=df.run_id.str.encode("utf-8"))
        return Case("binary-run-id", "parquet", _parquet(t, False), None, column="run_id")
    if choice == 3:
        t = df.assign(run_id=pd.factorize(df.run_id)[0] + 0.5)
        return Case("float-run-id", "parquet", _parquet(t, False), None, column="run_id")
    if choice == 4:
        t = df.assign(event=df.event.astype(str), temp_c=df.temp_c.map(repr))
        meaning = df.assign(temp_c=df.temp_c)
        return Case("numbers-as-text", "parquet", _parquet(t, False), meaning, must_load=True)
    if choice == 5:
        codes = pd.factorize(df.run_id)[0]
        t = df.assign(run_id=codes)
        meaning = df.assign(run_id=[str(c) for c in codes])
        return Case("int-run-id", "parquet", _parquet(t, False), meaning, must_load=True)
    t = df.assign(run_id=pd.Categorical(df.run_id))
    return Case("categorical-plain", "parquet", _parquet(t, False), df, must_load=True)


# ---------------------------------------------------------------------- the generator
FRAME: list[Mutation] = [
    m_valid,
    m_drop_column,
    m_rename_column,
    m_word,
    m_huge,
    m_infinite,
    m_nan,
    m_fraction_event,
    m_duplicate_row,
    m_swap_rows,
    m_interleave,
    m_empty_run,
    m_failed_early,
    m_volume_range,
]
CSV_ONLY = [
    c_blank_lines,
    c_multiline,
    c_bad_encoding,
    c_bom_crlf,
    c_quoted_numbers,
    c_ragged,
    c_truncate,
    c_header_only,
    c_event_text,
]
PARQUET_ONLY = [p_bit_flip, p_bit_flip, p_garble, p_truncate, p_types, p_types]


def generate(n: int, seed: int = 0) -> list[Case]:
    """``n`` cases, half CSV and half Parquet, each from a fresh valid log."""
    rng = np.random.default_rng(seed)
    cases = []
    while len(cases) < n:
        df = base_log(rng)
        if not any(df.run_id[i] == df.run_id[i + 1] for i in range(len(df) - 1)):
            continue
        fmt = "csv" if len(cases) % 2 == 0 else "parquet"
        own = CSV_ONLY if fmt == "csv" else PARQUET_ONLY
        pick = int(rng.integers(len(FRAME) + len(own)))
        if pick < len(FRAME):
            cases.append(FRAME[pick](df, rng, fmt))
        else:
            cases.append(own[pick - len(FRAME)](df, rng))  # type: ignore[call-arg]
    return cases


# ---------------------------------------------------------------------- the judge
def _text_of(v: object) -> str:
    """A cell as comparable text, so a kept unknown column compares across formats (a CSV
    keeps it as text)."""
    if v is None:
        return ""
    if isinstance(v, bool | np.bool_):
        return "true" if v else "false"
    if isinstance(v, str):
        if v.strip().lower() in ("true", "false"):
            return v.strip().lower()
        try:
            v = float(v)
        except ValueError:
            return v
    if isinstance(v, int | float | np.number):
        return "" if np.isnan(float(v)) else repr(float(v))
    return str(v)


def same_meaning(got: pd.DataFrame, want: pd.DataFrame) -> str | None:
    """Why ``got`` does not say what ``want`` says, or None."""
    if list(got.columns) != list(want.columns):
        return f"columns {list(got.columns)} != {list(want.columns)}"
    if len(got) != len(want):
        return f"{len(got)} rows != {len(want)}"
    for c in want.columns:
        kind = COLUMNS[c].kind if c in COLUMNS else None
        a, b = got[c], want[c]
        if kind is None:  # an unknown column: kept as it is, as text from a CSV
            ok = [_text_of(x) for x in a] == [_text_of(x) for x in b]
        elif kind == "str":
            ok = [str(x) for x in a] == [str(x) for x in b]
        elif kind == "bool":
            ok = np.array_equal(a.to_numpy(bool), b.to_numpy(bool))
        else:
            ok = np.array_equal(a.to_numpy(float), b.to_numpy(float), equal_nan=True)
        if not ok:
            return f"column {c!r}: {a.tolist()} != {b.tolist()}"
    return None


def judge(case: Case, path: Path) -> tuple[str, str | None]:
    """(outcome, failure or None) of reading ``case`` written at ``path``."""
    path.write_bytes(case.content)
    try:
        got = read_event_log(path)
    except EventLogError as e:
        msg = str(e)
        if case.must_load:
            return "refused", f"a valid log was refused: {msg}"
        need = [str(path)]
        need += [case.column] if case.column else []
        need += [f"row {case.row}"] if case.row is not None else []
        need += [f"CSV line {case.line}"] if case.line is not None else []
        missing = [w for w in need if w not in msg]
        return "refused", (f"message lacks {missing}: {msg}" if missing else None)
    except Exception as e:  # the point: any other exception is a failure
        return "other-exception", f"{type(e).__name__}: {e}"
    if case.meaning is None:
        return "loaded", "a log that must be refused was loaded"
    why = same_meaning(got, case.meaning)
    outcome = "loaded-prefix" if case.kind == "truncated-at-line-end" else "loaded-intact"
    return outcome, (f"loaded with another meaning: {why}" if why else None)


def run_all(n: int, seed: int, scratch: Path) -> tuple[Counter[str], list[str]]:
    """Counts by (format, outcome) and kind, and the failures."""
    counts: Counter[str] = Counter()
    failures = []
    for k, case in enumerate(generate(n, seed)):
        outcome, failure = judge(case, scratch / f"case{k:04d}.{case.fmt}")
        counts[f"{case.fmt} {outcome}"] += 1
        counts[f"kind {case.kind}"] += 1
        counts[f"outcome {case.fmt} {case.kind}: {outcome}"] += 1
        if failure:
            failures.append(f"case {k} ({case.fmt}, {case.kind}): {failure}")
    return counts, failures
