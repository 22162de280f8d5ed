"""The event-log reader against generated malformed logs (docs/schema.md).

Each of 240 logs (half CSV, half Parquet; ``scripts/probes/fuzz_logs.py``) either loads with
the meaning it was written with, or raises one EventLogError naming the file and, where one
cell is at fault, its column, row and CSV line. Valid variants (blank lines, quoted fields over two
lines, BOM, CRLF, interleaved runs, NaN text in a sensor channel...) must load.
"""

from __future__ import annotations

from scripts.probes.fuzz_logs import generate, judge, run_all

N_CASES = 240


def test_malformed_logs_load_intact_or_get_one_clear_error(tmp_path) -> None:
    counts, failures = run_all(N_CASES, seed=0, scratch=tmp_path)
    outcomes = {k: v for k, v in sorted(counts.items()) if k.startswith(("csv ", "parquet "))}
    print("reader fuzz:", outcomes)
    assert not failures, "\n".join(failures[:20])
    for fmt in ("csv", "parquet"):
        assert counts[f"{fmt} loaded-intact"] >= 20, outcomes
        assert counts[f"{fmt} refused"] >= 50, outcomes
    assert counts["csv other-exception"] == counts["parquet other-exception"] == 0
    assert sum(v for k, v in counts.items() if k.startswith("kind ")) == N_CASES


def test_the_generator_is_seeded() -> None:
    a, b = generate(12, seed=5), generate(12, seed=5)
    assert [(c.kind, c.content) for c in a] == [(c.kind, c.content) for c in b]


def test_the_judge_catches_a_reader_that_lets_bad_logs_through(tmp_path, monkeypatch) -> None:
    """A reader that accepts anything fails the judge: the fuzz test can fail."""
    import pandas as pd

    import scripts.probes.fuzz_logs as fl

    monkeypatch.setattr(fl, "read_event_log", lambda p: pd.DataFrame({"x": [1]}))
    bad = next(c for c in generate(40, seed=1) if c.meaning is None)
    assert judge(bad, tmp_path / f"bad.{bad.fmt}") == (
        "loaded",
        "a log that must be refused was loaded",
    )
