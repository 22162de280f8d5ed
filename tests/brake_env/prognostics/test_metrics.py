"""Prognostic metrics on hand-made runs whose answers are computed by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest

from brake_env.prognostics import metrics as m

TRUE = np.arange(9, -1, -1, dtype=np.float64)  # a run of 10 events: RUL 9 .. 0


def test_life_and_rmse() -> None:
    assert m.life_events(TRUE) == 10.0
    est = TRUE + np.array([3, -3, 3, -3, 3, -3, 3, -3, 3, -3])
    assert m.rmse(est, TRUE) == pytest.approx(3.0)
    assert m.rmse(TRUE, TRUE) == 0.0


def test_convergence_event_is_start_of_the_last_stretch_within_tolerance() -> None:
    # tolerance 0.2 * life 10 = 2 events; errors |e| > 2 at events 0, 1 and 4, then within.
    err = np.array([5.0, 3.0, 0.0, 1.0, 2.5, 2.0, 1.0, 0.0, -1.0, -2.0])
    assert m.convergence_event(TRUE + err, TRUE, 0.2, 10.0) == 5
    assert m.convergence_event(TRUE, TRUE, 0.05, 10.0) == 0  # always within
    late = TRUE.copy()
    late[-1] += 3.0
    assert m.convergence_event(late, TRUE, 0.2, 10.0) == 10  # never converges
    nan = TRUE.copy()
    nan[6] = np.nan
    assert m.convergence_event(nan, TRUE, 0.2, 10.0) == 7  # a missing estimate is a miss
    assert m.prognostic_horizon(TRUE + err, TRUE, 0.2, 10.0) == 5.0


def test_relative_accuracy_and_alpha_lambda_at_half_life() -> None:
    # lambda 0.5 of 10 events -> index round(4.5) = 4 (banker's rounding), true RUL 5.
    est = TRUE.copy()
    est[4] = 6.0
    assert m.lambda_index(10, 0.5) == 4
    assert m.relative_accuracy(est, TRUE, 0.5) == pytest.approx(1 - 1 / 5)
    assert m.alpha_lambda(est, TRUE, alpha=0.2, lam=0.5)  # 6 within [4, 6]
    est[4] = 6.5
    assert not m.alpha_lambda(est, TRUE, alpha=0.2, lam=0.5)
    assert math.isnan(m.relative_accuracy(TRUE, TRUE, 1.0))  # true RUL 0 at the end


def test_phm08_score_is_asymmetric() -> None:
    true = np.array([100.0])
    early, late = m.phm08_score([87.0], true), m.phm08_score([110.0], true)
    assert early == pytest.approx(math.e - 1)  # d = -13 -> exp(1) - 1
    assert late == pytest.approx(math.e - 1)  # d = +10 -> exp(1) - 1
    assert m.phm08_score([90.0], true) < m.phm08_score([110.0], true)
    assert m.phm08_score([110.0], true, scale=10.0) == pytest.approx(math.exp(0.1) - 1)
    assert m.phm08_score([1e9], true) < math.inf  # clipped, no overflow warning


def test_interval_coverage_and_width() -> None:
    lower, upper = TRUE - 1, TRUE + 1
    lower[:3] = TRUE[:3] + 0.5  # misses the truth at 3 of 10 events
    assert m.interval_coverage(lower, upper, TRUE) == pytest.approx(0.7)
    assert m.interval_width(TRUE - 1, TRUE + 1, 10.0) == pytest.approx(0.2)


def test_relative_error_and_its_convergence() -> None:
    k_true = np.full(5, 2e-6)
    k_est = np.array([4e-6, 1e-6, 2.3e-6, 2.1e-6, 2e-6])
    err = m.relative_error(k_est, k_true)
    np.testing.assert_allclose(err, [1.0, 0.5, 0.15, 0.05, 0.0])
    assert m.converged_within(err, 0.1) == 3
    assert m.at_life_fractions(err, (0.0, 0.5, 1.0)) == pytest.approx([1.0, 0.15, 0.0])


def test_bad_input_is_rejected_clearly() -> None:
    with pytest.raises(ValueError, match="one length"):
        m.rmse([1.0, 2.0], [1.0])
    with pytest.raises(ValueError, match="empty"):
        m.rmse([], [])
    with pytest.raises(ValueError, match="tolerance"):
        m.convergence_event(TRUE, TRUE, 0.0, 10.0)
    with pytest.raises(ValueError, match="NaN"):
        m.rmse([np.nan], [1.0])
