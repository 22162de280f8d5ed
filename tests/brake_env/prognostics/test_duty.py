"""RUL under a stated duty (brake_env.prognostics.duty): the remaining-work ratio, the twin's
route RUL equal to the route clock's from its volume and K, agreement with the simulated-ahead
true RUL, and the re-indexing of a shift in base-mix events."""

from __future__ import annotations

import numpy as np
import pytest

from brake_env.env.fleet.route_rul import duty_clocks
from brake_env.prognostics.duty import DutyClocks, equivalent_events, route_rul
from brake_env.prognostics.events import RULEstimate


@pytest.fixture(scope="module")
def clocks(atlas) -> DutyClocks:
    return duty_clocks(atlas, ("hot", "mild", "uniform"))


def test_ratio_at_a_fresh_pad_is_the_life_ratio_and_the_base_route_is_one(clocks):
    r = clocks.remaining_ratio(np.array([1.0, 0.6, clocks.base.lower_edges[-1]]))
    lives = [c.life_work / clocks.base.life_work for c in clocks.routes]
    np.testing.assert_allclose(r[0], lives, rtol=1e-12)
    np.testing.assert_allclose(r[:, 2], 1.0, rtol=1e-12)  # uniform over uniform
    # the hot route's remaining life shrinks relative to the mix as the pad thins
    assert r[0, 0] > r[1, 0] > r[2, 0] and r[2, 0] > 0
    assert (r[:, 1] > 2.0).all()  # the drifts last more than twice the mix


def test_state_predictors_route_rul_is_the_route_clock_from_volume_and_k(clocks):
    """For a twin-like estimate (volume and K on the base clock) the route RUL is
    route_clock.rul(V, K) at each node volume, mean and bounds."""
    k = np.array([1.8e-6, 2.0e-6, 2.3e-6])
    v = np.array([1.0, clocks.base.lower_edges[20], clocks.base.lower_edges[70]])
    base = clocks.base.rul(v, k)
    est = RULEstimate(base, 0.8 * base, 1.2 * base, v, k)
    out = route_rul(est, clocks.base.work_at_volume(v) / k, clocks)
    for j, c in enumerate(clocks.routes):
        np.testing.assert_allclose(out.mean[:, j], c.rul(v, k), rtol=1e-10)
        np.testing.assert_allclose(out.lower[:, j], 0.8 * c.rul(v, k), rtol=1e-10)
        np.testing.assert_allclose(out.upper[:, j], 1.2 * c.rul(v, k), rtol=1e-10)


def test_a_predictor_without_volume_is_placed_on_the_expected_path(clocks):
    k = 2e-6
    life = clocks.base.life(k)
    done = np.array([0.0, 0.3, 0.7]) * life
    est = RULEstimate(life - done)  # exact RUL, no volume: the expected path's volume
    out = route_rul(est, done, clocks)
    v = clocks.base.volume_at_work(k * done)
    np.testing.assert_allclose(out.volume, v, rtol=1e-12)
    np.testing.assert_allclose(out.mean[:, 0], clocks.routes[0].rul(v, k), rtol=1e-9)
    np.testing.assert_allclose(out.lower, out.mean)  # no interval: both bounds the mean


def test_bad_input_is_named(clocks, atlas):
    with pytest.raises(ValueError, match="ages for"):
        route_rul(RULEstimate(np.ones(2)), np.ones(3), clocks)
    with pytest.raises(ValueError, match="NaN"):
        route_rul(RULEstimate(np.array([np.nan])), np.ones(1), clocks)
    with pytest.raises(ValueError, match="unknown duty 'ramp'"):
        clocks.index("ramp")
    with pytest.raises(ValueError, match="unknown route"):
        duty_clocks(atlas, ("ramp",))


def test_equivalent_events_count_each_event_at_its_rate():
    done, after = equivalent_events(np.array([10.0, 0.0]), np.array([3, 2]), np.array([2.0, 0.5]))
    np.testing.assert_array_equal(done[0], [12.0, 14.0, 16.0])
    np.testing.assert_array_equal(done[1, :2], [0.5, 1.0])
    assert np.isnan(done[1, 2])
    np.testing.assert_array_equal(after, [16.0, 1.0])
