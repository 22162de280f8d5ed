"""The evaluation's summary table shows every metric the results hold, ``-`` for the rest."""

from __future__ import annotations

from typing import Any

from brake_env.prognostics.tables import summary_table


def _metrics(**extra: Any) -> dict[str, Any]:
    mean = {
        "rul_rmse": 1234.0,
        "rul_rmse_frac": 0.0123,
        "convergence_frac": {"0.1": 0.25},
        "relative_accuracy": 0.9,
        "alpha_lambda": 1.0,
        "phm08": 0.5,
        **extra,
    }
    return {"models": {"twin": {"splits": {"id": {"mean": mean}}}}}


def _row(text: str) -> dict[str, str]:
    head, _, row = (line.split("|")[1:-1] for line in text.splitlines())
    return {h.strip(): v.strip() for h, v in zip(head, row, strict=True)}


def test_horizon_cra_and_monotonicity_are_columns() -> None:
    row = _row(
        summary_table(
            _metrics(
                prognostic_horizon_frac=0.875,
                cumulative_relative_accuracy=-1.25,
                monotonicity=0.5,
            ),
            markdown=True,
        )
    )
    assert (row["PH"], row["CRA"], row["mono"]) == ("0.88", "-1.25", "0.50")
    assert (row["RA"], row["a-l"], row["conv 10%"]) == ("0.90", "1.0", "0.25")


def test_a_metric_the_results_lack_shows_as_a_dash() -> None:
    row = _row(summary_table(_metrics(), markdown=True))
    assert row["PH"] == row["CRA"] == row["mono"] == row["coverage"] == "-"
