"""Confidence intervals of fleet figures by a paired, stratified bootstrap over pads.

Every figure of the cost study is a smooth function of means over pads (a cost per event is
a ratio of mean cost to mean events per pad; a ratio to the oracle, a ratio of two such),
each mean taken per wear-regime label and weighted by the label's share. The bootstrap
resamples pads within each label (stratified, as they were drawn) and every policy's
values of a resampled pad go together (paired: every policy met the same pads), so the
intervals of differences between policies are as narrow as common random numbers make them.
BCa intervals (``scipy.stats.bootstrap``) correct the skew of a ratio estimator.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents.study.pads import PadSet

F64 = NDArray[np.float64]
# Statistic: the mixture means of the variables (..., variables) -> figures (..., figures).
Statistic = Callable[[F64], F64]


@dataclass(frozen=True)
class Intervals:
    """Point estimates and two-sided intervals of several figures.

    Attributes:
        point: The figures on the pads as drawn.
        low, high: Bounds of the interval of each figure.
        level: Confidence level [-].
    """

    point: F64
    low: F64
    high: F64
    level: float

    def __getitem__(self, i: int) -> tuple[float, float, float]:
        """(point, low, high) of figure ``i``."""
        return float(self.point[i]), float(self.low[i]), float(self.high[i])


def bootstrap_figures(
    pads: PadSet,
    variables: F64,
    statistic: Statistic,
    *,
    level: float = 0.95,
    n_resamples: int = 4000,
    seed: int = 0,
) -> Intervals:
    """BCa intervals of ``statistic`` of the mixture means of per-pad ``variables``.

    Args:
        pads: The pads (their labels and the labels' weights).
        variables: One row per variable, one column per pad.
        statistic: Figures from the mixture means, vectorised over leading axes.
        level: Confidence level.
        n_resamples: Bootstrap resamples.
        seed: Seeds the resampling.

    Returns:
        Each figure's point estimate and interval. Where a figure does not vary between
        resamples (every policy concerned acts alike on every pad) the interval is that
        value; an interval is widened to hold its point estimate where BCa's correction
        would push it past (a near-degenerate bootstrap distribution). Bounds are values
        the figure takes on some resample, so a figure bounded on every sample of pads
        (a ratio to the oracle is at least 1) keeps its bounds.
    """
    from scipy.stats import bootstrap

    x = np.asarray(variables, dtype=np.float64)
    if x.ndim != 2 or x.shape[1] != len(pads):
        raise ValueError(f"bootstrap_figures: variables must be (n, {len(pads)}), got {x.shape}")
    strata = pads.strata()
    weights = [pads.draws.weights[k] for k in strata]

    def means(*index: NDArray[np.intp]) -> F64:
        m = sum(w * x[:, i].mean(axis=-1) for w, i in zip(weights, index, strict=True))
        return np.moveaxis(np.asarray(m), 0, -1)  # (..., variables)

    point = np.asarray(statistic(means(*strata.values())), dtype=np.float64)
    n_out = point.size

    # scipy resamples each stratum's pad indices (each stratum on its own: stratified);
    # a stratum is given as n_out identical rows so that the statistic may return n_out
    # figures, and all rows share a resample (paired).
    def resampled(*index: NDArray[np.intp], axis: int = -1) -> F64:
        out = statistic(means(*(i[0] for i in index)))
        return np.moveaxis(np.asarray(out), -1, 0)

    data = tuple(np.broadcast_to(i, (n_out, i.size)) for i in strata.values())
    batch = max(1, int(4e7 // (x.shape[0] * len(pads))))  # ~300 MB of resampled values
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # degenerate figures are handled below
        res = bootstrap(data, resampled, vectorized=True, paired=False, axis=-1,
                        confidence_level=level, n_resamples=n_resamples, batch=batch,
                        method="BCa", rng=np.random.default_rng(seed))  # fmt: skip
    return _finish(res, point, level)


def _finish(res: Any, point: F64, level: float) -> Intervals:
    """BCa bounds; percentiles where BCa is undefined (nearly every resample equal to the
    estimate), the estimate where the figure never varies; widened to hold the estimate."""
    low = np.asarray(res.confidence_interval.low, dtype=np.float64)
    high = np.asarray(res.confidence_interval.high, dtype=np.float64)
    dist = np.asarray(res.bootstrap_distribution)
    flat = np.ptp(dist, axis=-1) <= 1e-12 * np.maximum(np.abs(point), 1.0)
    tail = 50.0 * (1.0 - level)
    pct_lo, pct_hi = np.percentile(dist, [tail, 100.0 - tail], axis=-1)
    low = np.where(np.isfinite(low), low, pct_lo)
    high = np.where(np.isfinite(high), high, pct_hi)
    low = np.where(flat, point, np.minimum(low, point))
    high = np.where(flat, point, np.maximum(high, point))
    return Intervals(point, low, high, level)
