"""Training fleets whose pads were removed before failure (docs/results/prognostics.md).

Real fleets rarely run pads to failure: a pad is replaced at a planned service, sometimes
with its remaining volume measured in the workshop. :func:`censor_log` turns a simulated
run-to-failure log into such a fleet: each run is cut at a random fraction of its life, the
``failed`` flag of a cut run stays False, the remaining volume may be "measured" at the cut
(and at earlier inspections) with multiplicative noise, and the ground truth is dropped, so
nothing downstream can read the life a cut run would have had.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from brake_env.data.schema import FAILED, MEASURED_VOLUME, TRUTH

# Known only in simulation; ``failed`` stays: a fleet knows which pads failed.
TRUTH_DROPPED = TRUTH


def censor_log(
    log: pd.DataFrame,
    rng: np.random.Generator,
    cut: tuple[float, float] = (0.5, 0.9),
    volume_noise: float | None = 0.02,
    inspections: int = 0,
) -> pd.DataFrame:
    """Cut every run of a run-to-failure log at a random point of its life.

    Args:
        log: A simulated event log with ground truth (``volume_frac``, ``rul_events``),
            each run starting at event 0 and ending at failure.
        rng: Draws the cut points, inspection events and measurement noise, in that order.
        cut: The cut falls uniformly in this range of fractions of each run's life [-].
        volume_noise: Relative standard deviation of a measured volume [-]; None measures
            nothing (the column is then all NaN).
        inspections: Earlier events per run at which the volume is measured as well [-].

    Returns:
        The kept rows, without ``volume_frac``, ``wear_coeff`` and ``rul_events``, with
        ``failed`` all False and ``measured_volume_frac`` set after the last kept event
        (and at the inspections): the true volume at the start of the next event times
        ``1 + volume_noise * N(0, 1)``, at most 1.

    Raises:
        ValueError: No ground truth to cut by, or ``cut`` outside (0, 1).
    """
    missing = [c for c in ("run_id", "event", "volume_frac", "rul_events") if c not in log]
    if missing:
        raise ValueError(f"censor_log: the log lacks column(s) {missing} (a simulated log)")
    lo, hi = cut
    if not 0.0 < lo <= hi < 1.0:
        raise ValueError(f"censor_log: cut must satisfy 0 < lo <= hi < 1, got {cut}")
    if inspections < 0:
        raise ValueError(f"censor_log: inspections must be >= 0, got {inspections}")
    codes, names = pd.factorize(log["run_id"], sort=False)
    event = log["event"].to_numpy(dtype=np.int64)
    life = event + 1 + log["rul_events"].to_numpy(dtype=np.int64)  # per row, constant per run
    run_life = np.zeros(len(names), dtype=np.int64)
    np.maximum.at(run_life, codes, life)
    # Last kept event of each run: at least the first event, never the failure one.
    last = np.clip(np.floor(rng.uniform(lo, hi, len(names)) * run_life), 1, run_life - 1) - 1
    keep = event <= last[codes]
    out = log.loc[keep].drop(columns=[c for c in TRUTH_DROPPED if c in log])
    out[FAILED] = False
    measured = np.full(len(log), np.nan)
    if volume_noise is not None:
        measured = _measure(
            log, codes, event, last, rng=rng, volume_noise=volume_noise, inspections=inspections
        )
    out[MEASURED_VOLUME] = measured[keep]
    return out.reset_index(drop=True)


def _measure(
    log: pd.DataFrame,
    codes: NDArray[np.intp],
    event: NDArray[np.int64],
    last: NDArray[np.float64],
    *,
    rng: np.random.Generator,
    volume_noise: float,
    inspections: int,
) -> NDArray[np.float64]:
    """Per row of ``log``: the measured volume after it at each run's last kept event
    ``last`` and at ``inspections`` random earlier ones, NaN elsewhere."""
    at = event == last[codes]
    if inspections:
        picks = rng.uniform(0.0, 1.0, (len(last), inspections)) * (last[:, None] + 1)
        at |= (event[:, None] == picks.astype(np.int64)[codes]).any(axis=1)
    rows = np.flatnonzero(at & (event <= last[codes]))
    # After event e the volume is the one at the start of event e + 1: the next row
    # (a kept row is never a run's failure row, so the next row exists).
    if np.any(codes[rows + 1] != codes[rows]) or np.any(event[rows + 1] != event[rows] + 1):
        raise ValueError("censor_log: each run's rows must be contiguous and in event order")
    v_next = log["volume_frac"].to_numpy()[rows + 1]
    noisy = v_next * (1.0 + volume_noise * rng.standard_normal(rows.size))
    measured = np.full(len(log), np.nan)
    measured[rows] = np.clip(noisy, 0.0, 1.0)  # a gauge reads no more than a new pad
    return measured
