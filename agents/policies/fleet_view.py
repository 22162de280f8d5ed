"""What a fleet rule reads from BrakeWearFleet-v0's observation: each vehicle's RUL (in
shifts of hot duty), pad age and shop state; the fleet's shift, window, stock and bays; and
the mask of allowed actions, rebuilt from the observation alone.

The RUL is the one a :class:`~brake_env.env.fleet.wrappers.FleetRULObservation` appends
(any predictor; the oracle's when the env has ``truth=True``). A predictor gives it in
events under its own assumption of the operating mix: the oracle's is events on the hot
route, the paper's predictors' events on the envelope's uniform mix. ``rul_per_shift``
converts it into shifts of hot duty, the unit every rule's limits are in.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from brake_env.env.fleet import routes
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.shop import HOT, MILD, SERVICE
from brake_env.env.fleet.spaces import FLEET_FEATURES, N_VF, VEHICLE_FEATURES
from brake_env.env.fleet.wrappers import ESTIMATE_FIELDS
from brake_env.model.atlas import Atlas

F64 = NDArray[np.float64]
_AGE = VEHICLE_FEATURES.index("pad_age")
_DOWN = VEHICLE_FEATURES.index("down_shifts")
_FLEET = {name: i for i, name in enumerate(FLEET_FEATURES)}


def rul_per_hot_shift(config: FleetConfig, atlas: Atlas, predictor_route: str = "hot") -> float:
    """Events of a predictor's RUL that one shift of hot duty uses: ``events_per_shift`` for
    a RUL on the hot route (the oracle's); for a RUL on the envelope's uniform mix (the
    paper's predictors) scaled by the hot route's wear per event over the uniform mix's
    (fresh-pad layer; the ratio grows ~15% towards the last layer, DESIGN.md 10)."""
    if predictor_route == "hot":
        return float(config.events_per_shift)
    if predictor_route != "uniform":
        raise ValueError(f"predictor_route must be 'hot' or 'uniform', got {predictor_route!r}")
    hot, uniform = (routes.route_mean(atlas, r)[0] for r in (routes.HOT, routes.UNIFORM))
    ratio = float(hot / uniform)
    return float(config.events_per_shift) * ratio


@dataclass(frozen=True)
class FleetLayout:
    """Where a rule finds things in the (RUL-wrapped) fleet observation.

    Attributes:
        n_vehicles: Vehicles in the fleet.
        hot_need: Vehicles needed on the hot route each working shift.
        max_order: Largest reorder quantity of one shift.
        fields: RUL fields appended per vehicle (FleetRULObservation's ``fields``).
        rul_field: Which of them the rules read (e.g. ``rul_lower`` for a cautious rule).
        rul_per_shift: Events of RUL one hot shift uses (:func:`rul_per_hot_shift`).
        mild_need: Vehicles needed on the mild route each working shift (beyond the hot).
        window_slots: Pad sets the window's crew can fit.
    """

    n_vehicles: int
    hot_need: int
    max_order: int
    fields: tuple[str, ...] = ("rul_mean",)
    rul_field: str = "rul_mean"
    rul_per_shift: float = 400.0
    mild_need: int = 0
    window_slots: int = 256

    def __post_init__(self) -> None:
        if self.n_vehicles < 1 or not 0 <= self.hot_need <= self.n_vehicles:
            raise ValueError(f"FleetLayout: need 1 <= n_vehicles and 0 <= hot_need <= n_vehicles,"
                             f" got {self.n_vehicles}, {self.hot_need}")  # fmt: skip
        if self.mild_need < 0 or self.hot_need + self.mild_need > self.n_vehicles:
            raise ValueError(f"FleetLayout: need 0 <= mild_need <= n_vehicles - hot_need,"
                             f" got {self.mild_need}")  # fmt: skip
        if self.window_slots < 0:
            raise ValueError(f"FleetLayout: window_slots must be >= 0, got {self.window_slots}")
        if not self.fields or any(f not in ESTIMATE_FIELDS for f in self.fields):
            raise ValueError(f"FleetLayout: fields must be among {ESTIMATE_FIELDS}")
        if self.rul_field not in self.fields:
            raise ValueError(f"FleetLayout: rul_field {self.rul_field!r} not in {self.fields}")
        if not self.rul_per_shift > 0:
            raise ValueError(f"FleetLayout: rul_per_shift must be > 0, got {self.rul_per_shift}")

    @classmethod
    def of(cls, config: FleetConfig, **kwargs: Any) -> FleetLayout:
        """The layout of an env with ``config`` (rul_per_shift defaults to the hot route's)."""
        kwargs.setdefault("rul_per_shift", float(config.events_per_shift))
        kwargs.setdefault("mild_need", config.mild_need)
        kwargs.setdefault("window_slots", config.window_slots)
        return cls(config.n_vehicles, config.hot_need, config.max_order, **kwargs)

    @property
    def size(self) -> int:
        return self.n_vehicles * (N_VF + len(self.fields)) + len(FLEET_FEATURES)


@dataclass(frozen=True)
class FleetView:
    """One observation, read. Per vehicle arrays have shape (n_vehicles,).

    Attributes:
        rul: RUL in shifts of hot duty.
        age: Pad age [events].
        down: Whether the vehicle is in the shop (down) this shift.
        shift, to_window, stock, transit, free_bays: The fleet's features.
    """

    rul: F64
    age: F64
    down: NDArray[np.bool_]
    shift: int
    to_window: int
    stock: int
    transit: int
    free_bays: int

    @property
    def window(self) -> bool:
        """Whether the coming shift is a scheduled window."""
        return self.to_window == 0

    @classmethod
    def read(cls, obs: NDArray[Any], layout: FleetLayout) -> FleetView:
        o = np.asarray(obs, dtype=np.float64)
        if o.shape != (layout.size,):
            raise ValueError(
                f"fleet rule: observation must have {layout.size} values (n_vehicles"
                f" {layout.n_vehicles}, RUL fields {layout.fields}), got shape {o.shape}"
            )
        n = layout.n_vehicles
        veh = o[: n * N_VF].reshape(n, N_VF)
        fleet = o[n * N_VF : n * N_VF + len(FLEET_FEATURES)]
        est = o[n * N_VF + len(FLEET_FEATURES) :].reshape(n, len(layout.fields))
        rul = est[:, layout.fields.index(layout.rul_field)] / layout.rul_per_shift
        return cls(
            rul=rul,
            age=veh[:, _AGE],
            down=veh[:, _DOWN] > 0,
            shift=round(float(fleet[_FLEET["shift"]])),
            to_window=round(float(fleet[_FLEET["shifts_to_window"]])),
            stock=round(float(fleet[_FLEET["stock"]])),
            transit=round(float(fleet[_FLEET["in_transit"]])),
            free_bays=round(float(fleet[_FLEET["free_bays"]])),
        )

    def mask(self, max_order: int) -> NDArray[np.bool_]:
        """The env's :meth:`action_masks`, rebuilt from the observation (the same rule as
        :func:`brake_env.env.fleet.spaces.action_mask`; tested equal along episodes)."""
        n = len(self.rul)
        m = np.ones((n, 4), dtype=bool)
        m[:, [HOT, MILD]] = ~(self.down | self.window)[:, None]
        m[:, SERVICE] = self.stock > 0
        if not self.window:
            m[~self.down, SERVICE] &= self.free_bays > 0
        return np.concatenate([m.ravel(), np.ones(max_order + 1, dtype=bool)])


def respects(action: NDArray[np.int64], mask: NDArray[np.bool_], n_vehicles: int) -> bool:
    """Whether every dimension of ``action`` is allowed by the flat ``mask``."""
    a = np.asarray(action)
    duty_ok = mask[: 4 * n_vehicles].reshape(n_vehicles, 4)[np.arange(n_vehicles), a[:-1]]
    return bool(duty_ok.all() and mask[4 * n_vehicles + int(a[-1])])


class ExpectedRULObservation(
    gym.ObservationWrapper[NDArray[np.float32], NDArray[np.int64], NDArray[np.float32]]
):
    """The oracle's RUL in closed form: appends, like
    :class:`~brake_env.env.fleet.wrappers.FleetRULObservation`, each vehicle's RUL, here the
    expected events to failure on the hot route from its pad's true volume and K (the
    atlas's layer wear; :func:`~brake_env.env.fleet.routes.route_wear_model`). It differs
    from the oracle predictor's RUL (the events the pad will really complete, simulated
    ahead) only by the law-of-large-numbers noise of the wear to come, and costs nothing
    to compute (the simulated-ahead oracle makes a 2-vehicle episode ~20x slower). It reads
    the env's truth: for references and oracle-RUL versions of rules, never deployable.

    Args:
        env: BrakeWearFleet-v0 (possibly wrapped).
        fields: Fields to append (all equal: a point estimate).
    """

    def __init__(
        self,
        env: gym.Env[NDArray[np.float32], NDArray[np.int64]],
        fields: tuple[str, ...] = ("rul_mean",),
    ) -> None:
        super().__init__(env)
        if not fields or any(f not in ESTIMATE_FIELDS for f in fields):
            raise ValueError(f"ExpectedRULObservation: fields must be among {ESTIMATE_FIELDS}")
        base = env.observation_space
        assert isinstance(base, spaces.Box)
        self.fields = tuple(fields)
        self.n = int(env.unwrapped.config.n_vehicles)  # type: ignore[attr-defined]
        self.wear = routes.route_wear_model(env.unwrapped.atlas, routes.HOT)  # type: ignore[attr-defined]
        k = len(fields) * self.n
        self.observation_space = spaces.Box(
            np.concatenate([base.low, np.zeros(k, dtype=np.float32)]),
            np.concatenate([base.high, np.full(k, 1e7, dtype=np.float32)]),
            dtype=np.float32,
        )

    def rul(self) -> F64:
        """Each vehicle's expected hot-route RUL now [events]."""
        truth = self.env.unwrapped.truth()  # type: ignore[attr-defined]
        v = np.clip(truth["volume_frac"], self.wear.lower_edges[-1], 1.0)
        return self.wear.rul(v, truth["wear_coeff"])

    def observation(self, observation: NDArray[np.float32]) -> NDArray[np.float32]:
        est = np.repeat(np.clip(self.rul(), 0.0, 1e7), len(self.fields))
        return np.concatenate([observation, est]).astype(np.float32)
