"""The winner's fitted parameter, refined, with an interval (docs/results/sim2real.md).

The coarse fit of :mod:`sim2real.diagnosis.attribute` puts a candidate's parameter on a grid
that halves towards neutral (plus one parabola vertex), which is enough to rank candidates
but not to feed the effect to the twin. For the winner only:

1. a bounded scalar search (Brent, ``scipy.optimize.minimize_scalar``) of the calibration
   log-likelihood between the neighbours of the best grid value, to ``refine_tol`` of the
   parameter's range and at most ``refine_evals`` models (each builds a replay model and
   fits every calibration run's K: seconds on a large log); the estimate is the best value
   tried, so it is never worse on the calibration runs than the coarse fit;
2. its interval: a bootstrap over calibration runs. The calibration log-likelihood is kept
   per run at every value tried; each resample of the runs (with replacement) sums those
   curves and takes their maximiser (a parabola through the best value and its neighbours,
   kept between those neighbours). The interval is the resamples' percentiles, widened to
   at least half the tolerance either side of the estimate (what the search resolves). It
   says how much the runs disagree on the value, not how wrong the replay model may be:
   with few calibration runs it is narrow, and it need not cover a simulated truth.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.optimize import minimize_scalar

from sim2real.diagnosis.attribute import Calibration, Progress, Scored, parameter_grid
from sim2real.diagnosis.logdata import F64
from sim2real.effects.interface import Param

METHOD = "bootstrap over calibration runs"


@dataclass(frozen=True)
class ParameterFit:
    """The winner's fitted parameter (``attribution.parameter`` of ``diagnosis.json``).

    Attributes:
        name, unit: The parameter.
        value: The estimate (the best calibration log-likelihood of the values tried).
        interval: ``level`` bootstrap interval over calibration runs.
        level: Interval level [-].
        resamples: Bootstrap resamples [-].
        runs: Calibration runs resampled [-].
        values_tried: Every value scored on the calibration runs (grid and refinement).
        refine_evaluations: Models built by the refinement (beyond the grid) [-].
        grid_value: The coarse fit's value (grid and parabola), before the refinement.
        bracket: The values the search stayed between (the best grid value's neighbours).
        range: The parameter's physically sensible range.
    """

    name: str
    unit: str
    value: float
    interval: tuple[float, float]
    level: float
    resamples: int
    runs: int
    values_tried: tuple[float, ...]
    refine_evaluations: int
    grid_value: float
    bracket: tuple[float, float]
    range: tuple[float, float]

    def summary(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "unit": self.unit,
            "value": self.value,
            "interval": list(self.interval),
            "level": self.level,
            "method": METHOD,
            "resamples": self.resamples,
            "calibration_runs": self.runs,
            "values_tried": list(self.values_tried),
            "refine_evaluations": self.refine_evaluations,
            "grid_value": self.grid_value,
            "bracket": list(self.bracket),
            "range": list(self.range),
        }


def refine_winner(
    s: Scored, ctx: Calibration, rng: np.random.Generator, *, progress: Progress = None
) -> tuple[Scored, ParameterFit]:
    """The winner ``s`` (coarse fit, ``curve`` filled) at its refined value, with held-out
    residuals, and its parameter's fit; ``rng`` draws the bootstrap resamples."""
    assert s.effect is not None
    cls = type(s.effect)
    p = cls.fitted_params()[0]
    cfg = ctx.cfg
    grid_value = s.effect[p.name]
    tried: dict[float, Scored] = {grid_value: s}
    curve = dict(s.curve)

    def loss(v: float) -> float:
        v = float(v)
        if v not in curve:
            tried[v] = ctx.score(cls, v)
            curve[v] = tried[v].cal_ll_runs
            if progress:
                progress(f"{cls.name}:{p.name}={v:.4g} (refine)")
        return -float(curve[v].sum())

    bracket = _bracket(p, s.curve, cfg.grid_points)
    n0 = len(curve)
    tol = cfg.refine_tol * (p.hi - p.lo)
    if cfg.refine_evals > 0 and bracket[1] > bracket[0]:
        opts = {"xatol": tol, "maxiter": cfg.refine_evals}
        minimize_scalar(loss, bounds=bracket, method="bounded", options=opts)
    best = max(tried, key=lambda v: tried[v].cal_ll)  # the coarse fit's value is in ``tried``
    x, ll = _curve_arrays(curve)
    boot = curve_maximiser(x, bootstrap_curves(ll, cfg.resamples, rng))
    a = (1 - cfg.level) / 2
    q_lo, q_hi = np.quantile(boot, [a, 1 - a])
    # Not narrower than the search resolves: each value's K fits make the curve jitter by
    # about one log-likelihood unit per run, which moves the maximiser within the tolerance.
    lo = max(p.lo, min(float(q_lo), best - tol / 2))
    hi = min(p.hi, max(float(q_hi), best + tol / 2))
    fit = ParameterFit(
        p.name,
        p.unit,
        best,
        (lo, hi),
        cfg.level,
        cfg.resamples,
        ll.shape[1],
        tuple(sorted(curve)),
        len(curve) - n0,
        grid_value,
        bracket,
        (p.lo, p.hi),
    )
    out = ctx.score_held(tried[best])
    out.curve = curve
    return out, fit


def _bracket(p: Param, curve: dict[float, F64], grid_points: int) -> tuple[float, float]:
    """The neighbours of the best grid value on the grid (the value itself at a range end)."""
    grid = parameter_grid(p.neutral, p.lo, p.hi, grid_points)
    i = int(np.argmax([curve[v].sum() for v in grid]))
    return grid[max(i - 1, 0)], grid[min(i + 1, len(grid) - 1)]


def _curve_arrays(curve: dict[float, F64]) -> tuple[F64, F64]:
    """(values, by value; log-likelihood per value and calibration run)."""
    x = np.array(sorted(curve))
    return x, np.stack([curve[float(v)] for v in x])


def bootstrap_curves(ll_runs: F64, n: int, rng: np.random.Generator) -> F64:
    """(n, values): the log-likelihood curve summed over a resample of the calibration runs
    (with replacement), for ``n`` resamples; ``ll_runs`` is (values, runs)."""
    n_runs = ll_runs.shape[1]
    counts = rng.multinomial(n_runs, np.full(n_runs, 1.0 / n_runs), size=n)
    return counts @ ll_runs.T


def curve_maximiser(x: F64, y: F64) -> F64:
    """Per row of ``y`` (curves over the sorted values ``x``), the vertex of a parabola
    through the best value and its neighbours, kept between those neighbours; the best value
    itself at either end of ``x`` or where the three points are not concave."""
    i = np.argmax(y, axis=1)
    if x.size < 3:
        return x[i]
    at = np.arange(y.shape[0])
    j = np.clip(i, 1, x.size - 2)
    x0, x1, x2 = x[j - 1], x[j], x[j + 1]
    y0, y1, y2 = y[at, j - 1], y[at, j], y[at, j + 1]
    s01, s12 = (y1 - y0) / (x1 - x0), (y2 - y1) / (x2 - x1)
    curv = (s12 - s01) / (x2 - x0)  # the parabola's leading coefficient
    concave = (i == j) & (curv < 0)
    safe = np.where(concave, curv, -1.0)
    vertex = 0.5 * (x0 + x1) - s01 / (2 * safe)
    return np.where(concave, np.clip(vertex, x0, x2), x[i])
