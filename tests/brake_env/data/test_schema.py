import numpy as np
import pandas as pd
import pytest

from brake_env.data.schema import (
    SENSOR_CHANNELS,
    EventLogError,
    read_event_log,
    validate_event_log,
    write_event_log,
)


def good_log(n: int = 6) -> pd.DataFrame:
    return pd.DataFrame(
        {
            "run_id": ["a"] * (n // 2) + ["b"] * (n - n // 2),
            "event": list(range(n // 2)) + list(range(n - n // 2)),
            "speed_kmh": np.linspace(5, 14, n),
            "mass_kg": np.full(n, 48e3),
            "slope_rad": np.full(n, 0.1),
            "energy_j": np.full(n, 1.5e5),
            "temp_c": np.linspace(450, 520, n),
            "stop_dist_m": np.full(n, 2.0),
            "volume_frac": np.linspace(1.0, 0.9, n),
            "failed": [False] * n,
        }
    )


def test_good_log_passes_and_keeps_unknown_columns() -> None:
    df = good_log()
    df["driver"] = "x"
    out = validate_event_log(df)
    assert list(out.columns) == list(df.columns)
    assert out["event"].dtype == np.int64


@pytest.mark.parametrize("channel", SENSOR_CHANNELS)
def test_nan_in_a_sensor_channel_is_a_dropout_not_an_error(channel) -> None:
    df = good_log()
    df.loc[2, channel] = np.nan
    assert np.isnan(validate_event_log(df)[channel].iloc[2])


def test_sensor_channels_are_the_measured_ones() -> None:
    assert set(SENSOR_CHANNELS) == {
        "speed_kmh",
        "mass_kg",
        "slope_rad",
        "energy_j",
        "temp_c",
        "stop_dist_m",
    }


def test_interleaved_runs_are_fine() -> None:
    df = good_log().iloc[[0, 3, 1, 4, 2, 5]].reset_index(drop=True)
    validate_event_log(df)


@pytest.mark.parametrize(
    ("mutate", "expected"),
    [
        (lambda d: d.drop(columns=["temp_c"]), r"missing required column\(s\) \['temp_c'\]"),
        (
            lambda d: d.assign(temp_c=d["temp_c"].astype(object).where(d.index != 4, "hot")),
            r"column 'temp_c', row 4.*expected a number, got 'hot'",
        ),
        (
            lambda d: d.assign(event=d["event"].astype(float).where(d.index != 1, np.nan)),
            r"column 'event', row 1.*missing value",
        ),
        (
            lambda d: d.assign(event=d["event"].astype(float).where(d.index != 1, 0.5)),
            r"column 'event', row 1.*expected an integer",
        ),
        (
            lambda d: d.assign(event=[0, 2, 2, 0, 1, 2]),
            r"column 'event', row 2, run 'a': 2 does not increase \(previous value.* is 2\)",
        ),
        (
            lambda d: d.assign(mass_kg=d["mass_kg"].where(d.index != 3, -5.0)),
            r"column 'mass_kg', row 3.*outside the physically possible range",
        ),
        (
            lambda d: d.assign(temp_c=d["temp_c"].where(d.index != 5, -300.0)),
            r"column 'temp_c', row 5.*-300",
        ),
        (
            lambda d: d.assign(volume_frac=d["volume_frac"].where(d.index != 0, 1.5)),
            r"column 'volume_frac', row 0",
        ),
        (lambda d: d.assign(failed=["no", *[False] * 5]), r"column 'failed', row 0.*boolean"),
        (lambda d: d.assign(run_id=[None, *["a"] * 2, *["b"] * 3]), r"column 'run_id', row 0"),
        (
            lambda d: d.assign(energy_j=d["energy_j"].where(d.index != 2, np.inf)),
            r"column 'energy_j', row 2.*value inf is outside",
        ),
        (
            lambda d: d.assign(mass_kg=d["mass_kg"].where(d.index != 1, 0.0)),
            r"column 'mass_kg', row 1.*range \(0, ",
        ),
        (
            lambda d: d.assign(event=d["event"].astype(float).where(d.index != 4, 1e19)),
            r"column 'event', row 4.*value 1e\+19 is outside the physically possible range",
        ),
        (
            lambda d: d.assign(event=[True, False, True, False, True, False]),
            r"column 'event': expected numbers, got bool values",
        ),
        (
            lambda d: d.assign(time_s=[0.0, 5.0, 4.0, 0.0, 1.0, 2.0]),
            r"column 'time_s', row 2, run 'a': 4 goes back in time",
        ),
    ],
    ids=[
        "missing",
        "wrong-type",
        "nan",
        "fraction",
        "order",
        "neg-mass",
        "cold",
        "volume",
        "bool",
        "no-run",
        "infinite",
        "zero-mass",
        "int-overflow",
        "bool-event",
        "time-back",
    ],
)
def test_bad_input_gets_one_clear_error(mutate, expected) -> None:
    with pytest.raises(EventLogError, match=expected):
        validate_event_log(mutate(good_log()))


def test_csv_errors_give_the_file_line(tmp_path) -> None:
    df = good_log()
    path = tmp_path / "log.csv"
    write_event_log(df, path)
    text = path.read_text().splitlines()
    text[3] = text[3].replace('"a",2,', '"a",zwei,')  # row 2 of the data is line 4 of the file
    path.write_text("\n".join(text) + "\n")
    with pytest.raises(EventLogError, match=r"log.csv: column 'event', row 2 \(CSV line 4\)"):
        read_event_log(path)


def test_unsupported_or_missing_file(tmp_path) -> None:
    (tmp_path / "log.xlsx").write_text("x")
    with pytest.raises(EventLogError, match="unsupported file type"):
        read_event_log(tmp_path / "log.xlsx")
    with pytest.raises(FileNotFoundError):
        read_event_log(tmp_path / "none.parquet")


def _csv(tmp_path, text: str):
    path = tmp_path / "log.csv"
    path.write_text(text)
    return path


HEADER = "run_id,event,speed_kmh,mass_kg,slope_rad,energy_j,temp_c,stop_dist_m\n"


@pytest.mark.parametrize(
    ("body", "expected"),
    [
        ("a,0,5,48000,0.1,1e5,450,2\na,1,5,48000\n", r"CSV line 3 \(row 1\) has 4 fields"),
        ("a,0,5,48000,0.1,1e5,450,2,9\n", r"CSV line 2 \(row 0\) has 9 fields"),
        ('a,0,5,48000,0.1,1e5,"450,2\n', r"CSV line 2 \(row 0\) has 7 fields"),
    ],
    ids=["short-row", "long-row", "open-quote"],
)
def test_ragged_csv_rows_are_named_by_line(tmp_path, body, expected) -> None:
    with pytest.raises(EventLogError, match=expected):
        read_event_log(_csv(tmp_path, HEADER + body))


def test_csv_header_problems(tmp_path) -> None:
    with pytest.raises(EventLogError, match="no columns"):
        read_event_log(_csv(tmp_path, ""))
    dup = HEADER.replace("stop_dist_m", "temp_c")
    with pytest.raises(EventLogError, match=r"duplicate column\(s\) \['temp_c'\]"):
        read_event_log(_csv(tmp_path, dup + "a,0,5,48000,0.1,1e5,450,2\n"))


def test_a_run_called_na_is_a_run(tmp_path) -> None:
    df = read_event_log(_csv(tmp_path, HEADER + "NA,0,5,48000,0.1,1e5,450,2\n"))
    assert df["run_id"].tolist() == ["NA"]


def test_parquet_problems(tmp_path) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    good = tmp_path / "good.parquet"
    write_event_log(good_log(), good)
    raw = bytearray(good.read_bytes())
    raw[4:200] = b"\xff" * 196  # garble the first data pages, keep the footer and schema
    (tmp_path / "damaged.parquet").write_bytes(bytes(raw))
    with pytest.raises(EventLogError, match="damaged Parquet data"):
        read_event_log(tmp_path / "damaged.parquet")
    (tmp_path / "junk.parquet").write_bytes(b"not parquet at all")
    with pytest.raises(EventLogError, match="not a readable Parquet file"):
        read_event_log(tmp_path / "junk.parquet")
    t = pa.Table.from_arrays([pa.array([1.0]), pa.array([2.0])], names=["temp_c", "temp_c"])
    pq.write_table(t, tmp_path / "dup.parquet")
    with pytest.raises(EventLogError, match="duplicate column"):
        read_event_log(tmp_path / "dup.parquet")


# ---------------------------------------------------------------------- reader gaps
def test_every_numeric_column_has_finite_physical_bounds() -> None:
    from brake_env.data.schema import COLUMNS

    for c in COLUMNS.values():
        if c.kind in ("int", "float"):
            assert np.isfinite(c.lo) and np.isfinite(c.hi) and c.lo < c.hi, c.name


@pytest.mark.parametrize("column", ["energy_j", "stop_dist_m", "speed_kmh", "time_s", "event"])
def test_impossible_magnitudes_are_refused_by_column_and_row(tmp_path, column) -> None:
    df = good_log().assign(time_s=np.arange(6.0))
    df[column] = df[column].astype(float)
    df.loc[4, column] = 1e300
    for suffix in (".csv", ".parquet"):
        path = write_event_log(df, tmp_path / f"log{suffix}")
        with pytest.raises(EventLogError, match=rf"log{suffix}: column '{column}', row 4"):
            read_event_log(path)


def test_a_csv_that_is_not_utf8_names_the_cell(tmp_path) -> None:
    body = HEADER + "a,0,5,48000,0.1,1e5,450,2\na,1,5,48000,0.1,1e5,4\xe950,2\n"
    path = tmp_path / "log.csv"
    path.write_bytes(body.encode("latin-1"))
    with pytest.raises(
        EventLogError, match=r"column 'temp_c', row 1 \(CSV line 3\): not UTF-8 text \(byte 0xe9"
    ):
        read_event_log(path)


def test_a_directory_or_a_header_only_file_is_refused(tmp_path) -> None:
    (tmp_path / "logs.csv").mkdir()
    with pytest.raises(EventLogError, match="not a file"):
        read_event_log(tmp_path / "logs.csv")
    with pytest.raises(EventLogError, match="no rows"):
        read_event_log(_csv(tmp_path, HEADER))
    path = write_event_log(good_log().iloc[:0], tmp_path / "empty.parquet")
    with pytest.raises(EventLogError, match="no rows"):
        read_event_log(path)


def test_a_csv_without_a_final_line_end_may_be_cut_off(tmp_path) -> None:
    with pytest.raises(EventLogError, match="no line end, so the file may be cut off"):
        read_event_log(_csv(tmp_path, HEADER + "a,0,5,48000,0.1,1e5,450,2"))


def test_empty_run_ids_are_refused_in_both_formats(tmp_path) -> None:
    df = good_log()
    df.loc[3, "run_id"] = ""
    with pytest.raises(EventLogError, match=r"column 'run_id', row 3 \(CSV line 5\): missing"):
        read_event_log(write_event_log(df, tmp_path / "log.csv"))
    with pytest.raises(EventLogError, match=r"column 'run_id', row 3: empty value"):
        read_event_log(write_event_log(df, tmp_path / "log.parquet"))


def test_nan_text_in_a_sensor_channel_is_a_dropout(tmp_path) -> None:
    body = "a,0,5,48000,0.1,1e5,NaN,2\na,1,nan,48000,0.1,1e5,450, NaN \n"
    df = read_event_log(_csv(tmp_path, HEADER + body))
    assert np.isnan(df["temp_c"][0]) and np.isnan(df["speed_kmh"][1])
    assert np.isnan(df["stop_dist_m"][1]) and df["temp_c"][1] == 450.0
    with pytest.raises(EventLogError, match=r"column 'event', row 1 \(CSV line 3\).*missing"):
        read_event_log(_csv(tmp_path, HEADER + "a,0,5,48000,0.1,1e5,450,2\na,NaN,5,1,0,1,1,1\n"))


def test_csv_lines_count_blank_lines_and_multi_line_fields(tmp_path) -> None:
    body = '\n"pad\none",0,5,48000,0.1,1e5,450,2\n\n"pad\none",1,5,48000,0.1,1e5,hot,2\n'
    with pytest.raises(EventLogError, match=r"row 1 \(CSV line 6\), run 'pad\\none'"):
        read_event_log(_csv(tmp_path, HEADER + body))
    ok = read_event_log(_csv(tmp_path, HEADER + body.replace("hot", "451")))
    assert ok["run_id"].tolist() == ["pad\none"] * 2 and ok["temp_c"].tolist() == [450, 451]


def test_parquet_timestamps_and_bytes_are_not_numbers_or_names(tmp_path) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    df = good_log().assign(time_s=pd.to_datetime(np.arange(6), unit="s"))
    pq.write_table(pa.Table.from_pandas(df), tmp_path / "ts.parquet")
    with pytest.raises(EventLogError, match=r"column 'time_s': Parquet type timestamp"):
        read_event_log(tmp_path / "ts.parquet")
    df = good_log().assign(run_id=[b"a"] * 3 + [b"b"] * 3)
    pq.write_table(pa.Table.from_pandas(df), tmp_path / "bin.parquet")
    with pytest.raises(EventLogError, match=r"column 'run_id': Parquet type binary"):
        read_event_log(tmp_path / "bin.parquet")


def test_parquet_written_here_refuses_flipped_bits(tmp_path) -> None:
    """Page CRCs and the footer checksum: of 200 single-bit flips none reads as other data."""
    path = write_event_log(good_log(), tmp_path / "log.parquet")
    raw, want = path.read_bytes(), read_event_log(path)
    rng = np.random.default_rng(0)
    refused = 0
    for _ in range(200):
        b = bytearray(raw)
        b[int(rng.integers(len(b)))] ^= 1 << int(rng.integers(8))
        path.write_bytes(bytes(b))
        try:
            got = read_event_log(path)
        except EventLogError:
            refused += 1
            continue
        pd.testing.assert_frame_equal(got, want)
    assert refused > 100


def test_failed_marks_only_a_runs_last_event_and_volumes_are_fractions() -> None:
    df = good_log().assign(failed=[False, True, False, False, False, True])
    with pytest.raises(EventLogError, match=r"column 'failed', row 1, run 'a': true, but the"):
        validate_event_log(df)
    censored = good_log().assign(
        failed=[False] * 6, measured_volume_frac=[np.nan, np.nan, 0.4, np.nan, np.nan, 0.7]
    )
    out = validate_event_log(censored)  # runs removed before failure, volumes measured
    assert out["measured_volume_frac"].iloc[2] == 0.4
    with pytest.raises(EventLogError, match=r"column 'measured_volume_frac', row 5"):
        validate_event_log(censored.assign(measured_volume_frac=[np.nan] * 5 + [1.3]))
