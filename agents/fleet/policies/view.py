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

import numpy as np
from numpy.typing import NDArray

from brake_env.env.fleet import routes, rules
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.spaces import FLEET_FEATURES, N_VF, read_observation
from brake_env.env.fleet.wrappers import ESTIMATE_FIELDS
from brake_env.model.atlas import Atlas

F64 = NDArray[np.float64]


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
    """Where a rule finds things in the (RUL-wrapped) fleet observation, and the fleet it
    acts on (its needs, crew and order limit are the config's).

    Attributes:
        config: The env's config.
        fields: RUL fields appended per vehicle (FleetRULObservation's ``fields``).
        rul_field: Which of them the rules read (e.g. ``rul_lower`` for a cautious rule).
        rul_per_shift: Events of RUL one hot shift uses (:func:`rul_per_hot_shift`); None:
            the config's ``events_per_shift`` (a RUL on the hot route).
    """

    config: FleetConfig
    fields: tuple[str, ...] = ("rul_mean",)
    rul_field: str = "rul_mean"
    rul_per_shift: float | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.config, FleetConfig):
            raise TypeError(f"FleetLayout: config must be a FleetConfig, got {self.config!r}")
        if not self.fields or any(f not in ESTIMATE_FIELDS for f in self.fields):
            raise ValueError(f"FleetLayout: fields must be among {ESTIMATE_FIELDS}")
        if self.rul_field not in self.fields:
            raise ValueError(f"FleetLayout: rul_field {self.rul_field!r} not in {self.fields}")
        if self.rul_per_shift is not None and not self.rul_per_shift > 0:
            raise ValueError(f"FleetLayout: rul_per_shift must be > 0, got {self.rul_per_shift}")

    @classmethod
    def of(cls, config: FleetConfig, **kwargs: Any) -> FleetLayout:
        """The layout of an env with ``config``."""
        return cls(config, **kwargs)

    @property
    def n_vehicles(self) -> int:
        return self.config.n_vehicles

    @property
    def max_order(self) -> int:
        return self.config.max_order

    @property
    def events_per_hot_shift(self) -> float:
        """Events of the appended RUL that one shift of hot duty uses."""
        r = self.rul_per_shift
        return float(self.config.events_per_shift) if r is None else r

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
        try:
            o = read_observation(obs, layout.n_vehicles, len(layout.fields))
        except ValueError as e:
            raise ValueError(f"fleet rule: {e} (RUL fields {layout.fields})") from None
        est = o.appended[:, layout.fields.index(layout.rul_field)]
        f = o.fleet
        return cls(
            rul=est / layout.events_per_hot_shift,
            age=o.vehicle("pad_age"),
            down=o.down,
            shift=f["shift"],
            to_window=f["shifts_to_window"],
            stock=f["stock"],
            transit=f["in_transit"],
            free_bays=f["free_bays"],
        )

    def mask(self, max_order: int) -> NDArray[np.bool_]:
        """The env's :meth:`action_masks`, from the observation (the env's rule,
        :func:`brake_env.env.fleet.rules.action_mask`)."""
        return rules.action_mask(self.down, self.window, self.stock, self.free_bays, max_order)


def respects(action: NDArray[np.int64], mask: NDArray[np.bool_], n_vehicles: int) -> bool:
    """Whether every dimension of ``action`` is allowed by the flat ``mask``."""
    a = np.asarray(action)
    duty_ok = mask[: 4 * n_vehicles].reshape(n_vehicles, 4)[np.arange(n_vehicles), a[:-1]]
    return bool(duty_ok.all() and mask[4 * n_vehicles + int(a[-1])])
