"""Unmodelled effects: the plug-in interface (docs/results/sim2real.md, paper 5).

An :class:`Effect` changes what the nominal model (atlas and twin) assumes in one of three
places, named by its ``kind``:

- ``in-event``: the physics of a braking event. Hooks return multipliers on the friction
  coefficient, on the share of friction heat that enters the brake's thermal mass, and on the
  Archard wear rate, as functions of brake temperature [deg C], sliding speed [m/s], line
  pressure [Pa] and pad volume fraction [-] (:class:`EventState`).
- ``between-events``: the thermal history. ``start_temp`` gives the brake temperature at the
  onset of an event from the previous event's peak temperature and the time since it.
- ``sensor``: the measurement. ``measure_temp`` maps the true mean event temperature to what
  the thermocouple logs, given the event's start and peak temperature and duration.

Every parameter is declared with its unit, physically sensible range and *neutral* value, at
which the effect is the nominal model exactly (every hook returns 1.0 or the identity).
The candidates the diagnosis tries are in :mod:`sim2real.effects.library`.

Writing your own effect::

    class Glazing(Effect):
        name = "glazing"
        kind = "in-event"
        params = (Param("g", "-", neutral=0.0, lo=0.0, hi=0.3, mid=0.15, doc="friction loss"),)

        def friction_factor(self, s: EventState) -> ArrayLike:
            return 1.0 - self["g"] * (1.0 - s.volume_frac)

and pass ``Glazing(g=0.1)`` to :func:`sim2real.effects.truth.simulate_truth` or as a diagnosis
candidate. ``sim2real.effects.library.register(Glazing)`` makes it reachable by name
(``--effect glazing:g=0.1``).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from brake_env.model.params import BrakeModel

F64 = NDArray[np.float64]
KINDS = ("in-event", "between-events", "sensor")


@dataclass(frozen=True)
class Param:
    """One parameter of an effect.

    Attributes:
        name: Identifier (``--effect NAME:name=value``).
        unit: Physical unit, for documentation.
        neutral: Value at which the effect is the nominal model exactly.
        lo, hi: Physically sensible range; values outside are rejected.
        mid: A typical magnitude inside the range (validation uses it).
        doc: One line for the docs.
        fit: Whether the diagnosis fits it (False for parameters the logs cannot identify).
    """

    name: str
    unit: str
    neutral: float
    lo: float
    hi: float
    mid: float
    doc: str = ""
    fit: bool = True

    def __post_init__(self) -> None:
        if not (self.lo <= self.neutral <= self.hi and self.lo <= self.mid <= self.hi):
            raise ValueError(
                f"Param {self.name}: need lo <= neutral, mid <= hi, got lo={self.lo},"
                f" neutral={self.neutral}, mid={self.mid}, hi={self.hi}"
            )


@dataclass(frozen=True, eq=False)
class EventState:
    """State of a batch of events at one integration stage (arrays broadcast together).

    Attributes:
        temp_c: Brake temperature [deg C].
        slide_speed_mps: Sliding speed at the effective friction radius [m/s].
        pressure_pa: Brake line pressure [Pa].
        volume_frac: Remaining pad volume fraction [-].
        model: The nominal physical parameters (material laws, reference values).
    """

    temp_c: F64
    slide_speed_mps: F64
    pressure_pa: float
    volume_frac: F64
    model: BrakeModel


@dataclass(frozen=True, eq=False)
class SensorContext:
    """True quantities of each event that a sensor effect may need (arrays, one per event).

    Attributes:
        temp_start_c: Brake temperature at brake onset [deg C].
        temp_peak_c: Brake temperature at standstill [deg C].
        stop_time_s: Duration of the stop [s].
    """

    temp_start_c: F64
    temp_peak_c: F64
    stop_time_s: F64


class Effect:
    """Base class of an unmodelled effect; subclasses set the class attributes and hooks.

    Attributes:
        name: Short name (registry key, ``--effect NAME``).
        kind: ``in-event``, ``between-events`` or ``sensor``.
        params: Declared parameters; constructor keywords give their values (others neutral).
        summary: One line for reports.
    """

    name: ClassVar[str] = "effect"
    kind: ClassVar[str] = "in-event"
    params: ClassVar[tuple[Param, ...]] = ()
    summary: ClassVar[str] = ""

    def __init__(self, **values: float) -> None:
        declared = {p.name: p for p in self.params}
        unknown = sorted(set(values) - set(declared))
        if unknown:
            raise ValueError(
                f"effect {self.name!r}: unknown parameter(s) {unknown};"
                f" valid are {sorted(declared)}"
            )
        if self.kind not in KINDS:
            raise ValueError(
                f"effect {self.name!r}: kind must be one of {KINDS}, got {self.kind!r}"
            )
        self.values: dict[str, float] = {}
        for p in self.params:
            v = float(values.get(p.name, p.neutral))
            if not (math.isfinite(v) and p.lo <= v <= p.hi):
                raise ValueError(
                    f"effect {self.name!r}: {p.name}={v:g} {p.unit} outside its range"
                    f" [{p.lo:g}, {p.hi:g}]"
                )
            self.values[p.name] = v

    def __getitem__(self, key: str) -> float:
        return self.values[key]

    def __repr__(self) -> str:
        return self.key

    @property
    def key(self) -> str:
        """Canonical text form ``name:p=v,...`` (also the cache key)."""
        vals = ",".join(f"{k}={v:.6g}" for k, v in self.values.items())
        return f"{self.name}:{vals}" if vals else self.name

    @property
    def is_neutral(self) -> bool:
        return all(self.values[p.name] == p.neutral for p in self.params)

    def with_values(self, **values: float) -> Effect:
        """A copy with some parameters changed."""
        return type(self)(**{**self.values, **values})

    @classmethod
    def fitted_params(cls) -> tuple[Param, ...]:
        return tuple(p for p in cls.params if p.fit)

    # ---- in-event hooks (multipliers; 1.0 = nominal)
    def friction_factor(self, s: EventState) -> ArrayLike:
        """Multiplier on mu(T)."""
        return 1.0

    def heat_fraction(self, s: EventState) -> ArrayLike:
        """Share of the friction heat entering the brake's lumped thermal mass."""
        return 1.0

    def wear_factor(self, s: EventState) -> ArrayLike:
        """Multiplier on the Archard wear rate."""
        return 1.0

    # ---- between-event hook
    def start_temp(self, prev_peak_c: F64, gap_s: F64, base_c: float) -> F64:
        """Brake temperature at onset, from the previous event's peak and the time since it.

        ``base_c`` is the nominal model's start temperature (the duty-cycle level).
        """
        return np.full(np.shape(prev_peak_c), base_c)

    # ---- sensor hook
    def measure_temp(self, temp_c: F64, ctx: SensorContext) -> F64:
        """What the thermocouple logs for true mean event temperature ``temp_c``."""
        return temp_c


class InEventPhysics:
    """The in-event effects of a list, combined as one ``brake_env.model.physics.EventModifier``."""

    def __init__(self, effects: Iterable[Effect], model: BrakeModel) -> None:
        self.effects = [e for e in effects if e.kind == "in-event"]
        self.model = model

    def _state(self, temp: F64, v: F64, p: float, vol: F64) -> EventState:
        return EventState(temp, v, p, vol, self.model)

    def _product(self, hook: str, temp: F64, v: F64, p: float, vol: F64) -> F64 | float:
        out: F64 | float = 1.0
        s = self._state(temp, v, p, vol)
        for e in self.effects:
            out = out * np.asarray(getattr(e, hook)(s), dtype=np.float64)
        return out

    def friction_factor(
        self, temp_c: F64, slide_speed_mps: F64, pressure_pa: float, volume_frac: F64
    ) -> F64 | float:
        return self._product("friction_factor", temp_c, slide_speed_mps, pressure_pa, volume_frac)

    def heat_fraction(
        self, temp_c: F64, slide_speed_mps: F64, pressure_pa: float, volume_frac: F64
    ) -> F64 | float:
        return self._product("heat_fraction", temp_c, slide_speed_mps, pressure_pa, volume_frac)

    def wear_factor(
        self, temp_c: F64, slide_speed_mps: F64, pressure_pa: float, volume_frac: F64
    ) -> F64 | float:
        return self._product("wear_factor", temp_c, slide_speed_mps, pressure_pa, volume_frac)


def effects_key(effects: Sequence[Effect]) -> str:
    """Canonical text of a list of effects (order kept)."""
    return "+".join(e.key for e in effects) or "nominal"


def split_kinds(effects: Sequence[Effect]) -> dict[str, list[Effect]]:
    """The effects grouped by kind; raises on two between-event effects (ambiguous history)."""
    out: dict[str, list[Effect]] = {k: [] for k in KINDS}
    for e in effects:
        if not isinstance(e, Effect):
            raise TypeError(f"expected an Effect, got {e!r}")
        out[e.kind].append(e)
    if len(out["between-events"]) > 1:
        raise ValueError("at most one between-events effect at a time (they set one start temp)")
    return out


def apply_sensor(effects: Sequence[Effect], temp_c: F64, ctx: SensorContext) -> F64:
    """Apply the sensor effects of a list to true mean temperatures, in list order."""
    out = np.asarray(temp_c, dtype=np.float64)
    for e in effects:
        if e.kind == "sensor":
            out = np.asarray(e.measure_temp(out, ctx), dtype=np.float64)
    return out
