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


def test_prognostic_horizon_starts_at_the_first_event_inside_the_band() -> None:
    # band 0.2 * life 10 = 2 events; first inside at event 2 (true RUL 7), although the
    # estimate leaves the band again at event 4 (the convergence event is 5).
    err = np.array([5.0, 3.0, 0.0, 1.0, 2.5, 2.0, 1.0, 0.0, -1.0, -2.0])
    assert m.prognostic_horizon(TRUE + err, TRUE, 0.2, 10.0) == 7.0
    assert m.prognostic_horizon(TRUE, TRUE, 0.2, 10.0) == 9.0  # inside from event 0
    only_at_failure = TRUE + np.r_[np.full(9, 5.0), 0.0]
    assert m.prognostic_horizon(only_at_failure, TRUE, 0.2, 10.0) == 0.0  # true RUL 0 there
    assert m.prognostic_horizon(TRUE + 5.0, TRUE, 0.2, 10.0) == 0.0  # never inside
    nan_first = TRUE.copy()
    nan_first[0] = np.nan
    assert m.prognostic_horizon(nan_first, TRUE, 0.2, 10.0) == 8.0  # a NaN never meets it
    with pytest.raises(ValueError, match="alpha"):
        m.prognostic_horizon(TRUE, TRUE, 0.0, 10.0)


def test_lambda_is_the_first_event_at_or_after_its_time() -> None:
    assert m.lambda_index(10, 0.5) == 5  # t_lambda = 4.5 -> event 5
    assert m.lambda_index(11, 0.5) == 5  # t_lambda = 5 exactly
    assert m.lambda_index(11, 0.3) == 3  # 0.3 * 10 = 3.0000000000000004 in floating point
    assert m.lambda_index(10, 0.0) == 0 and m.lambda_index(10, 1.0) == 9
    assert m.lambda_index(1, 0.5) == 0
    with pytest.raises(ValueError, match="lambda"):
        m.lambda_index(10, 1.5)


def test_relative_accuracy_and_alpha_lambda_at_half_life() -> None:
    # lambda 0.5 of 10 events -> event 5, true RUL 4; alpha 0.25 -> band [3, 5].
    est = TRUE.copy()
    est[5] = 5.0
    assert m.relative_accuracy(est, TRUE, 0.5) == pytest.approx(1 - 1 / 4)
    assert m.alpha_lambda(est, TRUE, alpha=0.25, lam=0.5)  # on the bound: inside
    est[5] = 5.5
    assert not m.alpha_lambda(est, TRUE, alpha=0.25, lam=0.5)
    assert math.isnan(m.relative_accuracy(TRUE, TRUE, 1.0))  # true RUL 0 at the end


def test_cumulative_relative_accuracy_by_hand() -> None:
    true = np.array([4.0, 3.0, 2.0, 1.0, 0.0])
    est = np.array([5.0, 3.0, 1.0, 1.5, 7.0])
    # RA per event: 0.75, 1, 0.5, 0.5 and undefined at true RUL 0 (left out).
    assert m.cumulative_relative_accuracy(est, true) == pytest.approx((0.75 + 1 + 0.5 + 0.5) / 4)
    # lambda 0.5: t_lambda = 2, events 0..2.
    assert m.cumulative_relative_accuracy(est, true, 0.5) == pytest.approx((0.75 + 1 + 0.5) / 3)
    assert m.cumulative_relative_accuracy(TRUE, TRUE) == 1.0
    assert math.isnan(m.cumulative_relative_accuracy([1.0], [0.0]))  # nothing defined
    # The same as the RA of each event, averaged.
    rng = np.random.default_rng(0)
    noisy = TRUE + rng.normal(0.0, 1.0, TRUE.size)
    each = [m.relative_accuracy(noisy[: k + 1], TRUE[: k + 1], 1.0) for k in range(9)]
    assert m.cumulative_relative_accuracy(noisy, TRUE) == pytest.approx(np.mean(each))


def test_monotonicity_by_hand() -> None:
    assert m.monotonicity(TRUE) == 1.0  # falls at every step
    assert m.monotonicity(TRUE[::-1]) == 1.0  # rises at every step: the sign is dropped
    assert m.monotonicity([5.0, 3.0, 1.0, 1.5, 7.0]) == 0.0  # -, -, +, +
    assert m.monotonicity([5.0, 4.0, 4.0, 3.0, 2.0]) == 0.75  # -, 0, -, -
    assert m.monotonicity(np.full(6, 3.0)) == 0.0
    assert math.isnan(m.monotonicity([3.0]))
    with pytest.raises(ValueError, match="NaN"):
        m.monotonicity([3.0, np.nan])
    with pytest.raises(ValueError, match="1-D"):
        m.monotonicity(np.ones((2, 2)))


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
