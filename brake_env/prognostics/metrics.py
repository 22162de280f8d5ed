"""Prognostic metrics of one run: RUL error, state-estimate errors, convergence (paper 2.5).

Every function takes the arrays of ONE run (one value per braking event, oldest first) and
returns plain floats, so the harness (:mod:`brake_env.prognostics.evaluation`) can average them over
runs and write them as JSON. RUL is counted in braking events; ``true`` is the ground-truth
RUL of the event log (``rul_events``, 0 at the failing event), so the life of the run is
``true[0] + 1`` events when the log starts at installation.

Definitions (paper 2.5; Saxena et al., "Metrics for offline evaluation of prognostic
performance", IJPHM 2010; Saxena et al., PHM08 challenge data set). The paper defines only
RMSE and the convergence event; the others follow Saxena et al. as NASA ProgPy's
``progpy.metrics`` implements them, and ``tests/brake_env/prognostics/test_progpy_metrics.py``
computes them with ProgPy on the same estimates. Where we differ from ProgPy, the function
says so.

- RMSE: ``sqrt(mean((est - true)^2))`` over the events of the run (paper Table 4).
- Convergence event for tolerance ``eps``: the earliest event k after which the error stays
  within ``eps * life`` for the rest of the run, ``|est_j - true_j| <= eps * life`` for all
  j >= k (paper 2.5, Figure 13). A run whose last error is outside the tolerance never
  converges: its convergence event is ``life``.
- lambda: the event ``t_lambda = lambda * (n - 1)`` of a run of n events (first event 0,
  last n - 1), or the first event after it when it falls between two.
- Relative accuracy (RA) at ``lambda``: ``1 - |est - true| / true`` at that event.
- Cumulative relative accuracy (CRA): the mean RA over the events up to ``lambda`` whose
  true RUL is not 0.
- Alpha-lambda accuracy: whether the estimate at that event lies within ``(1 +- alpha)``
  times the true RUL.
- Prognostic horizon (PH) for ``alpha``: the true RUL at the first event whose estimate lies
  within ``true +- alpha * life`` (the alpha bounds of constant width), i.e. the time of
  failure minus the time the criterion is first met. Unlike the convergence event, the
  estimate need not stay inside afterwards.
- Monotonicity: ``|sum(sign(diff(est)))| / (n - 1)``, 1 for an estimate that moves one way
  only, 0 when rises and falls balance (Coble and Hines, PHM 2009).
- PHM08 score: with ``d = (est - true) / scale``, ``exp(-d / 13) - 1`` for early estimates
  (d < 0) and ``exp(d / 10) - 1`` for late ones, averaged over the events. The challenge
  counted d in engine cycles (lives of ~200); brake lives are ~1e5 events, so d must be
  rescaled: the harness counts it in percent of the run's life (``scale = life / 100``),
  which makes the score independent of the life, and the mean instead of the sum keeps
  runs of different lives comparable.
- Interval coverage: share of events whose true RUL lies in ``[lower, upper]``.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

F64 = NDArray[np.float64]
TOLERANCES = (0.05, 0.10, 0.20)
PHM_EARLY = 13.0
PHM_LATE = 10.0
# Exponents above this would overflow float64 (exp(709)); the score is astronomically bad
# there anyway.
_MAX_EXPONENT = 700.0
# lambda * (n - 1) may land a rounding error above a whole event (0.3 * 10 = 3.0000000000000004).
_LAMBDA_SLACK = 1e-9


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
    """First event at or after ``t_lambda = lam * (n_events - 1)``.

    Saxena et al. put ``t_lambda = t_P + lam * (t_EoL - t_P)`` between the first prediction
    ``t_P`` (event 0) and the end of life ``t_EoL`` (the last event); ProgPy's
    ``alpha_lambda`` reads the first prediction at or after it, and so do we (a rounding
    error of the product does not move it to the next event).
    """
    if not 0.0 <= lam <= 1.0:
        raise ValueError(f"lambda must be in [0, 1], got {lam}")
    if n_events < 1:
        raise ValueError("empty run")
    return min(math.ceil(lam * (n_events - 1) - _LAMBDA_SLACK), n_events - 1)


def relative_accuracy(est: ArrayLike, true: ArrayLike, lam: float = 0.5) -> float:
    """``1 - |est - true| / true`` at the event ``lam`` of the way through the run.

    ProgPy's ``UncertainData.relative_accuracy`` with the true RUL as ground truth gives the
    same number. NaN when the true RUL there is 0 (at the failing event the ratio is
    undefined; ProgPy raises ZeroDivisionError).
    """
    e, t = _pair(est, true)
    k = lambda_index(e.size, lam)
    if t[k] == 0:
        return float("nan")
    return float(1.0 - abs(e[k] - t[k]) / t[k])


def cumulative_relative_accuracy(est: ArrayLike, true: ArrayLike, lam: float = 1.0) -> float:
    """Mean relative accuracy ``1 - |est - true| / true`` over the events up to ``lam``.

    Saxena et al.'s CRA with equal weights over the events ``0 .. lambda_index(n, lam)``,
    leaving out those whose true RUL is 0 (RA undefined); NaN when none is left. A NaN
    estimate makes it NaN.

    ProgPy's ``cumulative_relative_accuracy`` averages its RA over a profile of predicted
    *times of event*, so it divides the error by the time of failure counted from its time
    origin, ``1 - mean(|est - true|) / t_EoL``, not by the true RUL: it changes when the
    origin moves (a log that starts mid-life) and weighs late errors no more than early
    ones. We keep Saxena's RUL-relative RA, the one :func:`relative_accuracy` reads.
    """
    e, t = _pair(est, true)
    k = lambda_index(e.size, lam)
    e, t = e[: k + 1], t[: k + 1]
    keep = t != 0
    if not keep.any():
        return float("nan")
    return float(1.0 - np.mean(np.abs(e[keep] - t[keep]) / np.abs(t[keep])))


def alpha_lambda(est: ArrayLike, true: ArrayLike, alpha: float = 0.2, lam: float = 0.5) -> bool:
    """Whether the estimate at ``lam`` of the life lies in ``[(1-alpha) true, (1+alpha) true]``.

    ProgPy's ``alpha_lambda`` (a point estimate, any beta in (0, 1]) agrees except on the
    bounds themselves: ProgPy's interval is open, Saxena et al.'s and ours closed.
    """
    if not 0.0 < alpha < 1.0:
        raise ValueError(f"alpha must be in (0, 1), got {alpha}")
    e, t = _pair(est, true)
    k = lambda_index(e.size, lam)
    return bool((1.0 - alpha) * t[k] <= e[k] <= (1.0 + alpha) * t[k])


def prognostic_horizon(est: ArrayLike, true: ArrayLike, alpha: float, life: float) -> float:
    """The true RUL [events] at the first event whose estimate is within ``alpha * life``.

    Saxena et al.'s ``PH = t_EoL - t_i``, where ``t_i`` is the first event whose estimate
    meets the criterion ``|est - true| <= alpha * life`` and whose true RUL is above 0; the
    estimate may leave the band afterwards (:func:`convergence_event` asks that it stays).
    This is ProgPy's ``prognostic_horizon`` with that criterion, event for event, except
    that a run that never meets it has a horizon of 0 here and None in ProgPy.
    NaN estimates never meet it.
    """
    if not alpha > 0:
        raise ValueError(f"alpha must be > 0, got {alpha}")
    e, t = _pair(est, true)
    met = (np.abs(e - t) <= alpha * life) & (t > 0)
    if not met.any():
        return 0.0
    return float(t[np.argmax(met)])


def monotonicity(est: ArrayLike) -> float:
    """``|sum(sign(diff(est)))| / (n - 1)`` of a run's RUL estimates [-], in [0, 1].

    1 when every step moves the estimate the same way, 0 when rises and falls balance;
    steps that leave it unchanged count 0 but stay in ``n - 1``. ProgPy's ``monotonicity``
    (Coble and Hines, PHM 2009) on the same estimates. NaN for a run of one event.
    """
    e = np.asarray(est, dtype=np.float64)
    if e.ndim != 1 or e.size == 0:
        raise ValueError(f"the estimate must be 1-D and not empty, got shape {e.shape}")
    if not np.all(np.isfinite(e)):
        raise ValueError("the estimate contains NaN or inf")
    if e.size < 2:
        return float("nan")
    return float(abs(np.sign(np.diff(e)).sum()) / (e.size - 1))


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
