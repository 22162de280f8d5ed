"""Our prognostic metrics against NASA ProgPy's ``progpy.metrics`` on the same estimates.

ProgPy is a dev dependency: this module imports it outright, so a missing ProgPy fails
the suite instead of skipping the cross-check. ProgPy scores a *profile*: at each time of
prediction t, a predicted time of event ``ToE = t + RUL estimate``, against the true time of
event (here the failing event). Each run below is turned into such a profile, with event k
as time k; the estimates are multiples of 1/4 event, so ProgPy's ``ToE - t`` gives back the
very RUL estimate we score and the comparison is exact.

Agreement, event for event: alpha-lambda (but on the band's bounds), relative accuracy,
prognostic horizon (but for a run that never meets the criterion) and monotonicity. By
definition, ProgPy's cumulative relative accuracy divides by the time of event, ours (Saxena
et al.'s) by the true RUL: see :func:`metrics.cumulative_relative_accuracy`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from numpy.typing import NDArray
from progpy.metrics import (
    alpha_lambda,
    cumulative_relative_accuracy,
    monotonicity,
    prognostic_horizon,
)
from progpy.predictors import ToEPredictionProfile
from progpy.uncertain_data import ScalarData

from brake_env.prognostics import metrics as m

F64 = NDArray[np.float64]
N = 400  # events per run; t_lambda = lambda * 399 mostly falls between two events
TRUE = np.arange(N - 1, -1, -1, dtype=np.float64)  # RUL N-1 .. 0; failure at event N-1
LIFE = float(N)
ALPHAS = (0.1, 0.2)
LAMBDAS = (0.1, 0.3, 0.5, 0.75, 0.9)


def _quarters(x: F64) -> F64:
    return np.round(x * 4.0) / 4.0


def _runs() -> dict[str, F64]:
    """RUL estimates of typical shapes, each for the run ``TRUE``."""
    rng = np.random.default_rng(7)
    k = np.arange(N, dtype=np.float64)
    steps = np.repeat(TRUE[::50], 50)  # updated every 50 events, flat in between
    return {
        "perfect": TRUE.copy(),
        "late by 15% of life": TRUE + 0.15 * LIFE,
        "physics line (wrong life)": _quarters(np.maximum(TRUE * 1.3 - 20.0, 0.0)),
        "noisy, converging": _quarters(TRUE + 150.0 * np.exp(-k / 80.0) + rng.normal(0.0, 8.0, N)),
        "piecewise constant": steps,
        # Inside the 20% band from the start, then out, ending outside: a horizon by
        # ProgPy's definition, none by "inside for good".
        "inside early, out at the end": TRUE + np.where(k < 150, 30.0, 120.0),
        "random walk": _quarters(TRUE + np.cumsum(rng.normal(0.0, 6.0, N))),
        "never inside": TRUE + 0.5 * LIFE,
    }


RUNS = _runs()


def _profile(est: F64, origin: float = 0.0) -> ToEPredictionProfile:
    """ProgPy's view of a run: predicted time of event at every event (time origin + k)."""
    profile = ToEPredictionProfile()
    for k, r in enumerate(est):
        t = origin + k
        profile.add_prediction(t, ScalarData({"EOL": t + float(r)}))
    return profile


def _truth(origin: float = 0.0) -> dict[str, float]:
    return {"EOL": origin + N - 1.0}  # the failing event, true RUL 0


def _band(alpha: float) -> Callable[[Any, dict[str, float]], dict[str, bool]]:
    """The prognostic-horizon criterion of :func:`metrics.prognostic_horizon`."""

    def criterion(tte: Any, truth_tte: dict[str, float]) -> dict[str, bool]:
        return {key: abs(v - truth_tte[key]) <= alpha * LIFE for key, v in tte.mean.items()}

    return criterion


def test_the_profiles_give_back_our_estimates_exactly() -> None:
    for name, est in RUNS.items():
        profile = _profile(est, origin=1000.0)
        back = np.array([toe.mean["EOL"] - t for t, toe in profile.items()])
        np.testing.assert_array_equal(back, est, err_msg=name)


@pytest.mark.parametrize("name", list(RUNS))
def test_alpha_lambda_agrees(name: str) -> None:
    est = RUNS[name]
    profile = _profile(est)
    for alpha in ALPHAS:
        for lam in LAMBDAS:
            k = m.lambda_index(N, lam)
            lo, hi = (1 - alpha) * TRUE[k], (1 + alpha) * TRUE[k]
            # The bounds are where the two differ (closed vs open): none here is on one.
            assert min(abs(est[k] - lo), abs(est[k] - hi)) > 1e-6, (name, alpha, lam)
            theirs = alpha_lambda(profile, _truth(), lam * (N - 1), alpha, beta=1.0)["EOL"]
            assert m.alpha_lambda(est, TRUE, alpha, lam) == theirs, (name, alpha, lam)


def test_alpha_lambda_on_the_bound_differs_by_definition() -> None:
    # t_lambda = 0.5 * 399 -> event 200, true RUL 199; alpha 0.25: est on the upper bound.
    k = m.lambda_index(N, 0.5)
    est = TRUE.copy()
    est[k] = 1.25 * TRUE[k]
    theirs = alpha_lambda(_profile(est), _truth(), 0.5 * (N - 1), 0.25, beta=1.0)["EOL"]
    assert m.alpha_lambda(est, TRUE, 0.25, 0.5) and not theirs  # closed here, open there


@pytest.mark.parametrize("name", list(RUNS))
def test_relative_accuracy_agrees(name: str) -> None:
    est = RUNS[name]
    profile = _profile(est)
    for lam in LAMBDAS:
        # ProgPy's time for lambda: the first prediction at or after it, as alpha_lambda.
        t = next(t for t in profile if t >= lam * (N - 1))  # sorted, as ProgPy iterates
        rul = ScalarData({"EOL": profile[t].mean["EOL"] - t})
        theirs = rul.relative_accuracy({"EOL": TRUE[int(t)]})["EOL"]
        assert m.relative_accuracy(est, TRUE, lam) == pytest.approx(theirs, rel=1e-14, abs=0)


@pytest.mark.parametrize("name", list(RUNS))
def test_prognostic_horizon_agrees(name: str) -> None:
    est = RUNS[name]
    profile = _profile(est)
    for alpha in ALPHAS:
        theirs = prognostic_horizon(profile, _band(alpha), _truth())["EOL"]
        ours = m.prognostic_horizon(est, TRUE, alpha, LIFE)
        # A run that never meets the criterion: None in ProgPy, a horizon of 0 here.
        assert ours == (0.0 if theirs is None else theirs), (name, alpha)


def test_prognostic_horizon_no_longer_asks_to_stay_inside() -> None:
    # The earlier definition, life minus the convergence event ("inside for good"), gave 0
    # where ProgPy gives the whole life: this run ends outside the band.
    est = RUNS["inside early, out at the end"]
    old = LIFE - m.convergence_event(est, TRUE, 0.2, LIFE)
    theirs = prognostic_horizon(_profile(est), _band(0.2), _truth())["EOL"]
    assert old == 0.0
    assert theirs == m.prognostic_horizon(est, TRUE, 0.2, LIFE) == N - 1.0
    assert prognostic_horizon(_profile(RUNS["never inside"]), _band(0.2), _truth())["EOL"] is None


@pytest.mark.parametrize("name", list(RUNS))
def test_monotonicity_agrees(name: str) -> None:
    est = RUNS[name]
    assert m.monotonicity(est) == monotonicity(_profile(est))["EOL"]


@pytest.mark.parametrize("name", list(RUNS))
def test_cumulative_relative_accuracy_differs_by_its_denominator(name: str) -> None:
    est = RUNS[name]
    err = np.abs(est - TRUE)
    # ProgPy: 1 - mean |error| / time of event, over every prediction of the profile.
    theirs = cumulative_relative_accuracy(_profile(est), _truth())["EOL"]
    assert theirs == pytest.approx(1.0 - err.mean() / (N - 1.0), rel=1e-12)
    # The time origin moves it (a log starting 30,000 events into the pad's life) ...
    shifted = cumulative_relative_accuracy(_profile(est, 30_000.0), _truth(30_000.0))["EOL"]
    assert shifted == pytest.approx(1.0 - err.mean() / (30_000.0 + N - 1.0), rel=1e-12)
    # ... ours is ProgPy's relative accuracy of the RUL at each event with true RUL > 0,
    # averaged, and does not depend on the origin.
    each = [
        ScalarData({"EOL": float(e)}).relative_accuracy({"EOL": float(t)})["EOL"]
        for e, t in zip(est[:-1], TRUE[:-1], strict=True)
    ]
    assert m.cumulative_relative_accuracy(est, TRUE) == pytest.approx(np.mean(each), rel=1e-12)
    if err.any():
        assert m.cumulative_relative_accuracy(est, TRUE) != pytest.approx(theirs, rel=1e-3)
