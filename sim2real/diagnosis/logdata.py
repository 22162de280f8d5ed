"""An event log as arrays for replay: rows grouped by run, the operational time of each row.

The pad state is not logged, so it is estimated from the log itself (localise):
each event's relative wear severity rho (nominal wear per unit K at its conditions, over the
log's mean) gives an *operational time* u = the sum of rho over the pad's earlier events
(events missing from the log count at the mean severity). :mod:`sim2real.diagnosis.replay` turns u
into a volume through the wear clock of the log's own operating mix.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from brake_env.model.atlas import Atlas

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]
SEVERITY_VOLUME = 0.6  # volume fraction at which event severities are compared (mid-life)


def operational_time(wear: F64, event: I64, starts: I64) -> F64:
    """Severity-weighted events since installation, per row (rows grouped by run).

    ``wear`` is each event's wear at its conditions (NaN where they are missing); its
    relative severity is wear over the log's mean. Events missing from the log count at the
    mean severity (1); a run that starts at event n starts at u = n.
    """
    rho = wear / np.nanmean(wear)
    u = np.empty(event.size)
    for r in range(starts.size - 1):  # one vectorised cumulative sum per run
        sl = slice(int(starts[r]), int(starts[r + 1]))
        if sl.start == sl.stop:
            continue
        rr = np.where(np.isfinite(rho[sl]), rho[sl], 1.0)
        ev = event[sl]
        step = rr + (np.diff(ev, append=ev[-1] + 1) - 1)
        u[sl] = ev[0] + np.concatenate([[0.0], np.cumsum(step)[:-1]])
    return u


@dataclass(frozen=True, eq=False)
class LogData:
    """A validated event log as arrays, rows grouped by run and ordered by event.

    Attributes:
        run_ids: Run names in order of first appearance.
        run: Run index of each row.
        event: Event index since installation.
        speed_mps, mass_kg, slope_rad: Logged conditions (slope is noisy).
        temp_c, stop_dist_m: Logged responses (NaN = dropout).
        time_s: Event start times [s], or None when the log has none.
        ok: Rows whose conditions are all present (replayable).
        u: Operational time of the nominal model (``operational_time``).
        wear_ref: Nominal wear per unit K of each row at the reference volume (NaN where
            the conditions are missing); a model with an effect re-weights it.
        starts: First row of each run, and the total at the end.
        frame: The log rows in this order (truth columns for RUL, if any).
    """

    run_ids: list[str]
    run: I64
    event: I64
    speed_mps: F64
    mass_kg: F64
    slope_rad: F64
    temp_c: F64
    stop_dist_m: F64
    time_s: F64 | None
    ok: NDArray[np.bool_]
    u: F64
    wear_ref: F64
    starts: I64
    frame: pd.DataFrame

    @property
    def n_runs(self) -> int:
        return len(self.run_ids)

    def prev(self, rows: I64, lag: int = 1) -> I64:
        """Row ``lag`` events earlier in the same run, or -1."""
        p = rows - lag
        return np.where(p >= self.starts[self.run[rows]], p, -1)

    def gap_s(self, rows: I64) -> F64:
        """Time since the previous logged event of the run [s] (inf for a run's first)."""
        if self.time_s is None:
            raise ValueError("the log has no time_s column: thermal history cannot be replayed")
        p = self.prev(rows)
        return np.where(p >= 0, self.time_s[rows] - self.time_s[np.maximum(p, 0)], np.inf)

    def run_rows(self, runs: I64) -> I64:
        """Every row of the given runs, in order."""
        return np.concatenate([np.arange(self.starts[r], self.starts[r + 1]) for r in runs])


def severity_layer(atlas: Atlas) -> int:
    """The atlas layer at which event severities are compared (mid-life)."""
    return int(atlas.layer_of(max(SEVERITY_VOLUME, atlas.failure_volume)))


def prepare_log(log: pd.DataFrame, atlas: Atlas) -> LogData:
    """Arrays of a validated log (``brake_env.data.schema.read_event_log``), grouped by run."""
    if len(log) == 0:
        raise ValueError("the event log has no rows")
    codes, names = pd.factorize(log["run_id"], sort=False)
    order = np.lexsort((log["event"].to_numpy(), codes))
    df = log.iloc[order].reset_index(drop=True)
    run = codes[order].astype(np.int64)
    starts = np.searchsorted(run, np.arange(len(names) + 1)).astype(np.int64)
    s = df["speed_kmh"].to_numpy(np.float64) / 3.6
    m = df["mass_kg"].to_numpy(np.float64)
    th = df["slope_rad"].to_numpy(np.float64)
    ok = np.isfinite(s) & np.isfinite(m) & np.isfinite(th) & (s > 0)
    if not ok.any():
        raise ValueError("no event of the log has speed, mass and slope: nothing to replay")
    # Relative wear severity of each event, at a mid-life layer of the nominal atlas.
    w = np.full(len(df), np.nan)
    w[ok] = atlas.query(
        s[ok],
        m[ok],
        th[ok],
        layer=np.int64(severity_layer(atlas)),
        clip=True,
        fields=("wear_per_k_m3",),
    )["wear_per_k_m3"]
    event = df["event"].to_numpy(np.int64)
    return LogData(
        run_ids=[str(n) for n in names],
        run=run,
        event=event,
        speed_mps=s,
        mass_kg=m,
        slope_rad=th,
        temp_c=df["temp_c"].to_numpy(np.float64),
        stop_dist_m=df["stop_dist_m"].to_numpy(np.float64),
        time_s=df["time_s"].to_numpy(np.float64) if "time_s" in df else None,
        ok=ok,
        u=operational_time(w, event, starts),
        wear_ref=w,
        starts=starts,
        frame=df,
    )


def sample_rows(d: LogData, n_per_run: int, rng: np.random.Generator) -> list[I64]:
    """Per run, up to ``n_per_run`` replayable rows drawn without replacement, sorted."""
    out = []
    for r in range(d.n_runs):
        ok = np.flatnonzero(d.ok[d.starts[r] : d.starts[r + 1]]) + d.starts[r]
        n = min(n_per_run, ok.size)
        out.append(np.sort(rng.choice(ok, n, replace=False)) if n else ok)
    return out
