"""Physics of one braking event, vectorised over a batch of events (paper 2.1.1).

A vehicle of mass m at speed v0 on a downhill slope theta applies a fixed line pressure p on
every braked wheel. Per brake:

    tau_b = mu(T) * N_p * p * (pi * D_b^2 / 4) * r_m         brake torque
    P_gen = tau_b * omega,  omega = v / r_w                   heat into the brake
    dT/dt = P_gen / C_th,   C_th = C_backing + C_pad * V      thermal mass shrinks with wear
    dV/dt = K * (N_p p A) * v_slide / H(T),  v_slide = omega * r_m   (Archard, hot hardness)

and the vehicle decelerates at a = n_w tau_b / (r_w m) + C_rr g cos(theta) - g sin(theta).

The event is integrated in the velocity domain: the independent variable s runs from 0 to 1
with v = v0 (1 - s), so every event ends exactly at v = 0 after the same fixed number of RK4
steps and a batch needs no masks. An event whose deceleration reaches zero before it stops
cannot stop (the fade runs away): it is a brake failure.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from brake_env.model.materials import friction, hardness_mpa
from brake_env.model.params import GRAVITY, BrakeModel

F64 = NDArray[np.float64]

# State vector rows: temperature, time, distance, wear per unit K, integral of T dt, friction work.
_T, _TIME, _DIST, _WEAR, _TINT, _WORK = range(6)
_N_STATE = 6


@dataclass(frozen=True)
class EventResponse:
    """Response of a batch of braking events (arrays of one shape; NaN where not stopped).

    Attributes:
        stopped: The vehicle came to rest [bool].
        stop_time_s: Duration of the stop [s].
        stop_dist_m: Stopping distance [m].
        sliding_dist_m: Distance slid at the effective friction radius [m].
        temp_mean_c: Time-averaged brake temperature over the stop [deg C].
        temp_peak_c: Brake temperature at standstill, its maximum [deg C].
        wear_per_k_m3: Pad volume worn per unit Archard coefficient K, one brake [m^3].
        friction_work_j: Energy dissipated by one brake [J].
    """

    stopped: NDArray[np.bool_]
    stop_time_s: F64
    stop_dist_m: F64
    sliding_dist_m: F64
    temp_mean_c: F64
    temp_peak_c: F64
    wear_per_k_m3: F64
    friction_work_j: F64


class EventModifier(Protocol):
    """Optional in-event hook: multipliers on the nominal laws (used by ``sim2real`` effects).

    Each method gets the state at an RK4 stage (arrays over the batch) and returns a factor
    that broadcasts against it. Factors of exactly 1.0 leave the physics bit-identical.
    Arguments: brake temperature [deg C], sliding speed at the effective radius [m/s], line
    pressure [Pa], remaining pad volume fraction [-].
    """

    def friction_factor(
        self, temp_c: F64, slide_speed_mps: F64, pressure_pa: float, volume_frac: F64
    ) -> F64 | float:
        """Multiplier on the friction coefficient mu(T)."""
        ...

    def heat_fraction(
        self, temp_c: F64, slide_speed_mps: F64, pressure_pa: float, volume_frac: F64
    ) -> F64 | float:
        """Share of the friction heat that enters the brake's lumped thermal mass."""
        ...

    def wear_factor(
        self, temp_c: F64, slide_speed_mps: F64, pressure_pa: float, volume_frac: F64
    ) -> F64 | float:
        """Multiplier on the Archard wear rate."""
        ...


def thermal_mass(volume_frac: ArrayLike, model: BrakeModel) -> F64:
    """Heat capacity of one brake [J/K] at remaining pad volume fraction ``volume_frac``."""
    b = model.brake
    v = np.asarray(volume_frac, dtype=np.float64)
    return b.backing_heat_capacity_j_per_k + b.pad_heat_capacity_j_per_k * v


def brake_force_per_mu(model: BrakeModel) -> float:
    """Total braking force at the tyres per unit friction coefficient [N]."""
    veh, b = model.vehicle, model.brake
    return veh.n_braked_wheels * b.normal_force_n * b.effective_radius_m / veh.wheel_radius_m


def simulate_events(
    speed_mps: ArrayLike,
    mass_kg: ArrayLike,
    slope_rad: ArrayLike,
    volume_frac: ArrayLike,
    model: BrakeModel | None = None,
    *,
    start_temp_c: ArrayLike | None = None,
    modifier: EventModifier | None = None,
) -> EventResponse:
    """Integrate a batch of braking events until standstill (broadcasting inputs).

    Args:
        speed_mps: Speed at brake onset [m/s], > 0.
        mass_kg: Vehicle mass [kg].
        slope_rad: Downhill slope [rad] (positive: gravity pushes the vehicle forward).
        volume_frac: Remaining pad volume as a fraction of a fresh pad [-], in (0, 1].
        model: Physical parameters; the default calibration if omitted.
        start_temp_c: Brake temperature at onset [deg C]; ``model.brake.start_temp_c`` if omitted.
        modifier: Optional in-event changes to friction, heat and wear (``sim2real``
            effects); None (the default) runs the nominal physics unchanged.

    Returns:
        The per-event response; fields of events that could not stop are NaN.
    """
    model = model or BrakeModel()
    v0, m, theta, vol, t_start, shape = _event_inputs(
        speed_mps, mass_kg, slope_rad, volume_frac, model, start_temp_c
    )
    rates = _EventRates(v0, m, theta, vol, model, modifier)
    y = np.zeros((_N_STATE, v0.size))
    y[_T] = t_start
    h = 1.0 / model.n_steps
    for i in range(model.n_steps):  # RK4 in s = 1 - v / v0: every event stops at s = 1
        s = i * h
        k1 = rates(s, y)
        k2 = rates(s + 0.5 * h, y + 0.5 * h * k1)
        k3 = rates(s + 0.5 * h, y + 0.5 * h * k2)
        k4 = rates(s + h, y + h * k3)
        y = y + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        # Runaway states overflow harmlessly; keep them finite until they are NaN-ed below.
        y[:, rates.failed] = 0.0
    return _response(y, ~rates.failed, shape, rates.slide_ratio)


def _event_inputs(
    speed_mps: ArrayLike,
    mass_kg: ArrayLike,
    slope_rad: ArrayLike,
    volume_frac: ArrayLike,
    model: BrakeModel,
    start_temp_c: ArrayLike | None,
) -> tuple[F64, F64, F64, F64, F64, tuple[int, ...]]:
    """Inputs broadcast together and flattened, checked; with their common shape."""
    v0, m, theta, vol = np.broadcast_arrays(
        *(np.asarray(x, dtype=np.float64) for x in (speed_mps, mass_kg, slope_rad, volume_frac))
    )
    shape = v0.shape
    v0, m, theta, vol = (x.ravel() for x in (v0, m, theta, vol))
    if not all(np.all(np.isfinite(x)) for x in (v0, m, theta, vol)):
        raise ValueError("speed, mass, slope and volume_frac must be finite (got NaN or inf)")
    if np.any(v0 <= 0) or np.any(m <= 0) or np.any((vol <= 0) | (vol > 1)):
        raise ValueError("speed and mass must be > 0 and volume_frac in (0, 1]")
    t_start = np.broadcast_to(
        np.asarray(model.brake.start_temp_c if start_temp_c is None else start_temp_c, float),
        shape,
    ).ravel()
    return v0, m, theta, vol, t_start, shape


class _EventRates:
    """d(state)/ds of a batch of events with v = v0 (1 - s); flags (``failed``) the events
    whose deceleration reaches zero: they can no longer stop."""

    def __init__(
        self,
        v0: F64,
        m: F64,
        theta: F64,
        vol: F64,
        model: BrakeModel,
        modifier: EventModifier | None,
    ) -> None:
        veh, brk = model.vehicle, model.brake
        self.v0, self.vol, self.model, self.modifier = v0, vol, model, modifier
        self.n_w = veh.n_braked_wheels
        self.f_per_mu = brake_force_per_mu(model)  # total tyre force per unit mu [N]
        self.slide_ratio = brk.effective_radius_m / veh.wheel_radius_m
        self.wear_force = brk.normal_force_n * 1e-6  # N per MPa of hardness: wear in m^3
        self.p_line = brk.line_pressure_pa
        self.c_th = thermal_mass(vol, model)
        # Net resisting acceleration apart from the brake: rolling resistance minus gravity.
        self.a_ext = veh.rolling_resistance * GRAVITY * np.cos(theta) - GRAVITY * np.sin(theta)
        self.inv_m = 1.0 / m
        self.failed = np.zeros(v0.shape, dtype=bool)

    def __call__(self, s: float, y: F64) -> F64:
        model, mod, vol = self.model, self.modifier, self.vol
        temp = y[_T]
        v = self.v0 * (1.0 - s)
        f_brake = friction(temp, model.friction) * self.f_per_mu
        if mod is not None:
            v_slide = v * self.slide_ratio
            f_brake = f_brake * mod.friction_factor(temp, v_slide, self.p_line, vol)
        a = f_brake * self.inv_m + self.a_ext
        self.failed[:] |= a <= 0.0
        dt_ds = self.v0 / np.maximum(a, 1e-9)  # dt/ds = v0 / a; clipped where failure is flagged
        power = f_brake / self.n_w * v  # heat into one brake [W]
        out = np.empty_like(y)
        out[_T] = power / self.c_th * dt_ds
        out[_TIME] = dt_ds
        out[_DIST] = v * dt_ds
        out[_WEAR] = (
            self.wear_force * self.slide_ratio * v / hardness_mpa(temp, model.hardness) * dt_ds
        )
        if mod is not None:
            out[_T] *= mod.heat_fraction(temp, v_slide, self.p_line, vol)
            out[_WEAR] *= mod.wear_factor(temp, v_slide, self.p_line, vol)
        out[_TINT] = temp * dt_ds
        out[_WORK] = power * dt_ds
        return out


def _response(
    y: F64, stopped: NDArray[np.bool_], shape: tuple[int, ...], slide: float
) -> EventResponse:
    """The per-event record of the final states; NaN where an event could not stop."""
    nan_if_failed = lambda x: np.where(stopped, x, np.nan).reshape(shape)  # noqa: E731
    dist = y[_DIST]
    return EventResponse(
        stopped=stopped.reshape(shape),
        stop_time_s=nan_if_failed(y[_TIME]),
        stop_dist_m=nan_if_failed(dist),
        sliding_dist_m=nan_if_failed(dist * slide),
        temp_mean_c=nan_if_failed(y[_TINT] / np.where(stopped, y[_TIME], 1.0)),
        temp_peak_c=nan_if_failed(y[_T]),
        wear_per_k_m3=nan_if_failed(y[_WEAR]),
        friction_work_j=nan_if_failed(y[_WORK]),
    )


def can_stop(
    volume_frac: float,
    speed_mps: float,
    mass_kg: float,
    slope_rad: float,
    model: BrakeModel,
    modifier: EventModifier | None = None,
) -> bool:
    """Whether one event at these conditions stops at pad volume fraction ``volume_frac``."""
    r = simulate_events(speed_mps, mass_kg, slope_rad, volume_frac, model, modifier=modifier)
    return bool(r.stopped)


def critical_volume(
    model: BrakeModel | None = None,
    tol: float = 1e-6,
    modifier: EventModifier | None = None,
    batch: int = 1,
) -> float:
    """Pad volume fraction below which the envelope's most severe event can no longer stop.

    Found on the physics (not by atlas layer steps) by shrinking a bracket until it is
    narrower than ``tol``: by bisection (``batch=1``), or with ``batch`` volumes per round
    simulated at once (fewer rounds, for callers that build many models). Returns 0.0 if
    even an almost fully worn pad stops it, and raises if a fresh pad cannot. ``modifier``
    as in :func:`simulate_events`.
    """
    if batch != 1 and batch < 3:  # 2 volumes per round are the bracket itself: no progress
        raise ValueError(f"critical_volume: batch must be 1 or >= 3, got {batch}")
    model = model or BrakeModel()
    v, m, th = model.envelope.severe_event
    lo, hi = 1e-4, 1.0  # lo: may fail, hi: must stop
    if not can_stop(hi, v, m, th, model, modifier):
        raise ValueError("a fresh brake cannot stop the most severe event: check the calibration")
    if can_stop(lo, v, m, th, model, modifier):
        return 0.0
    while hi - lo > tol:
        if batch > 1:  # stopping is monotonic in volume: the last failing one bounds below
            vols = np.linspace(lo, hi, batch)
            ok = simulate_events(v, m, th, vols, model, modifier=modifier).stopped
            j = int(np.flatnonzero(~ok)[-1])
            lo, hi = float(vols[j]), float(vols[j + 1])
            continue
        mid = 0.5 * (lo + hi)
        if can_stop(mid, v, m, th, model, modifier):
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi)


def end_of_life(critical_volume_frac: float, model: BrakeModel) -> float:
    """The pad's life ends when it cannot stop the severe event, or at the wear-out limit."""
    return max(critical_volume_frac, model.brake.min_volume_frac)
