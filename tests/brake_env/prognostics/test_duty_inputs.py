"""route_rul's volume input (issue 44, item 4): one pad's NaN volume leaves every other pad's
route RUL as it was (each NaN pad placed on the expected path alone); a volume no pad can
have (above a fresh pad's, below zero, a wrong length) is refused, naming the pad and value."""

from __future__ import annotations

import numpy as np
import pytest

from brake_env.env.fleet.route_rul import duty_clocks
from brake_env.prognostics.duty import DutyClocks, route_rul
from brake_env.prognostics.events import RULEstimate


@pytest.fixture(scope="module")
def clocks(atlas) -> DutyClocks:
    return duty_clocks(atlas, ("hot", "mild", "uniform"))


def twin_like(clocks: DutyClocks, v: np.ndarray) -> tuple[RULEstimate, np.ndarray]:
    k = np.full(v.shape, 2e-6)
    base = clocks.base.rul(v, k)
    return RULEstimate(base, 0.8 * base, 1.2 * base, v, k), clocks.base.work_at_volume(v) / k


def test_one_pads_nan_volume_changes_no_other_pads_route_rul(clocks):
    v = np.array([0.9, clocks.base.lower_edges[40], 0.6])
    est, done = twin_like(clocks, v)
    done = 0.5 * done  # the predictor's volumes are not those of the expected path
    full = route_rul(est, done, clocks)
    nan_v = v.copy()
    nan_v[1] = np.nan
    est_nan = RULEstimate(est.rul_mean, est.rul_lower, est.rul_upper, nan_v, est.wear_coeff)
    got = route_rul(est_nan, done, clocks)
    for i in (0, 2):  # the other vehicles' pads: their own volumes still read
        np.testing.assert_array_equal(got.mean[i], full.mean[i])
        assert got.volume[i] == full.volume[i]
    # the NaN pad is placed on the expected path, as a pad without a volume is
    alone = route_rul(RULEstimate(est.rul_mean[1:2]), done[1:2], clocks)
    np.testing.assert_array_equal(got.mean[1], alone.mean[0])
    assert np.isfinite(got.mean).all()


@pytest.mark.parametrize("bad", [5.0, 1.2, -0.1, np.inf])
def test_a_volume_no_pad_can_have_is_refused_naming_pad_and_value(clocks, bad):
    v = np.array([0.9, 0.8, 0.6])
    est, done = twin_like(clocks, v)
    v[2] = bad
    est = RULEstimate(est.rul_mean, volume_frac=v)
    with pytest.raises(ValueError, match=rf"volume_frac of pad 2 is {bad}"):
        route_rul(est, done, clocks)


def test_a_volume_of_another_length_is_refused(clocks):
    est, done = twin_like(clocks, np.array([0.9, 0.8]))
    with pytest.raises(ValueError, match="3 volumes for 2 estimates"):
        route_rul(RULEstimate(est.rul_mean, volume_frac=np.ones(3)), done, clocks)


def test_a_fresh_pads_volume_a_little_above_one_is_still_read_as_fresh(clocks):
    est, done = twin_like(clocks, np.array([1.0, 0.8]))
    near = RULEstimate(est.rul_mean, volume_frac=np.array([1.0 + 1e-3, 0.8]))
    got = route_rul(near, done, clocks)
    np.testing.assert_array_equal(got.volume, route_rul(est, done, clocks).volume)
