"""Route RUL on the fleet (brake_env.env.fleet.route_rul, FleetRULObservation): the shift's
events re-indexed in base-mix events, and the twin's hot and mild RUL against the
simulated-ahead true RUL after pads ran the ramp or the drifts."""

from __future__ import annotations

import numpy as np
import pytest

from brake_env.data.datasets import DatasetSpec, make_dataset
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.pads import ShiftEvents
from brake_env.env.fleet.route_rul import duty_clocks, equivalent_batch
from brake_env.env.fleet.wrappers import FleetRULObservation
from brake_env.model.regime import WearRegime
from brake_env.prognostics.registry import make_predictor
from tests.brake_env.env.fleet.small import SMALL


def shift(n_done: list[int], first: list[int]) -> ShiftEvents:
    n, width = len(n_done), max(n_done)
    valid = np.arange(width)[None, :] < np.asarray(n_done)[:, None]
    measured = np.random.default_rng(0).random((6, n, width))
    return ShiftEvents(
        measured, np.ones((n, width)), valid, np.asarray(first), np.asarray(n_done),
        np.zeros(n, dtype=bool), np.full(n, 2e-6),
    )  # fmt: skip


def test_a_ramp_shift_skips_indices_and_a_drift_shift_keeps_one_event_per_index():
    ev = shift([5, 5], [100, 100])
    age, rate, last = np.array([100.0, 100.0]), np.array([2.0, 0.4]), np.array([99, 99])
    batch, rows, vehicles, after = equivalent_batch(ev, age, rate, last)
    np.testing.assert_array_equal(after, [110.0, 102.0])
    hot, mild = batch.event[rows == 0], batch.event[rows == 1]
    np.testing.assert_array_equal(hot, [101, 103, 105, 107, 109])  # ceil(100 + 2k) - 1
    np.testing.assert_array_equal(
        mild, [100, 101]
    )  # done 100.4 .. 102.0: indices 100, 100, 101, 101, 101
    # the event kept for an index is the last of those sharing it
    np.testing.assert_array_equal(batch.temp_c[rows == 1], ev.measured[4][1, [1, 4]])
    np.testing.assert_array_equal(vehicles, [0, 1])


@pytest.fixture(scope="module")
def twin(atlas):
    spec = DatasetSpec(n_train=6, n_id=0, n_ood_slow=0, n_ood_fast=0, wear=WearRegime(1e-5, 1e-6))
    return make_predictor("twin", atlas).fit(make_dataset(atlas, spec, seed=3).logs["train"])


def test_twin_route_rul_agrees_with_the_true_rul_after_any_duty(atlas, twin):
    """New pads run the ramp, the drifts, or both in turn, for 70 shifts (55%, 10% and
    ~30% of their hot life): the twin's RUL on each route is within 10% of that route's
    life of the simulated-ahead truth, its interval around it, and the mild one longer
    (coverage is measured by benchmarks/analysis/route_rul_accuracy.py)."""
    env = FleetRULObservation(
        BrakeWearFleetEnv(atlas=atlas, **{**SMALL, "episode_shifts": 80}), twin
    )
    env.reset(seed=1)
    env.step(np.array([3, 3, 3, 2]))  # every vehicle gets a new pad
    base = env.unwrapped
    for s in range(70):
        _, _, _, _, info = env.step(np.array([0, 1, s % 2, 0]))
    est, per_shift = info["rul_estimate"], base.config.events_per_shift
    k = base.truth()["wear_coeff"]
    for name, clock in zip(("hot", "mild"), duty_clocks(atlas).routes, strict=True):
        true = base.true_rul(name) / per_shift
        life = clock.life(k) / per_shift
        assert (np.abs(est[f"{name}_rul_mean"] - true) < 0.1 * life).all(), (name, true)
        lo, mean, hi = (est[f"{name}_rul_{f}"] for f in ("lower", "mean", "upper"))
        assert (lo <= mean).all() and (mean <= hi).all() and (hi > lo).all()
    assert (est["mild_rul_mean"] > 3 * est["hot_rul_mean"]).all()
