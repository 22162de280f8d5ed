"""The library of candidate effects and the registry of effects by name (docs/results/sim2real.md).

Candidates drawn from the paper's own future work (section 5) and brake tribology:
speed- and pressure-dependent friction, power-law and energy-based wear, heat partition to
the disc, Newton cooling between events, thermocouple bias and lag. Each is an
:class:`~sim2real.effects.interface.Effect`; :func:`register` adds a user's own by name.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from brake_env.model.materials import friction, hardness_mpa
from sim2real.effects.interface import F64, KINDS, Effect, EventState, Param, SensorContext

_V_REF = 0.5  # reference sliding speed [m/s], mid-range of the envelope's stops
_P_REF = 10e6  # reference line pressure [Pa]
_T_REF = 500.0  # reference temperature of the energy-wear blend [deg C]


class SpeedFriction(Effect):
    """mu(T, v) = mu(T) (1 - a (v_s - v_ref)): friction falls with sliding speed."""

    name = "speed_friction"
    kind = "in-event"
    summary = "friction falls linearly with sliding speed"
    params = (Param("a", "s/m", 0.0, 0.0, 0.4, 0.2, "friction loss per m/s of sliding speed"),)

    def friction_factor(self, s: EventState) -> ArrayLike:
        return 1.0 - self["a"] * (s.slide_speed_mps - _V_REF)


class PressureFriction(Effect):
    """mu(T, p) = mu(T) (p / p_ref)^-n: friction falls with contact pressure."""

    name = "pressure_friction"
    kind = "in-event"
    summary = "friction falls as a power of line pressure"
    params = (Param("n", "-", 0.0, 0.0, 0.3, 0.15, "pressure exponent of friction"),)

    def friction_factor(self, s: EventState) -> ArrayLike:
        return (s.pressure_pa / _P_REF) ** (-self["n"])


class PowerLawWear(Effect):
    """dV/dt = K F v / H (v_s / v_ref)^(b-1) (p / p_ref)^(a-1): power-law wear in speed, pressure.

    With one line pressure for every event the pressure exponent only scales K, which the
    logs cannot tell from the pad's own coefficient, so the diagnosis does not fit it.
    """

    name = "powerlaw_wear"
    kind = "in-event"
    summary = "wear rate a power law in sliding speed and pressure"
    params = (
        Param("b", "-", 1.0, 0.5, 2.5, 1.8, "sliding-speed exponent of wear"),
        Param("a", "-", 1.0, 0.5, 2.0, 1.0, "pressure exponent of wear", fit=False),
    )

    def wear_factor(self, s: EventState) -> ArrayLike:
        v = np.maximum(s.slide_speed_mps, 1e-3) / _V_REF  # v -> 0 at standstill
        return v ** (self["b"] - 1.0) * (s.pressure_pa / _P_REF) ** (self["a"] - 1.0)


class EnergyWear(Effect):
    """Blend of Archard (wear ~ F v / H(T)) and energy-based wear (wear ~ mu F v).

    w = 0 is Archard with hot hardness, w = 1 wear proportional to the friction work; the
    two agree at the reference temperature.
    """

    name = "energy_wear"
    kind = "in-event"
    summary = "wear proportional to friction work instead of Archard with hot hardness"
    params = (Param("w", "-", 0.0, 0.0, 1.0, 0.6, "weight of the energy-based law"),)

    def wear_factor(self, s: EventState) -> ArrayLike:
        w = self["w"]
        if w == 0.0:
            return 1.0
        m = s.model
        ref = float(friction(_T_REF, m.friction) * hardness_mpa(_T_REF, m.hardness))
        mu_h = friction(s.temp_c, m.friction) * hardness_mpa(s.temp_c, m.hardness)
        return (1.0 - w) + w * mu_h / ref


class HeatPartition(Effect):
    """A share phi of the friction heat flows into the disc, outside the lumped thermal mass."""

    name = "heat_partition"
    kind = "in-event"
    summary = "part of the friction heat goes to the disc"
    params = (Param("phi", "-", 0.0, 0.0, 0.4, 0.2, "share of heat into the disc"),)

    def heat_fraction(self, s: EventState) -> ArrayLike:
        return 1.0 - self["phi"]


class NewtonCooling(Effect):
    """Thermal carry-over: the brake cools between events towards the duty-cycle level.

    T_start = T_base + (T_peak,prev - T_base) exp(-gap / tau); tau = 0 is the nominal model
    (every event starts at the duty-cycle level). Needs event times (``time_s``).
    """

    name = "newton_cooling"
    kind = "between-events"
    summary = "heat carried over between events (Newton cooling)"
    params = (Param("tau_s", "s", 0.0, 0.0, 120.0, 20.0, "cooling time constant"),)

    def start_temp(self, prev_peak_c: F64, gap_s: F64, base_c: float) -> F64:
        tau = self["tau_s"]
        if tau == 0.0:
            return np.full(np.shape(prev_peak_c), base_c)
        return base_c + (prev_peak_c - base_c) * np.exp(-np.asarray(gap_s) / tau)


class ThermocoupleBias(Effect):
    """The thermocouple reads a constant offset."""

    name = "tc_bias"
    kind = "sensor"
    summary = "constant thermocouple offset"
    params = (Param("bias_k", "K", 0.0, -30.0, 30.0, 10.0, "offset of the reading"),)

    def measure_temp(self, temp_c: F64, ctx: SensorContext) -> F64:
        return temp_c + self["bias_k"]


class ThermocoupleLag(Effect):
    """First-order thermocouple lag: the logged event mean trails the true one.

    For a temperature ramp from T_start to T_peak over the stop time D, a sensor with time
    constant tau averages to the true mean minus r (tau - tau^2 / D (1 - exp(-D / tau))),
    r = (T_peak - T_start) / D.
    """

    name = "tc_lag"
    kind = "sensor"
    summary = "first-order thermocouple lag"
    params = (Param("tau_s", "s", 0.0, 0.0, 2.0, 0.5, "sensor time constant"),)

    def measure_temp(self, temp_c: F64, ctx: SensorContext) -> F64:
        tau = self["tau_s"]
        if tau == 0.0:
            return temp_c
        d = np.maximum(ctx.stop_time_s, 1e-6)
        rate = (ctx.temp_peak_c - ctx.temp_start_c) / d
        deficit = rate * (tau - tau**2 / d * (-np.expm1(-d / tau)))
        return temp_c - deficit


LIBRARY: tuple[type[Effect], ...] = (
    SpeedFriction,
    PressureFriction,
    PowerLawWear,
    EnergyWear,
    HeatPartition,
    NewtonCooling,
    ThermocoupleBias,
    ThermocoupleLag,
)
_REGISTRY: dict[str, type[Effect]] = {e.name: e for e in LIBRARY}


def register(cls: type[Effect]) -> type[Effect]:
    """Make a user-defined effect reachable by name (usable as a class decorator)."""
    if not (isinstance(cls, type) and issubclass(cls, Effect)):
        raise TypeError(f"register() takes an Effect subclass, got {cls!r}")
    if cls.kind not in KINDS:
        raise ValueError(f"effect {cls.name!r}: kind must be one of {KINDS}, got {cls.kind!r}")
    _REGISTRY[cls.name] = cls
    return cls


def registry() -> dict[str, type[Effect]]:
    """Name -> effect class, the library plus registered user effects."""
    return dict(_REGISTRY)


def parse_effect(text: str) -> Effect:
    """``NAME[:PARAM=VALUE,...]`` -> an effect (parameters not given are at their mid value).

    A bare name gives the effect at its typical (``mid``) magnitude; give ``PARAM=neutral``
    explicitly for the nominal model.
    """
    name, _, rest = text.strip().partition(":")
    cls = _REGISTRY.get(name.strip())
    if cls is None:
        raise ValueError(f"unknown effect {name!r}; valid are {sorted(_REGISTRY)}")
    values: dict[str, float] = {p.name: p.mid for p in cls.params}
    for item in filter(None, (x.strip() for x in rest.split(","))):
        k, eq, v = item.partition("=")
        if not eq:
            raise ValueError(f"effect {name!r}: expected PARAM=VALUE, got {item!r}")
        try:
            values[k.strip()] = float(v)
        except ValueError:
            raise ValueError(f"effect {name!r}: {k.strip()}={v!r} is not a number") from None
    return cls(**values)


def describe_library() -> list[dict[str, Any]]:
    """The library as plain data (for reports and ``diagnosis.json``)."""
    return [
        {
            "name": cls.name,
            "kind": cls.kind,
            "summary": cls.summary,
            "params": [
                {
                    "name": p.name,
                    "unit": p.unit,
                    "neutral": p.neutral,
                    "range": [p.lo, p.hi],
                    "mid": p.mid,
                    "fit": p.fit,
                    "doc": p.doc,
                }
                for p in cls.params
            ],
        }
        for cls in _REGISTRY.values()
    ]
