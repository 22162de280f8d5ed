"""What the baselines read from training logs: the life of each run and the true RUL."""

from __future__ import annotations

import numpy as np
import pandas as pd
from numpy.typing import NDArray


def run_lives(train_log: pd.DataFrame) -> pd.Series:
    """Events to failure of each training run (index: run_id, in order of first appearance).

    With ground truth (``rul_events``) the life is ``last event + 1 + its RUL``, so a run
    cut short still counts its whole life. Without it the run must end at failure: its
    life is ``last event + 1``, and a ``failed`` column, when present, must mark that
    last event.

    Raises:
        ValueError: An empty log, or a run that neither carries its RUL nor ends in failure.
    """
    if len(train_log) == 0:
        raise ValueError("the training log has no events")
    last = train_log.groupby("run_id", observed=True, sort=False).tail(1).set_index("run_id")
    life = last["event"].astype(np.int64) + 1
    if "rul_events" in last:
        return (life + last["rul_events"].astype(np.int64)).rename("life")
    if "failed" in last and not last["failed"].all():
        bad = list(last.index[~last["failed"].to_numpy(dtype=bool)])
        raise ValueError(
            f"training run(s) {bad[:5]} do not end at failure and carry no rul_events: their"
            " life is unknown"
        )
    return life.rename("life")


def true_rul(train_log: pd.DataFrame) -> NDArray[np.float64]:
    """True RUL of every training event, row for row: ``rul_events``, else life - 1 - event."""
    if "rul_events" in train_log:
        return train_log["rul_events"].to_numpy(dtype=np.float64)
    lives = run_lives(train_log)
    life = train_log["run_id"].map(lives).to_numpy(dtype=np.float64)
    return life - 1.0 - train_log["event"].to_numpy(dtype=np.float64)
