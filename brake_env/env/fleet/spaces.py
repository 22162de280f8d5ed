"""Observation and action layout of BrakeWearFleet-v0, and the reader of the observation.

The observation is one flat float32 Box: ``VEHICLE_FEATURES`` for each vehicle in vehicle
order, then ``FLEET_FEATURES``, then what RUL wrappers append (``k`` fields per vehicle).
:func:`split_observation` gives the first two parts back as arrays, :func:`read_observation`
all three by name (what every policy reads). The mask is a rule (:mod:`.rules`).
The action is ``MultiDiscrete([4] * n_vehicles + [max_order + 1])``: a duty per vehicle (0
hot, 1 mild, 2 park, 3 service), then the reorder quantity.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from brake_env.env.fleet.config import ENV_ID, FleetConfig
from brake_env.env.fleet.pads import ShiftEvents
from brake_env.env.fleet.shop import Workshop
from brake_env.model.streams import SENSOR_CHANNELS

F32 = NDArray[np.float32]
# Per vehicle: the shift's mean of each event-log channel, its hottest event, the events
# braked, the pad's age and the shifts it is still out of service.
VEHICLE_FEATURES = (
    *(f"{c}_mean" for c in SENSOR_CHANNELS),
    "temp_c_max",
    "events",
    "pad_age",
    "down_shifts",
)
FLEET_FEATURES = ("shift", "shifts_to_window", "stock", "in_transit", "free_bays")
N_VF = len(VEHICLE_FEATURES)
# Sensor ranges (BrakeWear-v0's observation ranges), readings clipped into them.
_SENSOR_LOW = np.array([0.0, 0.0, -np.pi / 2, 0.0, -273.15, 0.0], dtype=np.float32)
_SENSOR_HIGH = np.array([200.0, 1e6, np.pi / 2, 1e9, 3000.0, 1e4], dtype=np.float32)
MAX_AGE = 1e7  # events; more than any pad's life at the K range allowed


def observation_space(config: FleetConfig) -> spaces.Box:
    c = config
    v_low = np.concatenate([_SENSOR_LOW, [-273.15, 0.0, 0.0, 0.0]])
    v_high = np.concatenate(
        [_SENSOR_HIGH, [3000.0, c.events_per_shift, MAX_AGE, 10 * c.failure_repair_shifts + 1e4]]
    )
    max_stock = c.initial_stock + c.max_order * c.episode_shifts
    f_low = np.zeros(len(FLEET_FEATURES))
    f_high = np.array(
        [c.episode_shifts, c.window_period - 1, max_stock, c.max_order * c.lead_time, c.bays]
    )
    low = np.concatenate([np.tile(v_low, c.n_vehicles), f_low]).astype(np.float32)
    high = np.concatenate([np.tile(v_high, c.n_vehicles), f_high]).astype(np.float32)
    return spaces.Box(low, high, dtype=np.float32)


def action_space(config: FleetConfig) -> spaces.MultiDiscrete:
    return spaces.MultiDiscrete([4] * config.n_vehicles + [config.max_order + 1])


def parse_action(config: FleetConfig, action: Any) -> tuple[NDArray[np.int64], int]:
    """The duties and the order of ``action``: an integer array (any numpy integer dtype)
    or a list or tuple of ints (Python or numpy), nothing else; one ``ValueError`` naming
    the first bad vehicle (or the order) and its value."""
    n, max_order = config.n_vehicles, config.max_order
    what = f"{n + 1} integers (a duty 0-3 per vehicle, then the order 0-{max_order})"
    if isinstance(action, np.ndarray):
        if action.shape != (n + 1,):
            raise ValueError(f"{ENV_ID}: action must be {what}, got shape {action.shape}")
        # Python ints (no wrap-around of a huge uint64), or numpy scalars that show their
        # dtype in the message.
        values = action.tolist() if action.dtype.kind in "iu" else list(action)
    elif isinstance(action, list | tuple):
        if len(action) != n + 1:
            raise ValueError(f"{ENV_ID}: action must be {what}, got {len(action)}: {action!r}")
        values = list(action)
    else:
        raise ValueError(f"{ENV_ID}: action must be {what}, got {action!r}")
    out = np.empty(n + 1, dtype=np.int64)
    for i, value in enumerate(values):
        who = f"vehicle {i}'s duty" if i < n else "the order (last entry)"
        x = as_int(value)
        if x is None:
            raise ValueError(
                f"{ENV_ID}: {who} {value!r} is not an integer; the action must be {what}"
            )
        high = 3 if i < n else max_order
        if not 0 <= x <= high:
            raise ValueError(f"{ENV_ID}: {who} {x} is outside 0-{high}; the action is {what}")
        out[i] = x
    return out[:-1], int(out[-1])


def as_int(value: object) -> int | None:
    """``value`` as a Python int if it is an integer: a Python int, a numpy integer scalar
    or a 0-d integer array; else None. Floats (even 2.0), bools, NaN, strings, None and
    larger arrays are not integers: an action is never guessed at by truncation."""
    if isinstance(value, bool | np.bool_):
        return None
    if isinstance(value, int | np.integer):
        return int(value)
    if isinstance(value, np.ndarray) and value.shape == () and value.dtype.kind in "iu":
        return int(value)
    return None


def split_observation(obs: F32, n_vehicles: int) -> tuple[F32, F32]:
    """(per-vehicle features (n_vehicles, len(VEHICLE_FEATURES)), fleet features)."""
    return obs[: n_vehicles * N_VF].reshape(n_vehicles, N_VF), obs[n_vehicles * N_VF :]


def shift_summary(ev: ShiftEvents | None, n: int) -> NDArray[np.float64]:
    """(n, 8): each vehicle's channel means and hottest reading over the shift's events,
    and their count; zeros for a vehicle that braked none."""
    out = np.zeros((n, len(SENSOR_CHANNELS) + 2))
    if ev is None or ev.measured is None:
        return out
    count = ev.valid.sum(axis=1)
    w = np.where(ev.valid, 1.0, 0.0)
    out[:, :6] = (ev.measured * w).sum(axis=2).T / np.maximum(count, 1)[:, None]
    temp = np.where(ev.valid, ev.measured[4], -np.inf).max(axis=1)
    out[:, 6] = np.where(count > 0, temp, 0.0)
    out[:, 7] = count
    return out


def fleet_observation(
    config: FleetConfig, summary: NDArray[np.float64], pad_age: NDArray[np.int64],
    shop: Workshop, shift: int, box: spaces.Box,
) -> F32:  # fmt: skip
    """The flat observation at the start of shift ``shift``."""
    per = np.concatenate([summary, pad_age[:, None], shop.down[:, None]], axis=1)
    fleet = [shift, config.shifts_to_window(shift), shop.stock, shop.in_transit, shop.free_bays()]
    obs = np.concatenate([per.ravel(), fleet]).astype(np.float32)
    return np.clip(obs, box.low, box.high, out=obs)


@dataclass(frozen=True)
class FleetObservation:
    """One (possibly RUL-wrapped) fleet observation, read by name.

    Attributes:
        vehicles: (n_vehicles, len(VEHICLE_FEATURES)) per-vehicle features.
        fleet: ``FLEET_FEATURES`` by name (counts rounded to ints).
        appended: (n_vehicles, k) values a RUL wrapper appended per vehicle (k may be 0).
    """

    vehicles: NDArray[np.float64]
    fleet: dict[str, int]
    appended: NDArray[np.float64]

    def vehicle(self, feature: str) -> NDArray[np.float64]:
        """One per-vehicle feature of ``VEHICLE_FEATURES`` for every vehicle."""
        return self.vehicles[:, VEHICLE_FEATURES.index(feature)]

    @property
    def down(self) -> NDArray[np.bool_]:
        """Vehicles in the shop this shift."""
        return self.vehicle("down_shifts") > 0

    @property
    def window(self) -> bool:
        """Whether the coming shift is a scheduled window."""
        return self.fleet["shifts_to_window"] == 0


def read_observation(obs: NDArray[np.floating], n_vehicles: int, k: int) -> FleetObservation:
    """Read an observation of ``n_vehicles`` with ``k`` values appended per vehicle.

    Raises:
        ValueError: The observation does not have that size.
    """
    o = np.asarray(obs, dtype=np.float64)
    size = n_vehicles * (N_VF + k) + len(FLEET_FEATURES)
    if o.shape != (size,):
        raise ValueError(
            f"fleet observation: expected {size} values ({n_vehicles} vehicles, {k} appended"
            f" each), got shape {o.shape}"
        )
    n, nf = n_vehicles * N_VF, len(FLEET_FEATURES)
    fleet = {name: round(float(x)) for name, x in zip(FLEET_FEATURES, o[n : n + nf], strict=True)}
    return FleetObservation(
        o[:n].reshape(n_vehicles, N_VF), fleet, o[n + nf :].reshape(n_vehicles, k)
    )
