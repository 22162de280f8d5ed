"""A predictor's RUL in a planner's units (brake_env.prognostics.planner_units): the twin's
route RUL equal to the route clock's, shifts and calendar time from events per shift, the
failure probability from the interval's lognormal, events per shift from time stamps, and
bad input named."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from brake_env.env.fleet.route_rul import duty_clocks
from brake_env.prognostics.duty import DutyClocks
from brake_env.prognostics.planner_units import (
    PLANNER_ROUTES,
    events_per_shift_from_times,
    last_times,
    p_fail_before,
    planner_units,
)

K = np.array([1.8e-6, 2.0e-6, 2.3e-6])


@pytest.fixture(scope="module")
def clocks(atlas) -> DutyClocks:
    return duty_clocks(atlas, PLANNER_ROUTES)


def twin_table(clocks: DutyClocks) -> pd.DataFrame:
    """Three twin-like last estimates (volume and K on the base clock), a fresh pad, one
    a fifth down the layers and one near the end."""
    v = np.array([1.0, clocks.base.lower_edges[20], clocks.base.lower_edges[70]])
    base = clocks.base.rul(v, K)
    return pd.DataFrame(
        {
            "run_id": ["a", "b", "c"],
            "rul_mean": base,
            "rul_lower": 0.7 * base,
            "rul_upper": 1.4 * base,
            "volume_frac": v,
            "wear_coeff": K,
            "events_since_install": clocks.base.work_at_volume(v) / K,
        }
    )


def test_twin_route_rul_is_the_route_clocks_and_hot_is_shortest(clocks):
    t = twin_table(clocks)
    out = planner_units(t, clocks, 400.0, (7.0,))
    v = t["volume_frac"].to_numpy()
    for r, c in zip(clocks.names, clocks.routes, strict=True):
        np.testing.assert_allclose(out[f"rul_{r}_events"], c.rul(v, K), rtol=1e-10)
        np.testing.assert_allclose(out[f"rul_{r}_events_lo"], 0.7 * c.rul(v, K), rtol=1e-10)
        np.testing.assert_allclose(out[f"rul_{r}_events_hi"], 1.4 * c.rul(v, K), rtol=1e-10)
    np.testing.assert_allclose(out["rul_uniform_events"], t["rul_mean"], rtol=1e-12)
    assert (out["rul_hot_events"] < out["rul_uniform_events"]).all()
    assert (out["rul_uniform_events"] < out["rul_mild_events"]).all()


def test_shifts_are_events_over_events_per_shift_and_calendar_follows(clocks):
    t = twin_table(clocks)
    per = np.array([400.0, 250.0, 555.5])
    as_of = np.array([1.7e9, np.nan, 0.0])
    out = planner_units(t, clocks, per, (7.0, 14.0), as_of=as_of, shift_hours=8.0)
    for r in PLANNER_ROUTES:
        for tail in ("", "_lo", "_hi"):
            x = out[f"rul_{r}_events{tail}"].to_numpy() / per
            assert np.array_equal(out[f"rul_{r}_shifts{tail}"].to_numpy(), x)
        want = as_of + out[f"rul_{r}_shifts"].to_numpy() * 8.0 * 3600.0
        np.testing.assert_allclose(out[f"fail_{r}_time_s"], want, rtol=1e-15)
        assert np.isnan(out[f"fail_{r}_time_s"][1])  # no as-of time, no date
    assert np.array_equal(out["as_of"].to_numpy(), as_of, equal_nan=True)
    assert list(out.index) == list(t.index) and out["events_per_shift"].tolist() == per.tolist()


def test_p_fail_is_a_probability_rising_with_the_horizon_from_zero(clocks):
    lo, hi = np.array([100.0, 5_000.0, 1.0]), np.array([400.0, 9_000.0, 1.0])
    e = np.linspace(0.0, 20_000.0, 401)
    p = p_fail_before(lo, hi, np.tile(e, (3, 1)))
    assert ((p >= 0) & (p <= 1)).all() and (np.diff(p, axis=1) >= 0).all()
    assert (p[:, 0] == 0).all() and p[0, -1] > 0.999999
    # at the interval's bounds: the tails outside the 90% interval
    np.testing.assert_allclose(p_fail_before(lo[:2], hi[:2], lo[:2]), 0.05, rtol=1e-12)
    np.testing.assert_allclose(p_fail_before(lo[:2], hi[:2], hi[:2]), 0.95, rtol=1e-12)
    np.testing.assert_allclose(p_fail_before(lo[:1], hi[:1], lo[:1], level=0.5), 0.25)
    assert p[2, 1] == 1.0  # an interval of no width: sure once its bound is passed


def test_p_fail_columns_at_the_lower_bound_horizon_and_without_interval(clocks):
    t = twin_table(clocks)
    per = 300.0
    h = float(t["rul_lower"].iloc[1]) / per  # the base mix's lower bound, in shifts
    out = planner_units(t, clocks, per, (h / 2, h, 2 * h))
    p = out.filter(like="p_fail_uniform_").to_numpy()
    assert p[1, 1] == pytest.approx(0.05, rel=1e-9)
    assert (np.diff(p, axis=1) >= 0).all() and ((p >= 0) & (p <= 1)).all()
    # the hot route fails sooner than the mix, the mix sooner than the drifts
    hot, mild = out.filter(like="p_fail_hot_").to_numpy(), out.filter(like="p_fail_mild_")
    assert (hot >= p).all() and (p >= mild.to_numpy()).all() and hot[1, 1] > 0.5
    bare = planner_units(t.drop(columns=["rul_lower", "rul_upper"]), clocks, per, (h,))
    assert bare.filter(like="p_fail_").isna().all().all()  # no interval: no distribution
    assert (bare["rul_hot_shifts_lo"] == bare["rul_hot_shifts"]).all()


def test_unknown_events_per_shift_leaves_the_shift_columns_empty(clocks):
    out = planner_units(twin_table(clocks), clocks, np.array([400.0, np.nan, 400.0]))
    assert out.loc[1].filter(like="shifts").isna().all()
    assert out.loc[0].filter(like="shifts").notna().all()
    assert out.loc[1].filter(like="_events").notna().all()


def time_log() -> pd.DataFrame:
    """Pad A: a partial first day (100 events), four days of 700, 800, 900 and 820 events
    with a parked day among them, a partial last day (50). Pad B: 31 events over 6 hours.
    Pad C: one event. Times at random within each day."""
    rng = np.random.default_rng(0)
    days = [(0, 100), (1, 700), (2, 800), (4, 900), (5, 820), (6, 50)]
    a = np.concatenate([d * 86_400 + np.sort(rng.uniform(0, 86_400, n)) for d, n in days])
    b = 3 * 86_400 + np.linspace(0.0, 6 * 3600.0, 31)
    t = np.concatenate([a, b, [1e6]])
    runs = ["A"] * a.size + ["B"] * b.size + ["C"]
    return pd.DataFrame({"run_id": runs, "time_s": t})


def test_events_per_shift_from_time_stamps():
    log = time_log()
    per = events_per_shift_from_times(log, 12.0)
    assert list(per.index) == ["A", "B", "C"]
    assert per["A"] == 810.0 * 12 / 24  # the median day braked, partial days left out
    assert per["B"] == pytest.approx(30 / 6 * 12)  # under three days: over its span
    assert per["C"] == np.median([per["A"], per["B"]])  # no span: the others' median
    assert events_per_shift_from_times(log, 8.0)["A"] == 810.0 * 8 / 24
    last = last_times(log)
    assert last["A"] == log["time_s"][log["run_id"] == "A"].max() and last["C"] == 1e6


def test_bad_input_is_named(clocks):
    t = twin_table(clocks)
    with pytest.raises(ValueError, match="must be a number of shifts > 0"):
        planner_units(t, clocks, 400.0, (7.0, 0.0))
    with pytest.raises(ValueError, match="repeats"):
        planner_units(t, clocks, 400.0, (7.0, 7.0))
    with pytest.raises(ValueError, match="events_per_shift of pad 1 is -3"):
        planner_units(t, clocks, np.array([400.0, -3.0, 1.0]))
    with pytest.raises(ValueError, match="2 values of events_per_shift for 3 pads"):
        planner_units(t, clocks, np.array([400.0, 3.0]))
    with pytest.raises(ValueError, match="no column 'events_since_install'"):
        planner_units(t.drop(columns="events_since_install"), clocks, 400.0)
    with pytest.raises(ValueError, match="shift_hours"):
        planner_units(t, clocks, 400.0, shift_hours=0.0)
    with pytest.raises(ValueError, match="--events-per-shift"):
        events_per_shift_from_times(pd.DataFrame({"run_id": ["a"], "event": [0]}))
    with pytest.raises(ValueError, match="--events-per-shift"):
        events_per_shift_from_times(pd.DataFrame({"run_id": ["a", "b"], "time_s": [1.0, 2.0]}))
    with pytest.raises(ValueError, match="--shift-hours must be > 0"):
        events_per_shift_from_times(time_log(), -1.0)
