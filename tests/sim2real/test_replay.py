"""Replay of a log through the nominal model: pad-state fit and the wear clock."""

from __future__ import annotations

import dataclasses

import numpy as np

from brake_env.model.atlas import Atlas
from sim2real.diagnose import _sample_rows
from sim2real.effects import PowerLawWear
from sim2real.replay import ReplayModel, prepare_log
from sim2real.truth import TruthSpec, simulate_truth
from tests.sim2real.conftest import SMALL, short_runs


def test_likelihood_fit_recovers_each_pads_k_on_a_no_effect_log(s2r_atlas: Atlas) -> None:
    log = simulate_truth(SMALL, [], TruthSpec(short_runs(4)), seed=21)["train"]
    d = prepare_log(log, s2r_atlas)
    rm = ReplayModel(s2r_atlas, d)
    k = rm.fit_k(_sample_rows(d, 1500, np.random.default_rng(0)))
    true_k = log.groupby("run_id", observed=True)["wear_coeff"].first().to_numpy()
    # Least squares on the logged slope and unfloored distance put K 1.4-2.5% low here.
    np.testing.assert_allclose(k, true_k, rtol=0.01)


def test_wear_law_in_speed_reweights_the_operational_time(s2r_atlas: Atlas) -> None:
    spec = short_runs(2)
    spec = dataclasses.replace(spec, route_block_events=400)
    log = simulate_truth(SMALL, [], TruthSpec(spec), seed=3)["train"]
    d = prepare_log(log, s2r_atlas)
    steep = ReplayModel(s2r_atlas, d, PowerLawWear(b=2.0))
    step_nominal, step_steep = np.diff(d.u), np.diff(steep.u)
    haul = ((d.event[:-1] // 400) % 2 == 0) & (np.diff(d.run) == 0)
    pit = ((d.event[:-1] // 400) % 2 == 1) & (np.diff(d.run) == 0)
    # Faster stops wear more under b > 1: haul-road events count for more than nominal.
    nominal_ratio = step_nominal[haul].mean() / step_nominal[pit].mean()
    steep_ratio = step_steep[haul].mean() / step_steep[pit].mean()
    assert steep_ratio > 1.3 * nominal_ratio  # 3.6 -> 5.9 on this seed
    # Severities stay relative to the log's mean: a run's total operational time barely moves.
    assert abs(steep.u[d.starts[1] - 1] / d.u[d.starts[1] - 1] - 1) < 0.05
