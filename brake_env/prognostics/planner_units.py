"""A predictor's RUL in a planner's units (issue 42): per route, in shifts and calendar time,
with the probability of failing before given horizons and the as-of time of each pad.

:func:`planner_units` takes the last estimate of each pad (``brakewear predict``'s table:
``rul_mean``, ``rul_lower``/``rul_upper`` where the predictor gives an interval,
``volume_frac`` where it gives a volume, ``events_since_install``) and the duty clocks of
the routes (:class:`~brake_env.prognostics.duty.DutyClocks`; for the fleet's routes and the
envelope's uniform mix: ``brake_env.env.fleet.route_rul.duty_clocks(atlas, PLANNER_ROUTES)``).
Its assumptions, each a column's meaning:

- **Route RUL** (``rul_<route>_events``, ``_lo``, ``_hi``): the base-mix RUL and each bound
  carried onto the route by :func:`~brake_env.prognostics.duty.route_rul` (exact for the
  twin: the route clock's RUL at its volume and K).
- **Shifts** (``rul_<route>_shifts``...): events over the pad's events per shift, the same on
  every route (a vehicle brakes as often on the ramp as on the drifts; the fleet env's
  ``events_per_shift`` is one number too). Events per shift come from the caller: a number,
  or each pad's own from its log's time stamps (:func:`events_per_shift_from_times`).
- **Calendar time** (``fail_<route>_time_s``): ``as_of`` plus the RUL in shifts times the
  shift's hours, on the log's clock (``time_s``): shifts follow one another without gap
  (a 2 x 12 h roster), as they do in the rate of :func:`events_per_shift_from_times`.
- **Failure probability** (``p_fail_<route>_<h>_shifts``): the RUL is read as a lognormal
  through the predictor's interval (its median the interval's geometric centre, its
  spread such that the interval holds ``level`` of it): the predictors state an interval,
  not a distribution, and a lognormal is the least assuming law of a positive life whose
  interval is wider above than below (``agents/fleet/operate/estimates.py`` reads it the
  same way). At a horizon equal to the interval's lower bound it is ``(1 - level) / 2``
  exactly. A predictor without an interval states no spread: its column is NaN.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from brake_env.prognostics.duty import DutyClocks, route_rul
from brake_env.prognostics.events import RULEstimate

F64 = NDArray[np.float64]
PLANNER_ROUTES = ("hot", "mild", "uniform")  # the fleet's duties and the envelope's mix
LEVEL = 0.9  # the interval level of the predictors that give one (twin, window)
SHIFT_HOURS = 12.0  # a 2 x 12 h roster (brake_env/env/fleet/config.py)
DAY_S = 86_400.0
MIN_EVENTS = 1.0  # a bound below one event is read as one: the lognormal needs RUL > 0


def p_fail_before(lower: F64, upper: F64, events: ArrayLike, level: float = LEVEL) -> F64:
    """Probability that each pad fails within ``events`` (of the bounds' unit), from the
    lognormal through its interval ``[lower, upper]`` of level ``level`` (module doc).

    Args:
        lower, upper: Each pad's interval bounds, (pads,); bounds under one event are read
            as one; an interval of no width gives a step at the bound.
        events: (pads,) or (pads, horizons), >= 0; 0 gives 0, NaN (unknown) gives NaN.
        level: The interval's coverage, in (0, 1).
    """
    from scipy.stats import norm  # heavy: only where a probability is asked for

    e = np.asarray(events, dtype=np.float64)
    if (e < 0).any():
        raise ValueError("p_fail_before: events must be >= 0")
    mu, sigma = lognormal(lower, upper, level)
    if e.ndim == 2:
        mu, sigma = mu[:, None], sigma[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        z = (np.log(e) - mu) / np.where(sigma > 0, sigma, 1.0)
    step = (e >= np.exp(mu)).astype(np.float64)
    p = np.where(e > 0, np.where(sigma > 0, norm.cdf(z), step), 0.0)
    return np.where(np.isnan(e), np.nan, p)


def lognormal(lower: ArrayLike, upper: ArrayLike, level: float = LEVEL) -> tuple[F64, F64]:
    """(mu, sigma) of the log of each pad's RUL: the lognormal through its interval
    ``[lower, upper]`` of level ``level`` (module doc; bounds under one event read as one)."""
    from scipy.stats import norm  # heavy: only where a probability is asked for

    if not 0.0 < level < 1.0:
        raise ValueError(f"p_fail_before: level must be in (0, 1), got {level}")
    lo = np.log(np.maximum(np.asarray(lower, dtype=np.float64), MIN_EVENTS))
    hi = np.maximum(np.log(np.maximum(np.asarray(upper, dtype=np.float64), MIN_EVENTS)), lo)
    return 0.5 * (lo + hi), (hi - lo) / (2.0 * float(norm.ppf(0.5 + level / 2.0)))


def horizon_label(h: float) -> str:
    """A horizon in a column name: ``7`` for 7.0, ``0p5`` for 0.5."""
    return f"{h:g}".replace(".", "p").replace("-", "m").replace("+", "")


def check_horizons(horizons: Sequence[float]) -> tuple[float, ...]:
    """The horizons as floats; one ``ValueError`` naming the first that is not > 0 and
    finite, or a repeated one (their columns would collide)."""
    out = tuple(float(h) for h in horizons)
    for h in out:
        if not (np.isfinite(h) and h > 0):
            raise ValueError(f"horizons: each must be a number of shifts > 0, got {h:g}")
    labels = [horizon_label(h) for h in out]
    if len(set(labels)) != len(labels):
        raise ValueError(f"horizons: {list(out)} repeats one")
    return out


def _per_pad(x: float | ArrayLike | None, n: int, name: str) -> F64:
    """One number, or one per pad, as (n,): > 0 or NaN (unknown), any for ``as_of``."""
    a = np.asarray(np.nan if x is None else x, dtype=np.float64)
    if a.ndim > 1 or (a.ndim == 1 and a.size != n):
        raise ValueError(f"planner_units: {a.size} values of {name} for {n} pads")
    a = np.broadcast_to(a, (n,)).copy()
    if name != "as_of":
        bad = np.flatnonzero(~np.isnan(a) & ~(np.isfinite(a) & (a > 0)))
        if bad.size:
            i = int(bad[0])
            raise ValueError(f"planner_units: {name} of pad {i} is {a[i]:g}; it must be > 0")
    return a


def _estimate(table: pd.DataFrame) -> tuple[RULEstimate, F64]:
    """The table's last estimates as a :class:`RULEstimate`, and each pad's events done."""
    for name in ("rul_mean", "events_since_install"):
        if name not in table.columns:
            raise ValueError(f"planner_units: the estimates have no column {name!r}")
    has_interval = "rul_lower" in table.columns and "rul_upper" in table.columns

    def column(name: str, given: bool = True) -> F64 | None:
        ok = given and name in table.columns
        return table[name].to_numpy(np.float64) if ok else None

    est = RULEstimate(
        table["rul_mean"].to_numpy(np.float64),
        column("rul_lower", has_interval),
        column("rul_upper", has_interval),
        volume_frac=column("volume_frac"),
    )
    return est, table["events_since_install"].to_numpy(np.float64)


def planner_units(
    estimates: pd.DataFrame,
    clocks: DutyClocks,
    events_per_shift: float | ArrayLike,
    horizons: Sequence[float] = (7.0, 14.0, 28.0),
    *,
    as_of: ArrayLike | None = None,
    shift_hours: float = SHIFT_HOURS,
    level: float = LEVEL,
) -> pd.DataFrame:
    """Each pad's RUL per route in events and shifts, its calendar time to failure and its
    probability of failing before each horizon (module doc), one row per row of ``estimates``
    in its order and index.

    Args:
        estimates: ``rul_mean`` and ``events_since_install`` (base-mix events), with
            ``rul_lower``/``rul_upper`` and ``volume_frac`` where the predictor gives them.
        clocks: The routes' clocks (``duty_clocks(atlas, PLANNER_ROUTES)``).
        events_per_shift: One number, or one per pad (:func:`events_per_shift_from_times`);
            NaN: unknown (that pad's shifts, calendar time and probabilities are NaN).
        horizons: Shifts ahead, each > 0.
        as_of: Each pad's last event's time [s, the log's clock] (NaN or None: unknown).
        shift_hours: A shift's length, for the calendar time.
        level: The interval's coverage.

    Returns:
        Columns ``as_of``, ``events_per_shift``, then per route ``rul_<route>_events``,
        ``_events_lo``, ``_events_hi``, ``rul_<route>_shifts``, ``_shifts_lo``,
        ``_shifts_hi``, ``fail_<route>_time_s``; then per route and horizon
        ``p_fail_<route>_<h>_shifts``.
    """
    n = len(estimates)
    per = _per_pad(events_per_shift, n, "events_per_shift")
    hours = float(_per_pad(shift_hours, 1, "shift_hours")[0])
    if np.isnan(hours):
        raise ValueError("planner_units: shift_hours is NaN; it must be > 0")
    stamps = _per_pad(as_of, n, "as_of")
    hs = check_horizons(horizons)
    est, done = _estimate(estimates)
    rr = route_rul(est, done, clocks)
    out: dict[str, F64] = {"as_of": stamps, "events_per_shift": per}
    for j, r in enumerate(clocks.names):
        for tail, x in (("", rr.mean), ("_lo", rr.lower), ("_hi", rr.upper)):
            out[f"rul_{r}_events{tail}"] = x[:, j]
        for tail, x in (("", rr.mean), ("_lo", rr.lower), ("_hi", rr.upper)):
            out[f"rul_{r}_shifts{tail}"] = x[:, j] / per
        out[f"fail_{r}_time_s"] = stamps + rr.mean[:, j] / per * hours * 3600.0
    shown = est.rul_lower is not None
    ahead = np.outer(per, np.asarray(hs)) if hs else np.zeros((n, 0))
    for j, r in enumerate(clocks.names):
        p = p_fail_before(rr.lower[:, j], rr.upper[:, j], ahead, level) if shown else None
        for i, h in enumerate(hs):
            col = p[:, i] if p is not None else np.full(n, np.nan)
            out[f"p_fail_{r}_{horizon_label(h)}_shifts"] = col
    return pd.DataFrame(out, index=estimates.index)


def last_times(log: pd.DataFrame) -> pd.Series:
    """Each run's last event's ``time_s`` (the as-of time), by ``run_id``; NaN for a run
    without one, all NaN for a log without the column."""
    runs = log["run_id"].astype(str)
    if "time_s" not in log.columns:
        return pd.Series(np.nan, index=pd.Index(runs.unique(), name="run_id"), name="as_of")
    last = log.groupby(runs, sort=False)["time_s"].max()
    return last.astype(np.float64).rename("as_of")


def events_per_shift_from_times(log: pd.DataFrame, shift_hours: float = SHIFT_HOURS) -> pd.Series:
    """Each run's events per shift of ``shift_hours``, by ``run_id``, from its ``time_s``.

    A pad's rate is the median of its events per day over the days it braked (periods of
    24 h of the log's clock; the first and last left out as partial where it spans at
    least three), times ``shift_hours / 24``: a whole day holds a day of any roster
    whatever its shifts' start, and a day parked is not a slower day. A pad logged over
    fewer than three days takes its rate over its span, ``(events - 1) / span``; a pad
    with no span (one time stamp) the median of the others'.

    Raises:
        ValueError: No ``time_s`` column or no time stamp at all (naming the
            ``--events-per-shift`` flag), ``shift_hours`` not > 0, or no pad with two
            time stamps apart.
    """
    if not (np.isfinite(shift_hours) and shift_hours > 0):
        raise ValueError(f"--shift-hours must be > 0, got {shift_hours:g}")
    if "time_s" not in log.columns or not log["time_s"].notna().any():
        raise ValueError(
            "the log has no time stamps (time_s) to count events per shift from: give"
            " --events-per-shift N"
        )
    rates = {}
    t_all = log[["run_id", "time_s"]].dropna()
    for run, t in t_all.groupby(t_all["run_id"].astype(str), sort=False)["time_s"]:
        rates[run] = _daily_rate(np.sort(t.to_numpy(np.float64)))
    rate = pd.Series(rates, dtype=np.float64)
    known = rate.dropna()
    if known.empty:
        raise ValueError(
            "no pad of the log has two distinct time stamps to count events per shift"
            " from: give --events-per-shift N"
        )
    runs = pd.Index(log["run_id"].astype(str).unique(), name="run_id")
    rate = rate.reindex(runs).fillna(float(known.median()))
    return (rate * shift_hours / 24.0).rename("events_per_shift")


def _daily_rate(t: F64) -> float:
    """Events per day of sorted time stamps ``t`` (:func:`events_per_shift_from_times`);
    NaN when they span no time."""
    day = np.floor(t / DAY_S).astype(np.int64)
    if day[-1] - day[0] >= 2:
        counts = np.bincount(day - day[0])
        inner = counts[1:-1]
        inner = inner[inner > 0]
        if inner.size:
            return float(np.median(inner))
    span = float(t[-1] - t[0])
    return (t.size - 1) / span * DAY_S if span > 0 else float("nan")
