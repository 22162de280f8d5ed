"""How each run of an event log ended, read once for every consumer (the predictors' fits,
``brakewear fit``): failed or removed before failure, its last event, and the pad volumes
measured in the workshop (docs/results/prognostics.md, columns ``failed`` and
``measured_volume_frac``).

A run ends at failure when its last row has ``failed`` true; a log without that column is a
set of run-to-failure runs (paper 2.1.6). Any other run was removed before failure: it
survived its events, which bounds its life from below and never gives it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from brake_env.data.schema import FAILED, MEASURED_VOLUME


@dataclass(frozen=True, eq=False)
class RunEnds:
    """The runs of a log, in order of first appearance.

    Attributes:
        names: Run ids.
        codes: Run index of each row of the log.
        last_row: Row of each run's last event.
        last_event: Each run's last logged event (counted from installation) [-].
        failed: Whether each run ended at failure (else it was removed: censored).
        meas_rows: Rows carrying a measured pad volume, in log order.
        meas_volume: Those measured volume fractions [-].
    """

    names: NDArray[np.str_]
    codes: NDArray[np.intp]
    last_row: NDArray[np.intp]
    last_event: NDArray[np.int64]
    failed: NDArray[np.bool_]
    meas_rows: NDArray[np.intp]
    meas_volume: NDArray[np.float64]

    @property
    def censored(self) -> NDArray[np.bool_]:
        """Runs removed before failure."""
        return ~self.failed

    def describe(self, mask: NDArray[np.bool_], limit: int = 5) -> str:
        """``['a', 'b', ...] (n runs)`` for the runs where ``mask`` is true."""
        return describe_runs(self.names, mask, limit)


def describe_runs(names: NDArray[np.str_], mask: NDArray[np.bool_], limit: int = 5) -> str:
    """``['a', 'b', ...] (n runs)``: the run ids where ``mask`` is true, for messages."""
    picked = [str(n) for n in names[mask]]
    shown = str(picked[:limit])
    if len(picked) > limit:
        shown = shown[:-1] + ", ...]"
    return f"{shown} ({len(picked)} run{'s' if len(picked) != 1 else ''})"


def run_ends(log: pd.DataFrame, who: str = "the log") -> RunEnds:
    """How each run of ``log`` (rows in event order within a run) ended.

    Args:
        log: An event log with ``run_id`` and ``event``, optionally ``failed`` and
            ``measured_volume_frac``.
        who: Who reads it, for the errors (``"twin.fit"``).

    Raises:
        ValueError: An empty log, or runs marked failed before their last event (named).
    """
    if len(log) == 0:
        raise ValueError(f"{who}: the log has no events")
    codes, names = pd.factorize(log["run_id"], sort=False)
    rows = np.arange(len(codes))
    last_row = np.zeros(len(names), dtype=np.intp)
    np.maximum.at(last_row, codes, rows)
    if FAILED in log:
        flag = log[FAILED].to_numpy(dtype=bool)
        early = np.zeros(len(names), dtype=bool)
        np.logical_or.at(early, codes, flag & (rows != last_row[codes]))
        if early.any():
            raise ValueError(
                f"{who}: run(s) {list(names[early][:5])} are marked {FAILED!r} before their"
                " last event; a pad fails once, at the end of its run"
            )
        failed = flag[last_row]
    else:
        failed = np.ones(len(names), dtype=bool)
    if MEASURED_VOLUME in log:
        v = log[MEASURED_VOLUME].to_numpy(dtype=np.float64)
        meas = np.flatnonzero(np.isfinite(v))
    else:
        v, meas = np.empty(0), np.empty(0, dtype=np.intp)
    return RunEnds(
        names=np.asarray(names.astype(str)),
        codes=codes.astype(np.intp),
        last_row=last_row,
        last_event=log["event"].to_numpy(dtype=np.int64)[last_row],
        failed=failed,
        meas_rows=meas,
        meas_volume=v[meas],
    )
