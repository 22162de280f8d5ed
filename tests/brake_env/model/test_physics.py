import dataclasses
import math

import numpy as np
import pytest

from brake_env.model.materials import FrictionParams, HardnessParams
from brake_env.model.params import GRAVITY, BrakeModel, BrakeParams, OperatingRange, VehicleParams
from brake_env.model.physics import (
    brake_force_per_mu,
    critical_volume,
    simulate_events,
    thermal_mass,
)
from brake_env.model.simulator import simulate_runs
from brake_env.model.wear import WearModel

MODEL = BrakeModel()


def grid(n: int = 7):
    s = np.linspace(4, 15, n) / 3.6
    m = np.linspace(42e3, 54e3, n)
    th = np.radians(np.linspace(0, 10, n))
    return np.meshgrid(s, m, th, indexing="ij")


def test_energy_balance_of_every_event() -> None:
    # Friction work of all brakes = kinetic energy + potential energy released - rolling loss.
    s, m, th = grid()
    for vol in (1.0, 0.6, 0.3):
        r = simulate_events(s, m, th, vol, MODEL)
        assert r.stopped.all()
        d = r.stop_dist_m
        crr = MODEL.vehicle.rolling_resistance
        supplied = 0.5 * m * s**2 + m * GRAVITY * (np.sin(th) - crr * np.cos(th)) * d
        work = MODEL.vehicle.n_braked_wheels * r.friction_work_j
        np.testing.assert_allclose(work, supplied, rtol=1e-6)
        # The heat raises the brake by work / C_th, since nothing cools within an event.
        np.testing.assert_allclose(
            r.temp_peak_c - MODEL.brake.start_temp_c,
            r.friction_work_j / thermal_mass(vol, MODEL),
            rtol=1e-9,
        )


def test_constant_friction_and_hardness_match_closed_form() -> None:
    # mu and H (almost) constant: uniform deceleration, analytic distance, time, heat and wear.
    model = dataclasses.replace(
        MODEL,
        friction=FrictionParams(mu0=0.4, mu1=1.0, mu2=1e-12, mu3=1e-3, mu4=250.0),
        hardness=HardnessParams(h1=1.0, h2=1e-12, h5=1e-12),
    )
    v0, m, th, vol = 3.0, 50e3, math.radians(6.0), 0.5
    r = simulate_events(v0, m, th, vol, model)
    a = 0.4 * brake_force_per_mu(model) / m + GRAVITY * (0.02 * math.cos(th) - math.sin(th))
    d, t = v0**2 / (2 * a), v0 / a
    heat_rate = 0.4 * brake_force_per_mu(model) / 4 / float(thermal_mass(vol, model))
    assert r.stop_dist_m == pytest.approx(d, rel=1e-9)
    assert r.stop_time_s == pytest.approx(t, rel=1e-9)
    assert r.temp_peak_c == pytest.approx(model.brake.start_temp_c + heat_rate * d, rel=1e-9)
    # T(t) = T0 + heat_rate * (v0 t - a t^2 / 2): its time average is T0 + heat_rate v0^2 / (3a).
    assert r.temp_mean_c == pytest.approx(
        model.brake.start_temp_c + heat_rate * v0**2 / (3 * a), rel=1e-9
    )
    b = model.brake
    slide = b.effective_radius_m / model.vehicle.wheel_radius_m
    assert r.wear_per_k_m3 == pytest.approx(b.normal_force_n * slide * d / 137e6, rel=1e-9)


def test_batch_equals_event_by_event() -> None:
    s, m, th = (x.ravel() for x in grid(4))
    vol = np.linspace(1.0, 0.3, s.size)
    batch = simulate_events(s, m, th, vol, MODEL)
    for i in range(0, s.size, 7):
        one = simulate_events(s[i], m[i], th[i], vol[i], MODEL)
        assert one.temp_mean_c == batch.temp_mean_c[i]
        assert one.wear_per_k_m3 == batch.wear_per_k_m3[i]


@pytest.mark.parametrize("vol", [1.0, 0.25, "last"])
def test_rk4_is_converged_at_default_steps(vol) -> None:
    # Including the last layer before failure, where the severe corner runs past 1000 C and
    # the hardness meets its floor: the hardest case for a fixed-step integrator.
    v = 1.0 - 0.01 * math.floor((1.0 - critical_volume(MODEL)) / 0.01) if vol == "last" else vol
    s, m, th = grid(5)
    coarse = simulate_events(s, m, th, v, MODEL)
    fine = simulate_events(s, m, th, v, dataclasses.replace(MODEL, n_steps=4000))
    assert np.nanmax(fine.temp_peak_c) > (1000 if vol == "last" else 0)
    for f in ("temp_mean_c", "stop_dist_m", "wear_per_k_m3"):
        np.testing.assert_allclose(getattr(coarse, f), getattr(fine, f), rtol=1e-4)


def test_mean_temperature_rises_strictly_as_pad_wears_everywhere(atlas) -> None:
    # Every grid condition, every layer: a thinner pad has less thermal mass.
    assert np.all(np.diff(atlas.fields["temp_mean_c"], axis=0) > 0)
    assert np.all(np.diff(atlas.fields["temp_peak_c"], axis=0) > 0)


def test_failure_emerges_in_band_and_bisection_brackets_it() -> None:
    vc = critical_volume(MODEL)
    assert 0.15 <= vc <= 0.25
    v, m, th = MODEL.envelope.severe_event
    above = simulate_events(v, m, th, vc + 1e-4, MODEL)
    below = simulate_events(v, m, th, vc - 1e-4, MODEL)
    assert above.stopped and not below.stopped
    assert np.isnan(below.stop_dist_m) and np.isnan(below.wear_per_k_m3)
    # Milder events still stop below the critical volume: only the severe one defines it.
    assert simulate_events(v * 0.6, m, th, vc - 1e-4, MODEL).stopped


def test_a_stronger_brake_fails_later() -> None:
    stronger = dataclasses.replace(
        MODEL, brake=dataclasses.replace(MODEL.brake, line_pressure_pa=14.0e6)
    )
    assert critical_volume(stronger) < critical_volume(MODEL)


def test_wear_accelerates_towards_end_of_life_monte_carlo() -> None:
    # The calibration target, checked on the physics itself (no atlas interpolation).
    rng = np.random.default_rng(0)
    n = 60_000
    s, m = rng.uniform(4, 15, n) / 3.6, rng.uniform(42e3, 54e3, n)
    th = np.radians(rng.uniform(0, 10, n))
    vc = critical_volume(MODEL)
    last = 1.0 - 0.01 * math.floor((1.0 - vc) / 0.01)
    w_end = simulate_events(s, m, th, last, MODEL).wear_per_k_m3
    w_fresh = simulate_events(s, m, th, 1.0, MODEL).wear_per_k_m3
    ratio = w_end.mean() / w_fresh.mean()
    assert ratio >= 1.2, ratio


def test_cold_start_preset_shows_why_the_default_is_hot(atlas) -> None:
    # docs/model.md: with cold starts mu*H rises with temperature, so wear per event falls.
    from brake_env.model.atlas import Atlas, AtlasSpec

    cold = Atlas.build(
        AtlasSpec(model=BrakeModel.preset("cold-start"), n_speed=6, n_mass=3, n_slope=5)
    )
    w = cold.expected("wear_per_k_m3")
    assert w[-1] / w[0] < 0.95
    # Cold brakes always stop: the pad ends at the wear-out limit, never below it.
    assert cold.critical_volume == 0.0 and cold.failure_mode == "worn-out"
    assert cold.failure_volume == BrakeModel().brake.min_volume_frac
    (run,) = simulate_runs(cold, [4e-5], np.random.SeedSequence(0).spawn(1))
    assert cold.failure_volume - 0.001 < run.final_volume_frac < cold.failure_volume
    hot = atlas.expected("wear_per_k_m3")
    assert hot[-1] / hot[0] >= 1.2


def test_nominal_life_in_target_band(atlas) -> None:
    assert 3e4 <= float(WearModel.from_atlas(atlas).life(2e-6)) <= 2e5


def test_parameter_validation_names_the_field() -> None:
    with pytest.raises(ValueError, match="line_pressure_pa"):
        BrakeParams(line_pressure_pa=-1.0)
    with pytest.raises(ValueError, match="n_braked_wheels"):
        VehicleParams(n_braked_wheels=0)
    with pytest.raises(ValueError, match="slope_deg"):
        OperatingRange(slope_deg=(5.0, 2.0))
    with pytest.raises(ValueError, match="unknown parameter"):
        BrakeModel.from_dict({"brake": {"pressure": 1.0}})
    with pytest.raises(ValueError, match="preset"):
        BrakeModel.preset("lukewarm")
    with pytest.raises(ValueError, match="volume_frac"):
        simulate_events(3.0, 5e4, 0.1, 1.5)
    with pytest.raises(ValueError, match="finite"):
        simulate_events(np.nan, 5e4, 0.1, 0.5)


def test_model_dict_round_trip() -> None:
    model = BrakeModel.preset("cold-start")
    assert BrakeModel.from_dict(model.to_dict()) == model


def test_batched_critical_volume_agrees_with_bisection() -> None:
    exact = critical_volume(MODEL)
    for batch, tol in ((48, 1e-5), (5, 1e-6)):
        v = critical_volume(MODEL, tol=tol, batch=batch)
        assert abs(v - exact) <= tol
    with pytest.raises(ValueError, match="batch must be 1 or >= 3"):
        critical_volume(MODEL, batch=2)  # the bracket itself: it would never shrink
