"""User text made inert where people read it (issue 44): pad ids that a spreadsheet would
run as formulas get a leading quote in every CSV cell, numbers stay numbers; pad ids that
matplotlib would parse as mathtext are drawn as they are."""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from brake_env.csv_safe import plain_text, safe_cell, safe_csv, write_csv

# The probe's hostile pad ids, and what a spreadsheet-safe exporter writes for each.
HOSTILE = {
    "=cmd|' /C calc'!A0": "'=cmd|' /C calc'!A0",
    '+HYPERLINK("http://x.example","click")': '\'+HYPERLINK("http://x.example","click")',
    "@SUM(A1:A9)": "'@SUM(A1:A9)",
    "-2+3": "'-2+3",
    "\t=1+1": "'\t=1+1",
    "\r=1+1": "'\r=1+1",
}
HARMLESS = ["A-1", "pad 7", "", " =not first", "'=already quoted", "$x$"]


def written(frame: pd.DataFrame, tmp_path: Path) -> list[dict[str, str]]:
    """The CSV :func:`write_csv` writes, read back cell by cell as text."""
    with open(write_csv(frame, tmp_path / "t.csv"), newline="") as f:
        return list(csv.DictReader(f))


def test_formula_cells_get_a_leading_quote_and_others_are_kept(tmp_path: Path) -> None:
    ids = [*HOSTILE, *HARMLESS]
    rows = written(pd.DataFrame({"run_id": ids, "rul_mean": np.arange(len(ids)) - 3.5}), tmp_path)
    assert [r["run_id"] for r in rows] == [*HOSTILE.values(), *HARMLESS]


def test_numbers_stay_numbers_even_negative(tmp_path: Path) -> None:
    frame = pd.DataFrame({"run_id": ["=A1", "B"], "rul_mean": [-1.5, 2.0], "events": [-3, 4]})
    rows = written(frame, tmp_path)
    assert [r["rul_mean"] for r in rows] == ["-1.5", "2.0"]
    assert [r["events"] for r in rows] == ["-3", "4"]
    back = pd.read_csv(tmp_path / "t.csv")
    assert back["rul_mean"].tolist() == [-1.5, 2.0] and back["events"].dtype.kind == "i"
    mixed = pd.DataFrame({"x": pd.Series([-1.0, "-1", None], dtype=object)})
    assert safe_csv(mixed)["x"].tolist() == [-1.0, "'-1", None]


def test_categorical_and_string_columns_too_and_the_frame_is_not_changed(
    tmp_path: Path,
) -> None:
    frame = pd.DataFrame(
        {
            "run_id": pd.Categorical(["=A1", "B", "=A1"]),
            "note": pd.array(["@x", pd.NA, "y"], dtype="string"),
        }
    )
    rows = written(frame, tmp_path)
    assert [r["run_id"] for r in rows] == ["'=A1", "B", "'=A1"]
    assert [r["note"] for r in rows] == ["'@x", "", "y"]
    assert frame["run_id"].tolist() == ["=A1", "B", "=A1"]  # a copy was changed


def test_only_the_columns_asked_for() -> None:
    frame = pd.DataFrame({"run_id": ["=A1"], "formula": ["=B1"]})
    assert safe_csv(frame, columns=["run_id"]).iloc[0].tolist() == ["'=A1", "=B1"]
    with pytest.raises(KeyError, match="pad"):
        safe_csv(frame, columns=["pad"])


def test_a_cell_is_neutralised_once() -> None:
    for text, want in HOSTILE.items():
        assert safe_cell(text) == want and safe_cell(safe_cell(text)) == want
    assert safe_cell(-1) == -1 and safe_cell(None) is None and safe_cell("B") == "B"


# ---------------------------------------------------------------------- figure text
LABELS = ["$x$", r"$\x$", "$^$", "pad $5 and $", "$a_$", "a\\$b$", "_hidden", "plain"]


def draw(label: str) -> list[str]:
    """Draw ``label`` as a tick label, title and legend entry on the Agg canvas; the texts
    as matplotlib shows them (mathtext parsed or not)."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure()
    ax = fig.subplots()
    ax.plot([0, 1], [0, 1], label=label)
    ax.set_yticks([0.5], [label])
    ax.set_title(label)
    legend = ax.legend()
    FigureCanvasAgg(fig).draw()
    shown = [t._preprocess_math(t.get_text()) for t in (ax.title, ax.get_yticklabels()[0])]
    shown += [t._preprocess_math(t.get_text()) for t in legend.get_texts()]
    return ["<math>" if math else text for text, math in shown]


def test_a_pad_id_with_dollars_breaks_the_figure_unescaped() -> None:
    with pytest.raises(ValueError, match="Unknown symbol"):
        draw(r"$\x$")
    assert draw("$x$")[0] == "<math>"  # drawn as an italic x, not as the pad's name


@pytest.mark.parametrize("label", LABELS)
def test_plain_text_is_drawn_as_it_is(label: str) -> None:
    title, tick, *entries = draw(plain_text(label))  # drawn without an error
    assert title.replace("\u200b", "") == label and tick.replace("\u200b", "") == label
    assert [e.replace("\u200b", "") for e in entries] == [label]  # "_hidden" kept too


def test_a_plain_to_csv_writes_formulas_and_splits_rows_at_a_carriage_return() -> None:
    """What every CSV of the project did before (fleet.csv, backtest.csv)."""
    frame = pd.DataFrame({"run_id": ["=cmd|' /C calc'!A0", "a\rb"], "rul_mean": [1.0, 2.0]})
    text = frame.to_csv(index=False)
    assert "\n=cmd|' /C calc'!A0," in text
    assert pd.read_csv(io.StringIO(text))["run_id"].tolist() == ["=cmd|' /C calc'!A0", "a", "b"]


def test_a_carriage_return_in_a_pad_id_keeps_its_row(tmp_path: Path) -> None:
    frame = pd.DataFrame({"run_id": ["a\rb", "c\nd", "e"], "rul_mean": [1.0, -2.0, 3.0]})
    back = pd.read_csv(write_csv(frame, tmp_path / "t.csv"))
    pd.testing.assert_frame_equal(back, frame)
