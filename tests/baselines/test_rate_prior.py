"""The Student-t rate prior: the normal conjugate update in the normal limit, the prior
without a reading, and heavy tails that yield to a reading far from the training pads."""

from __future__ import annotations

import numpy as np
import pytest

from baselines._rate_prior import RatePrior


def test_normal_limit_is_the_conjugate_update() -> None:
    prior = RatePrior(mean=1.0, scale=0.1, dof=1e7, nodes=64)
    p, read = np.array([0.0, 100.0, 1e4]), np.array([0.0, 1.3, 0.7])
    r, sd = prior.posterior(p, p * read)
    post_p = p + 1.0 / 0.1**2
    np.testing.assert_allclose(r, (100.0 * 1.0 + p * read) / post_p, rtol=1e-5)
    np.testing.assert_allclose(sd, 1.0 / np.sqrt(post_p), rtol=1e-3)


def test_no_reading_leaves_the_prior() -> None:
    prior = RatePrior(mean=2.0, scale=0.5, dof=9.0)
    r, sd = prior.posterior(np.zeros(1), np.zeros(1))
    assert r[0] == pytest.approx(2.0)
    assert sd[0] == pytest.approx(0.5 * np.sqrt(9 / 7), rel=0.05)  # t's sd, 32 nodes


def test_heavy_tails_yield_to_a_far_reading() -> None:
    """A reading 10 prior scales away, as precise as the prior: a normal prior splits the
    difference, the t prior (3 dof) lets the reading win."""
    p = np.array([1.0 / 0.1**2])
    r_t, _ = RatePrior(1.0, 0.1, 3.0).posterior(p, p * 2.0)
    r_n, _ = RatePrior(1.0, 0.1, 1e7).posterior(p, p * 2.0)
    assert r_n[0] == pytest.approx(1.5, rel=1e-4) and r_t[0] > 1.9
    with pytest.raises(ValueError, match="scale and dof"):
        RatePrior(1.0, 0.0, 3.0)
