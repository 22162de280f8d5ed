"""What a log must hold before the diagnosis starts its long work (docs/results/sim2real.md).

The event-log reader accepts any log that keeps the schema; the diagnosis needs more: runs
to split into calibration and held-out runs, events to replay in each run, and the readings
it compares (temperature and stopping distance). :func:`check_log` looks at the log in a
fraction of a second and raises one error naming the runs or columns that fall short,
instead of the diagnosis failing after a minute. A channel missing for a whole pad (every
value NaN) is not an error: the pad is replayed without it, and the diagnosis output says
so (:class:`LogCheck`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from brake_env.data.schema import SENSOR_CHANNELS
from sim2real.diagnosis.config import DiagnosisConfig

MIN_RUN_EVENTS = 10  # replayable events a run needs for its K (one number per run)
MIN_CHANNEL_EVENTS = 10  # readings of a compared channel in the whole log
MIN_TWIN_RUNS = 2  # the twin's prior over K is fitted on at least 2 runs
COMPARED = ("temp_c", "stop_dist_m")  # the readings the replay is scored on
CONDITIONS = ("speed_kmh", "mass_kg", "slope_rad")  # what an event is replayed from


class DiagnosisInputError(ValueError):
    """A log the diagnosis cannot work on; the message names the runs or columns."""


@dataclass(frozen=True)
class LogCheck:
    """What the checks found that does not stop the diagnosis.

    Attributes:
        missing_channels: Run -> sensor channels with no value at all in that run.
        warnings: One sentence each, for the terminal, ``diagnosis.json`` and ``report.md``.
    """

    missing_channels: dict[str, list[str]] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)

    def summary(self) -> dict[str, Any]:
        """The part of ``diagnosis.json`` that reports the checks."""
        return {"missing_channels": self.missing_channels, "warnings": self.warnings}


def _names(runs: list[str], n: int = 5) -> str:
    shown = ", ".join(repr(r) for r in runs[:n])
    return shown + (f" and {len(runs) - n} more" if len(runs) > n else "")


def calibration_runs(n_runs: int, config: DiagnosisConfig) -> int:
    """How many of ``n_runs`` runs the diagnosis fits on (as ``diagnose`` splits them)."""
    return int(np.clip(round(config.calibration_fraction * n_runs), 1, n_runs - 1))


def check_log(
    log: pd.DataFrame, config: DiagnosisConfig | None = None, with_rul: bool = True
) -> LogCheck:
    """Check a validated event log (``read_event_log``) against what the diagnosis needs.

    Args:
        log: The log.
        config: The diagnosis settings (the calibration share of runs).
        with_rul: The twin's RUL error will be scored (it fits the twin on the
            calibration runs, when the log has ``rul_events``).

    Returns:
        Per run the channels it lacks entirely, and warnings.

    Raises:
        DiagnosisInputError: Fewer than 2 runs, too few calibration runs for the twin, a
            run with fewer than ``MIN_RUN_EVENTS`` replayable events, or a compared
            channel (temperature, stopping distance) without readings in the whole log.
    """
    cfg = config or DiagnosisConfig()
    runs = pd.factorize(log["run_id"], sort=False)
    codes, names = runs[0], [str(r) for r in runs[1]]
    n = len(names)
    if n < 2:
        raise DiagnosisInputError(
            f"the log has {n} run ({_names(names)}); the diagnosis fits on some runs and"
            " scores on the others, so it needs at least 2"
        )
    n_cal = calibration_runs(n, cfg)
    if with_rul and "rul_events" in log and n_cal < MIN_TWIN_RUNS:
        fix = "raise --calibration-fraction" if n > MIN_TWIN_RUNS else "give a log of more runs"
        raise DiagnosisInputError(
            f"the log has {n} runs, so {n_cal} calibration run; the RUL error fits the twin"
            f" on the calibration runs and needs {MIN_TWIN_RUNS}: {fix}, or pass --no-rul"
        )
    _check_runs(log, codes, names)
    for ch in COMPARED:
        have = int(np.isfinite(log[ch].to_numpy(dtype=np.float64)).sum())
        if have < MIN_CHANNEL_EVENTS:
            raise DiagnosisInputError(
                f"column '{ch}' has {have} readings in {len(log)} events (NaN everywhere"
                f" else); the diagnosis compares the model's {ch} with the log's and needs"
                f" at least {MIN_CHANNEL_EVENTS}"
            )
    return _missing_channels(log, codes, names, with_rul)


def _check_runs(log: pd.DataFrame, codes: np.ndarray, names: list[str]) -> None:
    """Every run needs ``MIN_RUN_EVENTS`` events with speed, mass and slope (replayable)."""
    ok = np.ones(len(log), dtype=bool)
    for c in CONDITIONS:
        ok &= np.isfinite(log[c].to_numpy(dtype=np.float64))
    ok &= log["speed_kmh"].to_numpy(dtype=np.float64) > 0
    per_run = np.bincount(codes, weights=ok, minlength=len(names)).astype(np.int64)
    short = np.flatnonzero(per_run < MIN_RUN_EVENTS)
    if short.size:
        detail = ", ".join(f"{names[r]!r}: {per_run[r]}" for r in short[:5])
        raise DiagnosisInputError(
            f"run(s) {detail}{' ...' if short.size > 5 else ''} have fewer than"
            f" {MIN_RUN_EVENTS} replayable events (speed > 0, mass and slope present); each"
            " run's wear coefficient is fitted from its own events: drop these runs or fix"
            " their rows"
        )


def _missing_channels(
    log: pd.DataFrame, codes: np.ndarray, names: list[str], with_rul: bool
) -> LogCheck:
    """Per run, the sensor channels with no reading at all, with a warning each."""
    missing: dict[str, list[str]] = {}
    for ch in SENSOR_CHANNELS:
        have = np.bincount(
            codes, weights=np.isfinite(log[ch].to_numpy(dtype=np.float64)), minlength=len(names)
        )
        for r in np.flatnonzero(have == 0):
            missing.setdefault(names[r], []).append(ch)
    warnings = []
    for run, chs in missing.items():
        text = f"run {run!r} has no {', '.join(chs)} at all (every value missing)"
        if "temp_c" in chs:
            text += (
                "; its temperature residuals are left out, and the twin (which reads the pad"
                " volume from temperatures) scores its RUL from its prior over K alone"
                if with_rul
                else "; its temperature residuals are left out"
            )
        warnings.append(text)
    return LogCheck(missing, warnings)
