"""Right-censored training lives (docs/results/prognostics.md).

A pad removed at event ``c`` before failure survived ``c + 1`` events: its life is longer,
so its wear coefficient (or wear rate) is *below* the one a life of ``c + 1`` events would
give. A remaining volume measured in the workshop says more: under a wear model it is a
noisy reading of the coefficient. The baselines fit a normal population of coefficients to
all three kinds of evidence by maximum likelihood (Tobit-style survival likelihood):

- a run that failed: its coefficient ``x``, density ``N(x; mu, sigma)``;
- a run removed before failure: only ``K < u``, probability ``Phi((u - mu) / sigma)``;
- a removed run with measured volumes: a reading ``m`` with noise ``s`` and ``K < u``,
  ``N(m; mu, sigma^2 + s^2) * Phi((u - m_post) / s_post)`` (the posterior of K given the
  reading, truncated by survival).

The column names are the event-log schema's (docs/schema.md).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from brake_env.data.schema import FAILED, MEASURED_VOLUME

__all__ = ["FAILED", "MEASURED_VOLUME", "Evidence", "fit_normal"]

F64 = NDArray[np.float64]


def _empty() -> F64:
    return np.empty(0)


@dataclass(frozen=True, eq=False)
class Evidence:
    """What the training runs say about one coefficient per run (any positive unit).

    Attributes:
        exact: Coefficients of runs that failed.
        upper: Upper bounds of runs removed before failure, without a measurement.
        measured, measured_sd, measured_upper: Per removed run with measured volumes: the
            coefficient they read, its standard deviation and the survival upper bound.
    """

    exact: F64 = field(default_factory=_empty)
    upper: F64 = field(default_factory=_empty)
    measured: F64 = field(default_factory=_empty)
    measured_sd: F64 = field(default_factory=_empty)
    measured_upper: F64 = field(default_factory=_empty)

    @property
    def censored(self) -> bool:
        return bool(self.upper.size or self.measured.size)

    @property
    def n_values(self) -> int:
        """Runs whose coefficient is known or read (not only bounded)."""
        return int(self.exact.size + self.measured.size)


def fit_normal(ev: Evidence) -> tuple[float, float]:
    """Maximum-likelihood mean and standard deviation of the coefficient's population.

    Without censored runs these are the mean and the (ddof 0) standard deviation of
    ``exact``. The standard deviation is kept above 1e-6 of the scale of the values, so
    identical coefficients give a finite fit.

    Raises:
        ValueError: No run at all, or censored runs beside fewer than two runs whose
            coefficient is known or measured: bounds alone do not fix a mean.
    """
    if not ev.censored and ev.exact.size:
        return float(np.mean(ev.exact)), float(np.std(ev.exact))
    if ev.n_values < 2:
        raise ValueError(
            f"{ev.n_values} run(s) with a known life or a measured volume: at least two are"
            " needed (runs removed before failure only bound the life)"
        )
    from scipy import optimize, stats  # only censored fits need them

    vals = np.concatenate([ev.exact, ev.measured])
    scale = float(np.median(np.abs(vals))) or 1.0
    x, u, m, s, mu_up = (
        a / scale for a in (ev.exact, ev.upper, ev.measured, ev.measured_sd, ev.measured_upper)
    )
    floor = np.log(1e-6)

    def nll(theta: F64) -> float:
        mu, log_sd = float(theta[0]), max(float(theta[1]), floor)
        sd = np.exp(log_sd)
        ll = stats.norm.logpdf(x, mu, sd).sum() + stats.norm.logcdf((u - mu) / sd).sum()
        tot = sd**2 + s**2
        post_mean = (mu * s**2 + m * sd**2) / tot
        post_sd = sd * s / np.sqrt(tot)
        ll += stats.norm.logpdf(m, mu, np.sqrt(tot)).sum()
        ll += stats.norm.logcdf((mu_up - post_mean) / post_sd).sum()
        return -float(ll)

    sd0 = float(np.std(vals)) or 0.1 * float(np.mean(np.abs(vals)))
    start = np.array([float(np.mean(vals)), np.log(max(sd0, 1e-3))])
    res = optimize.minimize(
        nll, start, method="Nelder-Mead", options={"xatol": 1e-10, "fatol": 1e-12, "maxiter": 4000}
    )
    mu, log_sd = float(res.x[0]), max(float(res.x[1]), floor)
    return mu * scale, float(np.exp(log_sd)) * scale
