"""Quantify the gap: held-out gap before and after adding the winning effect, per channel
(jackknife over runs) and as the twin's RUL error (docs/results/sim2real.md).

The RUL error comes from a callback (:func:`sim2real.diagnosis.rul.rul_scorer`) that gets the
held-out and calibration parts of the log as :class:`LogPart` records, each with the
winner's modelled change of the temperature reading where it has one.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from sim2real.diagnosis.attribute import Nominal, RunSplit, Scored
from sim2real.diagnosis.config import DiagnosisConfig
from sim2real.diagnosis.localise import CHANNELS, Cells, gap_summary, two_sample
from sim2real.diagnosis.logdata import F64, I64, LogData
from sim2real.effects.interface import Effect


@dataclass(frozen=True, eq=False)
class LogPart:
    """Some runs of a log, for the RUL callback.

    Attributes:
        log: Their rows (the event-log columns, ground truth included if the log has it).
        temp_offset: Per row, the effect's modelled change of the temperature reading
            [K] (sensor and between-events effects), or None.
    """

    log: pd.DataFrame
    temp_offset: F64 | None = None


# (effect or None for the nominal model, held-out part, calibration part) -> RUL error.
RulScorer = Callable[[Effect | None, LogPart, LogPart], dict[str, Any] | None]


def quantify(
    d: LogData,
    cells: Cells,
    split: RunSplit,
    gap0: dict[str, dict[str, Any]],
    nominal: Nominal,
    winner: Scored | None,
    *,
    cfg: DiagnosisConfig,
    rng: np.random.Generator,
) -> dict[str, Any]:
    """Held-out gap and two-sample tests before and after the winner (if any)."""
    out: dict[str, Any] = {"before": gap0}
    if winner is not None:
        after = winner.held
        assert after is not None
        out["after"] = gap_summary(after, d, cells, split.held_runs, cfg.level)
        out["shrink"] = {
            ch: 1.0 - out["after"][ch]["structured_gap"] / max(gap0[ch]["structured_gap"], 1e-12)
            for ch in CHANNELS
        }
        out["two_sample_before"] = two_sample(nominal.held, d, cfg.noise, rng)
        out["two_sample_after"] = two_sample(after, d, cfg.noise, rng)
    out["channel"] = max(CHANNELS, key=lambda c: gap0[c]["structured_gap"])
    return out


def rul_error(
    rul: RulScorer, d: LogData, split: RunSplit, nominal: Nominal, winner: Scored | None
) -> dict[str, Any]:
    """The twin's RUL error on the held-out runs (fitted on the calibration runs), without
    and with the winning effect; the winner's K covers calibration and held-out runs."""
    rows_h, rows_c = d.run_rows(split.held_runs), d.run_rows(split.cal_runs)
    held, cal = _part(d, rows_h), _part(d, rows_c)
    out = {"before": rul(None, held, cal)}
    if winner is not None and winner.effect is not None:
        out["after"] = rul(
            winner.effect,
            _part(d, rows_h, reading_offset(winner, nominal, rows_h)),
            _part(d, rows_c, reading_offset(winner, nominal, rows_c)),
        )
    return out


def _part(d: LogData, rows: I64, offset: F64 | None = None) -> LogPart:
    return LogPart(d.frame.iloc[rows].reset_index(drop=True), offset)


def reading_offset(s: Scored, nominal: Nominal, rows: I64) -> F64 | None:
    """Per row, the candidate's modelled change of the temperature reading (sensor and
    between-events effects); None for in-event effects."""
    rm, d = s.model, s.model.data
    if rm.kind not in ("sensor", "between-events"):
        return None
    ok = d.ok[rows]
    out = np.zeros(rows.size)
    r = rows[ok]
    v = rm.volume_at(r, s.k[d.run[r]])
    out[ok] = rm.respond(r, v)["temp_mean_c"] - nominal.model.respond(r, v)["temp_mean_c"]
    return out
