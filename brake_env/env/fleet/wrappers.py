"""RUL observation wrappers of BrakeWearFleet-v0: each vehicle's RUL on the hot and the mild
route, in shifts, from any predictor (:class:`FleetRULObservation`: estimate and interval, all
vehicles through the predictor's fleet API in one call per shift) and the oracle's in closed
form (:class:`ExpectedRULObservation`)."""

from __future__ import annotations

from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from brake_env.env.fleet.config import ENV_ID
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.pads import ShiftEvents
from brake_env.env.fleet.route_rul import ROUTE_NAMES, RouteTracker, duty_clocks
from brake_env.env.fleet.routes import ROUTE_INDEX
from brake_env.env.shared import require_env
from brake_env.model.atlas import Atlas
from brake_env.model.streams import SENSOR_CHANNELS
from brake_env.prognostics.fleet import LoopFleet, vectorises
from brake_env.prognostics.protocol import EventBatch, Oracle, RULEstimate, RULPredictor

ESTIMATE_FIELDS = ("rul_mean", "rul_lower", "rul_upper")
_FIELD_ROW = {f: i for i, f in enumerate(ESTIMATE_FIELDS)}
RUL_HIGH_SHIFTS = 1e5  # shifts; a wild extrapolation is clipped into the space


class FleetRULObservation(
    gym.ObservationWrapper[NDArray[np.float32], NDArray[np.int64], NDArray[np.float32]]
):
    """Append each vehicle's RUL on each route (mean and interval, in shifts of that route)
    to the fleet's observation, from any registered predictor, the oracle included.

    After every shift the events of all vehicles that braked go, concatenated in vehicle
    order, into one :meth:`~brake_env.prognostics.fleet.Fleet.update` of the predictor's
    fleet (a vectorised one where the predictor has it, else one copy per vehicle),
    re-indexed in events of the envelope's uniform mix the predictors were fitted on
    (:mod:`brake_env.env.fleet.route_rul`); its estimate after each vehicle's last event is
    carried onto the routes by one vectorised call
    (:func:`brake_env.prognostics.duty.route_rul`: the atlas's remaining-work ratio of the
    route to the uniform mix at the pad's volume estimate) and divided by
    ``events_per_shift``. The oracle (:class:`~brake_env.prognostics.protocol.Oracle`)
    reads the truth instead: each pad's events to failure on each route, simulated ahead on
    a copy of its streams (:meth:`BrakeWearFleetEnv.true_rul`; the episode is unchanged).

    A vehicle's slot is reset when a new pad's events arrive (they start at event 0); the
    pads in service at the start of an episode are first seen mid-life. A vehicle whose pad
    is new and has not been read yet shows the expected life of a pad of mean K on each
    route, for every field; a vehicle that did not brake keeps its last estimate. A
    predictor without an interval (the MLP) gives its estimate as both bounds. A NaN
    estimate, or an interval not around its mean, raises a ``ValueError`` naming the
    predictor, the vehicle and the values. ``info["rul_estimate"]`` holds the predictor's
    own estimate (uniform-mix events; volume and K where it gives them), each vehicle's
    age in uniform-mix events (``base_age``) and the appended values by name
    (``hot_rul_mean``... in shifts).

    Observation: the base observation, then per vehicle (vehicle order) for each route of
    ``routes`` the ``fields`` in their order, each in [0, 1e5] shifts.

    Args:
        env: BrakeWearFleet-v0 (possibly wrapped).
        predictor: A fitted RUL predictor.
        fields: Estimate fields to append: ``rul_mean``, ``rul_lower``, ``rul_upper``.
        routes: Routes whose RUL is appended: ``hot``, ``mild`` (or ``uniform``).
        atlas: The physics the predictor's user has, which carries its RUL onto the routes
            (the routes' wear rates); default the env's. A user who does not know an
            effect the env's pads wear with carries it with the nominal atlas.
    """

    def __init__(
        self,
        env: gym.Env[NDArray[np.float32], NDArray[np.int64]],
        predictor: RULPredictor,
        fields: tuple[str, ...] = ESTIMATE_FIELDS,
        routes: tuple[str, ...] = ROUTE_NAMES,
        atlas: Atlas | None = None,
    ) -> None:
        super().__init__(env)
        require_env("FleetRULObservation", env, BrakeWearFleetEnv, ENV_ID)
        self.fields, self.routes = _check_layout("FleetRULObservation", fields, routes)
        self.observation_space = _appended_space(env, len(fields) * len(routes))  # type: ignore[assignment]
        base: Any = env.unwrapped
        self.n, self.per_shift = int(base.config.n_vehicles), float(base.config.events_per_shift)
        self.predictor, self.atlas = predictor, atlas
        self.oracle = isinstance(predictor, Oracle)
        self._routes_idx = [ROUTE_INDEX[r] for r in routes]
        self._tracker: RouteTracker | None = None
        self._rul = np.zeros((3, self.n, len(routes)))  # (mean, lower, upper) [events]
        self._extra: dict[str, NDArray[np.float64]] = {}

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[NDArray[np.float32], dict[str, Any]]:
        obs, info = self.env.reset(seed=seed, options=options)
        base: Any = self.env.unwrapped
        if self.oracle:
            self._truth()
        else:
            if self._tracker is None:
                fleet = (
                    self.predictor.fleet(self.n)  # type: ignore[attr-defined]
                    if vectorises(self.predictor)
                    else LoopFleet(self.predictor, self.n)
                )
                k_mean = base.config.wear.k_mean
                atlas = base.atlas if self.atlas is None else self.atlas
                self._tracker = RouteTracker(fleet, atlas, self.routes, k_mean)
            self._tracker.reset(base.pads.pos.astype(np.float64))
            self._from_tracker()
        info["rul_estimate"] = self._info()
        return self.observation(obs), info

    def step(
        self, action: NDArray[np.int64]
    ) -> tuple[NDArray[np.float32], SupportsFloat, bool, bool, dict[str, Any]]:
        obs, reward, terminated, truncated, info = self.env.step(action)
        if self.oracle:
            self._truth()
        else:
            self._feed(info)
        info["rul_estimate"] = self._info()
        return self.observation(obs), reward, terminated, truncated, info

    def observation(self, observation: NDArray[np.float32]) -> NDArray[np.float32]:
        est = np.stack([self._rul[_FIELD_ROW[f]] for f in self.fields], axis=2)  # (n, r, f)
        est = np.clip(est / self.per_shift, 0.0, RUL_HIGH_SHIFTS).ravel()
        return np.concatenate([observation, est]).astype(np.float32, copy=False)

    def _truth(self) -> None:
        base: Any = self.env.unwrapped
        for j, r in enumerate(self._routes_idx):
            self._rul[:, :, j] = base.true_rul(np.full(self.n, r, dtype=np.int64))

    def _feed(self, info: dict[str, Any]) -> None:
        base: Any = self.env.unwrapped
        assert self._tracker is not None
        route = info["vehicles"]["route"]
        est, read = self._tracker.after_step(base.shift_events(), route, base.pads.pos)
        if est is not None:
            self._check(est, read)
        self._from_tracker()

    def _from_tracker(self) -> None:
        assert self._tracker is not None
        r = self._tracker.route_rul()
        self._rul[:] = np.stack([r.mean, r.lower, r.upper])
        self._extra = self._tracker.estimate_info()

    def _check(self, est: RULEstimate, vehicles: NDArray[np.intp]) -> None:
        """Refuse an estimate the observation cannot hold honestly: a NaN RUL or bound
        (outside the space; clipping does not mend it) or an interval not around its mean
        (lower > mean or mean > upper). Infinite RULs pass: they are clipped into the
        space, as any wild extrapolation is."""
        got = {
            f: np.asarray(x, dtype=np.float64)
            for f in ESTIMATE_FIELDS
            if (x := getattr(est, f)) is not None
        }
        mean = got["rul_mean"]
        nan = np.zeros(mean.shape, dtype=bool)
        for x in got.values():
            nan |= np.isnan(x)
        inverted = np.zeros_like(nan)
        if "rul_lower" in got:
            inverted |= got["rul_lower"] > mean
        if "rul_upper" in got:
            inverted |= mean > got["rul_upper"]
        if not (nan | inverted).any():
            return
        i = int(np.flatnonzero(nan | inverted)[0])
        kind = "a NaN RUL" if nan[i] else "an inverted interval (lower > mean or mean > upper)"
        shown = ", ".join(f"{f}={float(x[i])!r}" for f, x in got.items())
        raise ValueError(
            f"FleetRULObservation: predictor {predictor_name(self.predictor)} gave {kind}"
            f" for vehicle {int(vehicles[i])}: {shown} [events]"
        )

    def _info(self) -> dict[str, NDArray[np.float64]]:
        out = {k: v.copy() for k, v in self._extra.items()}
        for j, r in enumerate(self.routes):
            for f in ESTIMATE_FIELDS:
                out[f"{r}_{f}"] = self._rul[_FIELD_ROW[f], :, j] / self.per_shift
        return out


class ExpectedRULObservation(
    gym.ObservationWrapper[NDArray[np.float32], NDArray[np.int64], NDArray[np.float32]]
):
    """The oracle's route RUL in closed form: appends, in the layout of
    :class:`FleetRULObservation`, each vehicle's expected shifts to failure on each route
    from its pad's true volume and K (the atlas's layer wear;
    :func:`~brake_env.env.fleet.routes.route_wear_model`). It differs from the oracle
    predictor's RUL (the events the pad will really complete, simulated ahead) only by the
    law-of-large-numbers noise of the wear to come, and costs nothing to compute (the
    simulated-ahead oracle makes a 2-vehicle episode ~20x slower). It reads the env's
    truth: for references and oracle-RUL versions of rules, never deployable.

    Args:
        env: BrakeWearFleet-v0 (possibly wrapped).
        fields: Fields to append (all equal: a point estimate).
        routes: Routes whose RUL is appended.
    """

    def __init__(
        self,
        env: gym.Env[NDArray[np.float32], NDArray[np.int64]],
        fields: tuple[str, ...] = ("rul_mean",),
        routes: tuple[str, ...] = ROUTE_NAMES,
    ) -> None:
        super().__init__(env)
        require_env("ExpectedRULObservation", env, BrakeWearFleetEnv, ENV_ID)
        self.fields, self.routes = _check_layout("ExpectedRULObservation", fields, routes)
        base: Any = env.unwrapped
        self.n, self.per_shift = int(base.config.n_vehicles), float(base.config.events_per_shift)
        self.clocks = duty_clocks(base.atlas, self.routes)
        self.wear = self.clocks.routes[self.routes.index("hot")] if "hot" in self.routes else None
        self.observation_space = _appended_space(env, len(fields) * len(routes))  # type: ignore[assignment]

    def rul(self, route: str = "hot") -> NDArray[np.float64]:
        """Each vehicle's expected RUL on ``route`` now [events]."""
        truth = self.env.unwrapped.truth()  # type: ignore[attr-defined]
        clock = self.clocks.routes[self.clocks.index(route)]
        v = np.clip(truth["volume_frac"], clock.lower_edges[-1], 1.0)
        return clock.rul(v, truth["wear_coeff"])

    def observation(self, observation: NDArray[np.float32]) -> NDArray[np.float32]:
        per_route = np.stack([self.rul(r) for r in self.routes], axis=1) / self.per_shift
        est = np.repeat(np.clip(per_route, 0.0, RUL_HIGH_SHIFTS), len(self.fields), axis=1)
        return np.concatenate([observation, est.ravel()]).astype(np.float32)


def _check_layout(
    who: str, fields: tuple[str, ...], routes: tuple[str, ...]
) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(fields, routes) as tuples, or one ``ValueError`` naming the bad one."""
    if not fields or any(f not in ESTIMATE_FIELDS for f in fields):
        raise ValueError(f"{who}: fields must be among {ESTIMATE_FIELDS}, got {fields!r}")
    if not routes or any(r not in ROUTE_INDEX for r in routes) or len(set(routes)) < len(routes):
        raise ValueError(
            f"{who}: routes must be distinct names of {list(ROUTE_INDEX)}, got {routes!r}"
        )
    return tuple(fields), tuple(routes)


def _appended_space(env: gym.Env[Any, Any], k_per_vehicle: int) -> spaces.Box:
    base = env.observation_space
    if not isinstance(base, spaces.Box) or len(base.shape) != 1:
        raise ValueError(f"a fleet RUL wrapper needs a 1-D Box observation, got {base}")
    k = k_per_vehicle * int(env.unwrapped.config.n_vehicles)  # type: ignore[attr-defined]
    return spaces.Box(
        np.concatenate([base.low, np.zeros(k, dtype=np.float32)]),
        np.concatenate([base.high, np.full(k, RUL_HIGH_SHIFTS, dtype=np.float32)]),
        dtype=np.float32,
    )


def predictor_name(predictor: object) -> str:
    """A predictor as messages name it: its ``name`` and class (the class alone if it has
    no name)."""
    name, cls = getattr(predictor, "name", None), type(predictor).__name__
    return f"{name!r} ({cls})" if isinstance(name, str) and name and name != cls else cls


def shift_batch(
    ev: ShiftEvents, rul_after: NDArray[np.int64] | None = None
) -> tuple[EventBatch, NDArray[np.intp]]:
    """The shift's events of every vehicle that braked, concatenated in vehicle order (each
    vehicle's rows contiguous and in event order, as a predictor fleet takes them), and
    those vehicles. ``rul_after`` (each pad's true RUL after the shift, when known) fills
    the ``rul_events`` column; a pad that failed in the shift had 0 after its last event."""
    if ev.measured is None:
        raise ValueError("shift_batch needs the measured channels of the shift")
    vehicles = np.flatnonzero(ev.n_done > 0)
    mask = ev.valid
    idx = np.arange(ev.valid.shape[1])
    event = (ev.first_event[:, None] + idx)[mask]
    cols: dict[str, Any] = {c: ev.measured[i][mask] for i, c in enumerate(SENSOR_CHANNELS)}
    rows = np.repeat(vehicles, ev.n_done[vehicles])
    cols["volume_frac"] = ev.volume_frac[mask]
    cols["wear_coeff"] = ev.wear_coeff[rows]
    if rul_after is not None:
        after = np.where(ev.failed, 0, rul_after)
        cols["rul_events"] = (after[:, None] + (ev.n_done[:, None] - 1 - idx))[mask]
    return EventBatch(event=event, **cols), vehicles
