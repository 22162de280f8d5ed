"""What a fleet rule reads from BrakeWearFleet-v0's observation: each vehicle's RUL on the
hot and the mild route (in shifts of that route), pad age and shop state; the fleet's shift,
window, stock and bays; and the mask of allowed actions, rebuilt from the observation alone.

The RUL is the one a :class:`~brake_env.env.fleet.wrappers.FleetRULObservation` (any
predictor, the oracle included) or an
:class:`~brake_env.env.fleet.wrappers.ExpectedRULObservation` (the oracle's, closed form)
appends: already in shifts of each route, whatever the predictor, so no rule converts.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from brake_env.env.fleet import rules
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.route_rul import ROUTE_NAMES
from brake_env.env.fleet.routes import ROUTE_INDEX
from brake_env.env.fleet.spaces import FLEET_FEATURES, N_VF, read_observation
from brake_env.env.fleet.wrappers import ESTIMATE_FIELDS

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class FleetLayout:
    """Where a rule finds things in the (RUL-wrapped) fleet observation, and the fleet it
    acts on (its needs, crew and order limit are the config's).

    Attributes:
        config: The env's config.
        fields: RUL fields appended per vehicle and route (the wrapper's ``fields``).
        rul_field: Which of them the rules read (e.g. ``rul_lower`` for a cautious rule).
        routes: Routes whose RUL is appended, in order (the wrapper's ``routes``); must
            hold ``hot``.
    """

    config: FleetConfig
    fields: tuple[str, ...] = ("rul_mean",)
    rul_field: str = "rul_mean"
    routes: tuple[str, ...] = ROUTE_NAMES

    def __post_init__(self) -> None:
        if not isinstance(self.config, FleetConfig):
            raise TypeError(f"FleetLayout: config must be a FleetConfig, got {self.config!r}")
        if not self.fields or any(f not in ESTIMATE_FIELDS for f in self.fields):
            raise ValueError(f"FleetLayout: fields must be among {ESTIMATE_FIELDS}")
        if self.rul_field not in self.fields:
            raise ValueError(f"FleetLayout: rul_field {self.rul_field!r} not in {self.fields}")
        if "hot" not in self.routes or any(r not in ROUTE_INDEX for r in self.routes):
            raise ValueError(
                f"FleetLayout: routes must be route names holding 'hot', got {self.routes!r}"
            )

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
    def per_vehicle(self) -> int:
        """Values appended per vehicle: every field on every route."""
        return len(self.fields) * len(self.routes)

    @property
    def size(self) -> int:
        return self.n_vehicles * (N_VF + self.per_vehicle) + len(FLEET_FEATURES)

    def column(self, route: str, field: str) -> int | None:
        """Where ``field`` of ``route`` is among a vehicle's appended values (None: absent)."""
        if route not in self.routes or field not in self.fields:
            return None
        return self.routes.index(route) * len(self.fields) + self.fields.index(field)


@dataclass(frozen=True)
class FleetView:
    """One observation, read. Per vehicle arrays have shape (n_vehicles,).

    Attributes:
        rul: RUL on the hot route (the layout's ``rul_field``) [hot shifts].
        rul_mild: RUL on the mild route (``rul_field``; NaN if not appended) [mild shifts].
        rul_lower, rul_upper: Interval of the hot-route RUL (``rul`` where not appended)
            [hot shifts].
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
    rul_mild: F64 | None = None
    rul_lower: F64 | None = None
    rul_upper: F64 | None = None

    @property
    def window(self) -> bool:
        """Whether the coming shift is a scheduled window."""
        return self.to_window == 0

    @classmethod
    def read(cls, obs: NDArray[Any], layout: FleetLayout) -> FleetView:
        try:
            o = read_observation(obs, layout.n_vehicles, layout.per_vehicle)
        except ValueError as e:
            raise ValueError(
                f"fleet rule: {e} (RUL fields {layout.fields} on routes {layout.routes})"
            ) from None

        def col(route: str, field: str, default: F64 | None) -> F64 | None:
            i = layout.column(route, field)
            return default if i is None else o.appended[:, i]

        rul = o.appended[:, layout.column("hot", layout.rul_field)]
        f = o.fleet
        return cls(
            rul=rul,
            rul_mild=col("mild", layout.rul_field, np.full(len(rul), np.nan)),
            rul_lower=col("hot", "rul_lower", rul),
            rul_upper=col("hot", "rul_upper", rul),
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
