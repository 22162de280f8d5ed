"""What the baselines read from training logs: how each run ended, its life when known, the
true RUL, and the pad volumes measured in the workshop (docs/results/prognostics.md).

How a run ended is :func:`brake_env.data.runs.run_ends`'s reading. Simulated logs carry
the truth (``rul_events``), which gives the life of a run even when it was cut short. A run
removed before failure survived its events, which bounds its life from below but is never
taken as its life (:mod:`baselines._censoring`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from brake_env.data.runs import describe_runs, run_ends

F64 = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class TrainingRuns:
    """How the runs of a training log ended, in order of first appearance.

    Attributes:
        names: Run ids.
        last_event: Last logged event of each run [-].
        life: Events from installation to failure, ``failed event + 1``; NaN for a run
            removed before failure (censored) [-].
        meas_run, meas_done, meas_volume: One entry per measured pad volume: the run (an
            index into ``names``), the events completed when it was measured (``event +
            1`` of its row) [-] and the measured volume fraction [-].
    """

    names: NDArray[np.str_]
    last_event: NDArray[np.int64]
    life: F64
    meas_run: NDArray[np.intp]
    meas_done: F64
    meas_volume: F64

    @property
    def censored(self) -> NDArray[np.bool_]:
        return np.isnan(self.life)

    def describe(self, mask: NDArray[np.bool_], limit: int = 5) -> str:
        """``['a', 'b', ...] (n runs)`` for the runs where ``mask`` is true."""
        return describe_runs(self.names, mask, limit)


def training_runs(train_log: pd.DataFrame) -> TrainingRuns:
    """How each run of a validated training log ended (see the module docstring).

    Raises:
        ValueError: An empty log, or a run marked failed before its last event.
    """
    ends = run_ends(train_log, "the training log")
    last = ends.last_event
    if "rul_events" in train_log:
        rul = train_log["rul_events"].to_numpy(dtype=np.int64)[ends.last_row]
        life = (last + 1 + rul).astype(np.float64)
    else:
        life = np.where(ends.failed, last + 1.0, np.nan)
    rows = ends.meas_rows
    return TrainingRuns(
        names=ends.names,
        last_event=last,
        life=life,
        meas_run=ends.codes[rows],
        meas_done=train_log["event"].to_numpy(dtype=np.float64)[rows] + 1.0,
        meas_volume=ends.meas_volume,
    )


def run_lives(train_log: pd.DataFrame) -> pd.Series:
    """Events to failure of each training run (index: run_id, in order of first appearance).

    Raises:
        ValueError: An empty log, or runs removed before failure (named) whose life is
            unknown.
    """
    runs = training_runs(train_log)
    if runs.censored.any():
        raise ValueError(
            f"training run(s) {runs.describe(runs.censored)} do not end at failure and carry"
            " no rul_events: their life is unknown"
        )
    return pd.Series(runs.life.astype(np.int64), index=pd.Index(runs.names, name="run_id"))


def rul_targets(train_log: pd.DataFrame) -> tuple[F64, NDArray[np.bool_]]:
    """RUL of every training event, row for row, and where it is only a lower bound.

    Where the run's life is known the RUL is exact: ``rul_events``, else ``life - 1 -
    event``. A run removed before failure after event ``c`` failed at event ``c + 1`` or
    later, so after event ``k`` its RUL is at least ``c + 1 - k``: that bound is returned,
    flagged True.
    """
    if "rul_events" in train_log:
        return train_log["rul_events"].to_numpy(dtype=np.float64), np.zeros(len(train_log), bool)
    runs = training_runs(train_log)
    codes = pd.factorize(train_log["run_id"], sort=False)[0]
    event = train_log["event"].to_numpy(dtype=np.float64)
    censored = runs.censored[codes]
    end = np.where(runs.censored, runs.last_event + 2.0, runs.life)[codes]
    return end - 1.0 - event, censored


def true_rul(train_log: pd.DataFrame) -> F64:
    """True RUL of every training event, row for row: ``rul_events``, else life - 1 - event.

    Raises:
        ValueError: Runs removed before failure, whose RUL is unknown.
    """
    y, censored = rul_targets(train_log)
    if censored.any():
        run_lives(train_log)  # raises, naming the runs
    return y
