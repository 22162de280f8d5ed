"""The pad-state fit of a replay: each run's wear coefficient K by maximum likelihood.

The pad's volume at each event follows from its operational time and K through the replay
model's wear clock (:class:`sim2real.diagnosis.replay.ReplayModel`), so one number per run fixes the
whole state path; this module fits it to the temperature and stopping-distance readings
(the paper's identification, 2.4.1, on a log instead of a simulated run).
"""

from __future__ import annotations

import numpy as np

from sim2real.diagnosis.logdata import F64, I64
from sim2real.diagnosis.replay import ReplayModel


def k_bounds(rm: ReplayModel, run: int) -> tuple[float, float]:
    """A floor, and the largest K keeping the run's last event above the model's end of
    life."""
    d = rm.data
    u_last = float(rm.u[d.starts[run + 1] - 1]) + 1.0
    hi = rm.clock.life_work / u_last
    return hi / 200.0, hi


def fit_k(
    rm: ReplayModel, rows_by_run: list[I64], runs: I64 | None = None, n_slope: int = 3
) -> F64:
    """Per run, the maximum-likelihood K of its state path (NaN for other runs).

    The score is the model's likelihood of the readings (``predict`` and ``loglik``: stop
    readings floored, slope reading integrated out over ``n_slope`` nodes, 3 here against
    the 5 that score candidates, which is cheaper and moved K by < 0.1% in trials). Least
    squares on the logged slope and the unfloored distance is biased: on a no-effect log it
    put K 1.4-2.5% low, which left a structured residual growing with wear (0.05 noise
    units) where the model is right.

    A 12-point log-spaced grid between the bounds of :func:`k_bounds` on ~300 fit events of
    each run (every n-th), then three passes of 7 points over two steps around the best
    value on all fit events, then a parabola in log K through the best and its neighbours.
    """
    d = rm.data
    runs = np.arange(d.n_runs) if runs is None else np.asarray(runs)
    lo_hi = np.array([k_bounds(rm, int(r)) for r in runs])
    lg = np.linspace(np.log(lo_hi[:, 0]), np.log(lo_hi[:, 1]), 12).T  # (runs, n)
    few = [rows_by_run[int(r)][:: max(1, rows_by_run[int(r)].size // 300)] for r in runs]
    tot = _k_cost(rm, few, runs, lg, n_slope)
    at = np.arange(runs.size)
    for _ in range(3):
        best = np.argmin(tot, axis=1)
        n = lg.shape[1]
        i0, i2 = np.maximum(best - 1, 0), np.minimum(best + 1, n - 1)
        lg = np.linspace(lg[at, i0], lg[at, i2], 7).T
        tot = _k_cost(rm, [rows_by_run[int(r)] for r in runs], runs, lg, n_slope)
    out = np.full(d.n_runs, np.nan)
    out[runs] = np.exp(_parabola_min(lg, tot))
    return out


def _parabola_min(lg: F64, tot: F64) -> F64:
    """Per row, the minimum of a parabola through the best grid value and its neighbours
    (moved at most one step; the best value itself where the cost is not convex)."""
    at = np.arange(lg.shape[0])
    best = np.argmin(tot, axis=1)
    b = np.clip(best, 1, lg.shape[1] - 2)
    y0, y1, y2 = tot[at, b - 1], tot[at, b], tot[at, b + 1]
    curv = y0 - 2 * y1 + y2
    step = lg[at, b + 1] - lg[at, b]
    shift = np.where(curv > 0, 0.5 * (y0 - y2) / np.where(curv > 0, curv, 1.0), 0.0)
    return lg[at, b] + np.clip(shift, -1, 1) * step


def _k_cost(rm: ReplayModel, rows_by_run: list[I64], runs: I64, lg: F64, n_slope: int) -> F64:
    """Negative log-likelihood per run (rows) and log-K value (columns)."""
    rows = np.concatenate(rows_by_run)
    rr = np.repeat(np.arange(runs.size), [x.size for x in rows_by_run])
    n_k = lg.shape[1]
    v = rm.volume_at(rows[:, None], np.exp(lg[rr]))
    flat = np.repeat(rows, n_k)
    ll = rm.loglik(flat, rm.predict(flat, v.ravel(), n_slope)).reshape(rows.size, n_k)
    tot = np.zeros((runs.size, n_k))
    np.add.at(tot, rr, -ll)
    return tot
