"""Effects: the interface, the library's ranges, and neutral values giving the nominal model."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from brake_env.data.datasets import make_dataset
from brake_env.model.atlas import Atlas, AtlasSpec
from sim2real.effects.interface import Effect, SensorContext
from sim2real.effects.library import (
    LIBRARY,
    NewtonCooling,
    ThermocoupleBias,
    ThermocoupleLag,
    parse_effect,
)
from sim2real.effects.truth import TruthSpec, simulate_truth
from tests.sim2real.conftest import SMALL, short_runs


def _neutral(cls: type[Effect]) -> Effect:
    return cls(**{p.name: p.neutral for p in cls.params})


@pytest.mark.parametrize("cls", [c for c in LIBRARY if c.kind == "in-event"], ids=lambda c: c.name)
def test_in_event_effect_at_neutral_builds_the_nominal_atlas_bit_for_bit(cls: type[Effect]) -> None:
    spec = AtlasSpec(n_speed=4, n_mass=2, n_slope=3)
    nominal = Atlas.build(spec)
    changed = Atlas.build(dataclasses.replace(spec, effects=(_neutral(cls).key,)))
    assert changed.critical_volume == nominal.critical_volume
    for name, field in nominal.fields.items():
        assert np.array_equal(changed.fields[name], field), name


@pytest.mark.parametrize("cls", [c for c in LIBRARY if c.kind == "in-event"], ids=lambda c: c.name)
def test_in_event_effect_at_mid_changes_the_physics(cls: type[Effect]) -> None:
    spec = AtlasSpec(n_speed=4, n_mass=2, n_slope=3)
    nominal = Atlas.build(spec)
    mid = cls(**{p.name: p.mid for p in cls.params})
    changed = Atlas.build(dataclasses.replace(spec, effects=(mid.key,)))
    field = "wear_per_k_m3" if "wear" in cls.name else "temp_mean_c"
    n = min(changed.n_layers, nominal.n_layers)
    assert not np.allclose(changed.fields[field][:n], nominal.fields[field][:n])


@pytest.mark.parametrize("cls", LIBRARY, ids=lambda c: c.name)
def test_truth_simulator_at_neutral_reproduces_the_nominal_simulator(
    cls: type[Effect], s2r_atlas: Atlas
) -> None:
    ds = short_runs(2)
    nominal = make_dataset(s2r_atlas, ds, seed=3).logs["train"]
    truth = simulate_truth(SMALL, [_neutral(cls)], TruthSpec(ds), seed=3)["train"]
    assert truth.drop(columns="time_s").equals(nominal)


def test_carry_over_recurrence_with_no_cooling_delay_is_the_nominal_simulator(
    s2r_atlas: Atlas,
) -> None:
    """Force the per-event carry-over path (not the shortcut taken for neutral effects)."""

    class Forced(NewtonCooling):
        @property
        def is_neutral(self) -> bool:
            return False

    for ds in (short_runs(2), dataclasses.replace(short_runs(2), route_block_events=250)):
        nominal = make_dataset(s2r_atlas, ds, seed=4).logs["train"]
        truth = simulate_truth(SMALL, [Forced(tau_s=0.0)], TruthSpec(ds), seed=4)["train"]
        assert truth.drop(columns="time_s").equals(nominal), ds.route_block_events


def test_carry_over_heats_events_that_follow_closely(s2r_atlas: Atlas) -> None:
    ds = short_runs(2)
    base = simulate_truth(SMALL, [], TruthSpec(ds), seed=5)["train"]
    hot = simulate_truth(SMALL, [NewtonCooling(tau_s=20.0)], TruthSpec(ds), seed=5)["train"]
    assert hot["temp_c"].mean() > base["temp_c"].mean() + 5.0
    # Hotter brakes fail sooner: shorter lives.
    assert len(hot) < len(base)


def test_sensor_effects_analytic() -> None:
    t = np.array([500.0, 520.0])
    ctx = SensorContext(np.array([450.0, 450.0]), np.array([540.0, 600.0]), np.array([1.0, 2.0]))
    assert np.array_equal(ThermocoupleBias(bias_k=7.0).measure_temp(t, ctx), t + 7.0)
    lagged = ThermocoupleLag(tau_s=0.3).measure_temp(t, ctx)
    # Ramp r over D: deficit r (tau - tau^2/D (1 - exp(-D/tau))).
    r = (ctx.temp_peak_c - ctx.temp_start_c) / ctx.stop_time_s
    expect = t - r * (0.3 - 0.09 / ctx.stop_time_s * (1 - np.exp(-ctx.stop_time_s / 0.3)))
    np.testing.assert_allclose(lagged, expect, rtol=1e-12)
    assert np.array_equal(ThermocoupleLag(tau_s=0.0).measure_temp(t, ctx), t)


def test_parse_effect_and_range_errors() -> None:
    e = parse_effect("speed_friction:a=0.1")
    assert e.key == "speed_friction:a=0.1" and e["a"] == 0.1
    assert parse_effect("tc_bias")["bias_k"] == ThermocoupleBias.params[0].mid
    with pytest.raises(ValueError, match="unknown effect 'nope'"):
        parse_effect("nope:x=1")
    with pytest.raises(ValueError, match="unknown parameter"):
        parse_effect("tc_bias:b=1")
    with pytest.raises(ValueError, match="outside its range"):
        parse_effect("heat_partition:phi=0.9")
    with pytest.raises(ValueError, match="not a number"):
        parse_effect("tc_bias:bias_k=warm")


def test_every_library_parameter_has_neutral_and_mid_in_range() -> None:
    for cls in LIBRARY:
        assert cls.params, cls.name
        for p in cls.params:
            assert p.lo <= p.neutral <= p.hi and p.lo <= p.mid <= p.hi
        assert cls.fitted_params(), cls.name
