"""Replay of a log through the nominal model: the wear clock and the pad-state fit."""

from __future__ import annotations

import dataclasses

import numpy as np

from brake_env.model.atlas import Atlas
from brake_env.model.wear import WearModel
from sim2real.diagnosis.logdata import prepare_log, sample_rows
from sim2real.diagnosis.padfit import fit_k, k_bounds
from sim2real.diagnosis.replay import ReplayModel
from sim2real.effects.library import HeatPartition, PowerLawWear, SpeedFriction
from sim2real.effects.truth import TruthSpec, simulate_truth
from tests.sim2real.conftest import SMALL, short_runs


def test_likelihood_fit_recovers_each_pads_k_on_a_no_effect_log(s2r_atlas: Atlas) -> None:
    log = simulate_truth(SMALL, [], TruthSpec(short_runs(4)), seed=21)["train"]
    d = prepare_log(log, s2r_atlas)
    rm = ReplayModel(s2r_atlas, d)
    k = fit_k(rm, sample_rows(d, 1500, np.random.default_rng(0)))
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


def test_wear_clock_runs_from_a_fresh_pad_to_each_models_end_of_life(s2r_atlas: Atlas) -> None:
    log = simulate_truth(SMALL, [], TruthSpec(short_runs(2)), seed=6)["train"]
    d = prepare_log(log, s2r_atlas)
    nominal = ReplayModel(s2r_atlas, d)
    clock = nominal.clock
    assert clock.volume_at_work(0.0) == 1.0
    assert clock.volume_at_work(clock.life_work) == nominal.v_end == s2r_atlas.failure_volume
    # The log's conditions are uniform over the envelope: its clock is the atlas's uniform one.
    np.testing.assert_allclose(
        clock.life_work, WearModel.from_atlas(s2r_atlas).life_work, rtol=0.02
    )
    # The K bound keeps a run's last event above the end of life.
    _, k_hi = k_bounds(nominal, 0)
    assert nominal.volume_at(np.array([d.starts[1] - 1]), np.array(k_hi))[0] > nominal.v_end
    # Heat lost to the disc: a cooler brake stops the severe event on a thinner pad, so the
    # clock goes on below the atlas's last layer.
    cool = ReplayModel(s2r_atlas, d, HeatPartition(phi=0.3))
    assert cool.v_end < s2r_atlas.failure_volume and cool.clock.n_layers > s2r_atlas.n_layers
    assert cool.clock.lower_edges[-1] == cool.v_end
    # Friction falling with speed: the pad fails earlier, inside an atlas layer.
    slip = ReplayModel(s2r_atlas, d, SpeedFriction(a=0.3))
    assert slip.v_end > s2r_atlas.failure_volume and slip.clock.lower_edges[-1] == slip.v_end
    assert slip.clock.n_layers < s2r_atlas.n_layers and slip.clock.life_work < clock.life_work
