"""``brakewear predict``'s planner columns (issue 42): its options (``--events-per-shift``,
``--shift-hours``, ``--horizons``), checked as soon as the log is read, and the columns of
:func:`~brake_env.prognostics.planner_units.planner_units` appended to the fleet table.

It sits in the CLI stage because the routes' clocks are the fleet env's
(:func:`brake_env.env.fleet.route_rul.duty_clocks`), which the prognostics stage may not import.
"""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from brake_env.cli.common import POSITIVE
from brake_env.env.fleet.route_rul import duty_clocks
from brake_env.model.atlas import Atlas
from brake_env.prognostics.planner_units import (
    LEVEL,
    PLANNER_ROUTES,
    SHIFT_HOURS,
    check_horizons,
    events_per_shift_from_times,
    last_times,
    planner_units,
)

HORIZONS = (7.0, 14.0, 28.0)  # shifts ahead: the example


def horizon_list(text: str) -> tuple[float, ...]:
    """An argparse ``type``: comma-separated shifts ahead, each a finite number > 0."""
    parts = [p.strip() for p in text.split(",")]
    try:
        values = tuple(float(p) for p in parts)
        return check_horizons(values)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected shifts ahead > 0, comma-separated and not repeated (e.g. 7,14,28),"
            f" got {text!r}"
        ) from None


def add_planner_args(p: argparse.ArgumentParser) -> None:
    """``--events-per-shift``, ``--shift-hours``, ``--horizons``."""
    p.add_argument(
        "--events-per-shift",
        type=POSITIVE,
        default=argparse.SUPPRESS,  # its default told in the help, not as None
        help="braking events of a vehicle per shift, for every pad (default: each pad's own"
        " from the log's time_s: its median events per day braked, times shift hours / 24)",
    )
    p.add_argument(
        "--shift-hours",
        type=POSITIVE,
        default=argparse.SUPPRESS,  # its default told in the help, not as None
        help=f"a shift's hours, shifts back to back (default {SHIFT_HOURS:g}: a 2 x 12 h"
        " roster); sets events per shift from time stamps and the calendar time to failure",
    )
    p.add_argument(
        "--horizons",
        type=horizon_list,
        default=argparse.SUPPRESS,  # its default told in the help, not as None
        help="shifts ahead for the probabilities of failure p_fail_<route>_<h>_shifts"
        f" (default {','.join(f'{h:g}' for h in HORIZONS)})",
    )


@dataclass(frozen=True)
class PlannerSettings:
    """What the planner columns are computed with.

    Attributes:
        per_shift: Events per shift: by ``run_id`` from the log, one number, or None
            (unknown: the columns in shifts are empty).
        as_of: Each run's last event's ``time_s`` (NaN: none).
        shift_hours: A shift's hours.
        horizons: Shifts ahead.
        source: Where ``per_shift`` comes from, in words.
    """

    per_shift: pd.Series | float | None
    as_of: pd.Series
    shift_hours: float
    horizons: tuple[float, ...]
    source: str

    def columns(
        self, fleet: pd.DataFrame, atlas: Atlas, level: float | None
    ) -> tuple[pd.DataFrame, dict[str, Any]]:
        """``fleet`` with the planner columns appended (its own kept, in order), and the
        settings for ``fleet.json``."""
        runs = fleet["run_id"].astype(str)
        per: Any = self.per_shift
        if isinstance(per, pd.Series):
            per = runs.map(per).to_numpy(np.float64)
        elif per is None:
            per = math.nan
        extra = planner_units(
            fleet,
            duty_clocks(atlas, PLANNER_ROUTES),
            per,
            self.horizons,
            as_of=runs.map(self.as_of).to_numpy(np.float64),
            shift_hours=self.shift_hours,
            level=LEVEL if level is None else level,
        )
        info = {
            "routes": list(PLANNER_ROUTES),
            "events_per_shift": self.source,
            "shift_hours": self.shift_hours,
            "horizons_shifts": list(self.horizons),
            "p_fail": "lognormal through the predictor's interval (its median the interval's"
            f" geometric centre, level {LEVEL if level is None else level:g}); empty without"
            " an interval",
            "as_of": "time_s of each pad's last event (the log's clock)",
        }
        return pd.concat([fleet, extra], axis=1), info

    def note(self) -> str | None:
        """The warning when the shifts are unknown."""
        if self.per_shift is not None:
            return None
        return (
            "the log has no time stamps (time_s): the RUL in shifts, the calendar time and"
            " p_fail are empty; give --events-per-shift N"
        )


def planner_settings(log: pd.DataFrame, args: argparse.Namespace) -> PlannerSettings:
    """The settings from the options and the log, checked before the long work: a log
    without time stamps and no ``--events-per-shift`` is refused if ``--shift-hours`` or
    ``--horizons`` asked for shifts (else its columns in shifts are left empty, with a
    warning)."""
    given = {k: getattr(args, k, None) for k in ("events_per_shift", "shift_hours", "horizons")}
    hours = SHIFT_HOURS if given["shift_hours"] is None else float(given["shift_hours"])
    horizons = HORIZONS if given["horizons"] is None else tuple(given["horizons"])
    stamps = last_times(log)
    per: pd.Series | float | None
    if given["events_per_shift"] is not None:
        per, source = float(given["events_per_shift"]), "--events-per-shift"
    elif stamps.notna().any():
        per = events_per_shift_from_times(log, hours)
        source = f"the log's time_s: median events per day braked x {hours:g} h / 24 h"
    elif given["shift_hours"] is not None or given["horizons"] is not None:
        flags = "--horizons" if given["shift_hours"] is None else "--shift-hours"
        raise ValueError(
            f"{flags} asks for shifts, but the log has no time stamps (time_s) to count"
            " events per shift from: give --events-per-shift N"
        )
    else:
        per, source = None, "unknown (no time_s in the log, no --events-per-shift)"
    return PlannerSettings(per, stamps, hours, horizons, source)
