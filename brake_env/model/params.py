"""Frozen, validated parameters of the vehicle, the brake and the operating envelope (SI units).

Defaults are the documented calibration (docs/calibration.md): a 42-54 t load-haul-dumper on a
0-10 deg ramp in a hot duty cycle. See ``BrakeModel.preset`` for named alternatives.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

from brake_env._validate import (
    check_nonnegative,
    check_positive,
    check_range,
    from_dict,
    plain_numbers,
)
from brake_env.model.materials import FrictionParams, HardnessParams

GRAVITY = 9.81  # m/s^2


@dataclass(frozen=True)
class VehicleParams:
    """Longitudinal vehicle model on a downhill slope.

    Attributes:
        n_braked_wheels: Number of wheels with an identical brake [-].
        wheel_radius_m: Rolling radius of a tyre [m].
        rolling_resistance: Rolling-resistance coefficient C_rr [-]; it helps the brake stop.
    """

    n_braked_wheels: int = 4
    wheel_radius_m: float = 0.80
    rolling_resistance: float = 0.02

    def __post_init__(self) -> None:
        plain_numbers(self)
        if not isinstance(self.n_braked_wheels, int) or self.n_braked_wheels < 1:
            raise ValueError(
                "VehicleParams.n_braked_wheels must be a positive int,"
                f" got {self.n_braked_wheels!r}"
            )
        check_positive(self, "wheel_radius_m")
        check_range(self, "rolling_resistance", 0.0, 0.5)


@dataclass(frozen=True)
class BrakeParams:
    """One dry disc brake (identical on every braked wheel) and its duty cycle.

    Attributes:
        n_pads: Pads per brake, N_p [-].
        bore_diameter_m: Actuator (piston) bore diameter D_b [m].
        effective_radius_m: Effective friction radius r_m [m].
        line_pressure_pa: Brake line pressure p during an event [Pa], fixed per event.
        pad_volume_m3: Friction material of a fresh brake, all its pads [m^3].
        pad_heat_capacity_j_per_k: Heat capacity m*c_p of the fresh friction material [J/K];
            it shrinks in proportion to the remaining pad volume.
        backing_heat_capacity_j_per_k: Non-wearing thermal mass in contact with the
            friction material (steel backing plates) [J/K].
        start_temp_c: Brake temperature at the start of an event, the steady level of the
            hot downhill duty cycle [deg C].
        min_volume_frac: Wear-out limit: the pad is spent at this fraction of its friction
            material even if it can still stop the most severe event [-].
    """

    n_pads: int = 2
    bore_diameter_m: float = 0.146
    effective_radius_m: float = 0.20
    line_pressure_pa: float = 13.5e6
    pad_volume_m3: float = 200e-6
    pad_heat_capacity_j_per_k: float = 720.0
    backing_heat_capacity_j_per_k: float = 350.0
    start_temp_c: float = 450.0
    min_volume_frac: float = 0.05

    def __post_init__(self) -> None:
        plain_numbers(self)
        if not isinstance(self.n_pads, int) or self.n_pads < 1:
            raise ValueError(f"BrakeParams.n_pads must be a positive int, got {self.n_pads!r}")
        check_positive(
            self,
            "bore_diameter_m",
            "effective_radius_m",
            "line_pressure_pa",
            "pad_volume_m3",
            "pad_heat_capacity_j_per_k",
        )
        check_nonnegative(self, "backing_heat_capacity_j_per_k")
        check_range(self, "start_temp_c", -50.0, 900.0)
        check_range(self, "min_volume_frac", 0.001, 0.9)

    @property
    def bore_area_m2(self) -> float:
        return math.pi * self.bore_diameter_m**2 / 4.0

    @property
    def normal_force_n(self) -> float:
        """Total clamp force on the pads of one brake, N_p * p * A [N]."""
        return self.n_pads * self.line_pressure_pa * self.bore_area_m2


@dataclass(frozen=True)
class OperatingRange:
    """Envelope of braking events; the atlas grid spans it and the simulator samples it.

    Attributes:
        speed_kmh: (min, max) speed at brake onset [km/h].
        mass_kg: (min, max) vehicle mass, empty to full bucket [kg].
        slope_deg: (min, max) downhill slope [deg].
    """

    speed_kmh: tuple[float, float] = (4.0, 15.0)
    mass_kg: tuple[float, float] = (42_000.0, 54_000.0)
    slope_deg: tuple[float, float] = (0.0, 10.0)

    def __post_init__(self) -> None:
        plain_numbers(self)
        for name, lo_limit, hi_limit in (
            ("speed_kmh", 0.1, 100.0),
            ("mass_kg", 100.0, 1e6),
            ("slope_deg", 0.0, 45.0),
        ):
            lo, hi = getattr(self, name)
            object.__setattr__(self, name, (float(lo), float(hi)))
            if not (lo_limit <= lo < hi <= hi_limit):
                raise ValueError(
                    f"OperatingRange.{name} must satisfy {lo_limit} <= min < max <= {hi_limit},"
                    f" got {(lo, hi)}"
                )

    @property
    def severe_event(self) -> tuple[float, float, float]:
        """(speed [m/s], mass [kg], slope [rad]) of the most severe event of the envelope."""
        return (
            self.speed_kmh[1] / 3.6,
            self.mass_kg[1],
            math.radians(self.slope_deg[1]),
        )


@dataclass(frozen=True)
class BrakeModel:
    """Everything the physics of one braking event needs.

    Attributes:
        vehicle: Vehicle parameters.
        brake: Brake parameters.
        friction: Friction law mu(T).
        hardness: Hot-hardness law H(T).
        envelope: Operating envelope (atlas grid bounds, sampling ranges, severe event).
        n_steps: Fixed RK4 steps per event in the velocity domain [-].
    """

    vehicle: VehicleParams = field(default_factory=VehicleParams)
    brake: BrakeParams = field(default_factory=BrakeParams)
    friction: FrictionParams = field(default_factory=FrictionParams)
    hardness: HardnessParams = field(default_factory=HardnessParams)
    envelope: OperatingRange = field(default_factory=OperatingRange)
    n_steps: int = 48

    def __post_init__(self) -> None:
        plain_numbers(self)
        if not isinstance(self.n_steps, int) or not 4 <= self.n_steps <= 100_000:
            raise ValueError(
                f"BrakeModel.n_steps must be an int in [4, 100000], got {self.n_steps!r}"
            )

    @classmethod
    def preset(cls, name: str = "hot-duty") -> BrakeModel:
        """Named calibrations.

        ``hot-duty`` (default): events start at 450 C, the calibration that reproduces the
        paper's end-of-life wear acceleration. ``cold-start``: same brake with events starting
        at 25 C, kept to show why the default is hot (wear per event then falls with wear).
        """
        if name == "hot-duty":
            return cls()
        if name == "cold-start":
            return cls(brake=dataclasses.replace(BrakeParams(), start_temp_c=25.0))
        raise ValueError(
            f"unknown BrakeModel preset {name!r}; valid are ['cold-start', 'hot-duty']"
        )

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> BrakeModel:
        """Inverse of :meth:`to_dict`; unknown keys are rejected by name."""
        parts = {
            "vehicle": VehicleParams,
            "brake": BrakeParams,
            "friction": FrictionParams,
            "hardness": HardnessParams,
            "envelope": OperatingRange,
        }
        unknown = sorted(set(data) - set(parts) - {"n_steps"})
        if unknown:
            raise ValueError(f"BrakeModel: unknown section(s) {unknown}")
        kwargs: dict[str, Any] = {
            k: from_dict(t, dict(data[k])) for k, t in parts.items() if k in data
        }
        if "n_steps" in data:
            kwargs["n_steps"] = data["n_steps"]
        return cls(**kwargs)


__all__ = [
    "GRAVITY",
    "BrakeModel",
    "BrakeParams",
    "OperatingRange",
    "VehicleParams",
]
