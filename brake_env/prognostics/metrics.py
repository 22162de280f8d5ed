"""Prognostic metrics of one run: RUL error, state-estimate errors, convergence (paper 2.5).

Every function takes the arrays of ONE run (one value per braking event, oldest first) and
returns plain floats, so the harness (:mod:`brake_env.prognostics.evaluation`) can average them over
runs and write them as JSON. RUL is counted in braking events; ``true`` is the ground-truth
RUL of the event log (``rul_events``, 0 at the failing event), so the life of the run is
``true[0] + 1`` events when the log starts at installation.

Definitions (paper 2.5; Saxena et al., "Metrics for offline evaluation of prognostic
performance", IJPHM 2010; Saxena et al., PHM08 challenge data set):

- RMSE: ``sqrt(mean((est - true)^2))`` over the events of the run (paper Table 4).
- Convergence event for tolerance ``eps``: the earliest event k after which the error stays
  within ``eps * life`` for the rest of the run, ``|est_j - true_j| <= eps * life`` for all
  j >= k (paper 2.5, Figure 13). A run whose last error is outside the tolerance never
  converges: its convergence event is ``life``.
- Relative accuracy at ``lambda``: ``1 - |est - true| / true`` at the event a fraction
  ``lambda`` of the way through the life.
- Alpha-lambda accuracy: whether the estimate at that event lies within ``(1 +- alpha)``
  times the true RUL.
- Prognostic horizon for ``alpha``: ``life - k_alpha``, where k_alpha is the first event from
  which the estimate stays within ``true +- alpha * life`` (the alpha bounds of constant
  width); equal to ``life`` minus the convergence event for ``eps = alpha``.
- PHM08 score: with ``d = (est - true) / scale``, ``exp(-d / 13) - 1`` for early estimates
  (d < 0) and ``exp(d / 10) - 1`` for late ones, averaged over the events. The challenge
  counted d in engine cycles (lives of ~200); brake lives are ~1e5 events, so d must be
  rescaled: the harness counts it in percent of the run's life (``scale = life / 100``),
  which makes the score independent of the life, and the mean instead of the sum keeps
  runs of different lives comparable.
- Interval coverage: share of events whose true RUL lies in ``[lower, upper]``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

F64 = NDArray[np.float64]
TOLERANCES = (0.05, 0.10, 0.20)
PHM_EARLY = 13.0
PHM_LATE = 10.0
# Exponents above this would overflow float64 (exp(709)); the score is astronomically bad
# there anyway.
_MAX_EXPONENT = 700.0


def _pair(est: ArrayLike, true: ArrayLike) -> tuple[F64, F64]:
    e = np.asarray(est, dtype=np.float64)
    t = np.asarray(true, dtype=np.float64)
    if e.ndim != 1 or e.shape != t.shape:
        raise ValueError(f"estimate and truth must be 1-D of one length, got {e.shape}, {t.shape}")
    if e.size == 0:
        raise ValueError("estimate and truth are empty: a run needs at least one event")
    if not np.all(np.isfinite(t)):
        raise ValueError("the truth contains NaN or inf")
    return e, t


def life_events(true_rul: ArrayLike) -> float:
    """Life of the run in events: the true RUL at its first event plus one."""
    t = np.asarray(true_rul, dtype=np.float64)
    if t.size == 0:
        raise ValueError("empty run")
    return float(t[0] + 1.0)


def rmse(est: ArrayLike, true: ArrayLike) -> float:
    """Root mean square error over the events of a run; estimates must be finite."""
    e, t = _pair(est, true)
    if not np.all(np.isfinite(e)):
        raise ValueError("the estimate contains NaN or inf")
    return float(np.sqrt(np.mean((e - t) ** 2)))


def relative_error(est: ArrayLike, true: ArrayLike) -> F64:
    """``|est - true| / |true|`` per event (e.g. of the wear coefficient K)."""
    e, t = _pair(est, true)
    if np.any(t == 0):
        raise ValueError("relative error needs a truth without zeros")
    return np.abs(e - t) / np.abs(t)


def convergence_event(est: ArrayLike, true: ArrayLike, tolerance: float, life: float) -> int:
    """First event from which ``|est - true| <= tolerance * life`` holds to the end of the run.

    Returns the number of events of the run when the last event is outside the tolerance
    (it never converges), and 0 when every event is inside.
    """
    if not tolerance > 0:
        raise ValueError(f"tolerance must be > 0, got {tolerance}")
    e, t = _pair(est, true)
    outside = ~(np.abs(e - t) <= tolerance * life)  # NaN estimates count as outside
    if not outside.any():
        return 0
    return int(np.flatnonzero(outside)[-1]) + 1


def converged_within(err: ArrayLike, tolerance: float) -> int:
    """First index from which ``err <= tolerance`` holds to the end (len(err) if never)."""
    x = np.asarray(err, dtype=np.float64)
    outside = ~(x <= tolerance)
    return int(np.flatnonzero(outside)[-1]) + 1 if outside.any() else 0


def lambda_index(n_events: int, lam: float) -> int:
    """Event a fraction ``lam`` of the way through a run of ``n_events`` events."""
    if not 0.0 <= lam <= 1.0:
        raise ValueError(f"lambda must be in [0, 1], got {lam}")
    if n_events < 1:
        raise ValueError("empty run")
    return min(round(lam * (n_events - 1)), n_events - 1)


def relative_accuracy(est: ArrayLike, true: ArrayLike, lam: float = 0.5) -> float:
    """``1 - |est - true| / true`` at the event ``lam`` of the way through the run.

    NaN when the true RUL there is 0 (at the failing event the ratio is undefined).
    """
    e, t = _pair(est, true)
    k = lambda_index(e.size, lam)
    if t[k] == 0:
        return float("nan")
    return float(1.0 - abs(e[k] - t[k]) / t[k])


def alpha_lambda(est: ArrayLike, true: ArrayLike, alpha: float = 0.2, lam: float = 0.5) -> bool:
    """Whether the estimate at ``lam`` of the life lies in ``[(1-alpha) true, (1+alpha) true]``."""
    if not 0.0 < alpha < 1.0:
        raise ValueError(f"alpha must be in (0, 1), got {alpha}")
    e, t = _pair(est, true)
    k = lambda_index(e.size, lam)
    return bool((1.0 - alpha) * t[k] <= e[k] <= (1.0 + alpha) * t[k])


def prognostic_horizon(est: ArrayLike, true: ArrayLike, alpha: float, life: float) -> float:
    """Events between entering the ``true +- alpha * life`` band for good and the end of life."""
    return float(life - convergence_event(est, true, alpha, life))


def phm08_score(est: ArrayLike, true: ArrayLike, scale: float = 1.0) -> float:
    """Mean PHM08 score over the events; late estimates (est > true) cost more than early.

    ``scale`` is the number of events per unit of d (the challenge's "cycle").
    """
    if not scale > 0:
        raise ValueError(f"scale must be > 0, got {scale}")
    e, t = _pair(est, true)
    d = (e - t) / scale
    x = np.where(d < 0, -d / PHM_EARLY, d / PHM_LATE)
    return float(np.mean(np.expm1(np.minimum(x, _MAX_EXPONENT))))


def interval_coverage(lower: ArrayLike, upper: ArrayLike, true: ArrayLike) -> float:
    """Share of events whose truth lies within ``[lower, upper]``."""
    lo, t = _pair(lower, true)
    hi, _ = _pair(upper, true)
    return float(np.mean((lo <= t) & (t <= hi)))


def interval_width(lower: ArrayLike, upper: ArrayLike, life: float) -> float:
    """Mean interval width as a fraction of the life."""
    lo = np.asarray(lower, dtype=np.float64)
    hi = np.asarray(upper, dtype=np.float64)
    return float(np.mean(hi - lo) / life)


def at_life_fractions(x: ArrayLike, fractions: tuple[float, ...]) -> list[float]:
    """Values of a per-event series at fractions of the run (e.g. K error at 10%, 50%, 90%)."""
    a = np.asarray(x, dtype=np.float64)
    return [float(a[lambda_index(a.size, f)]) for f in fractions]
