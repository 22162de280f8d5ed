"""RUL observation wrappers of BrakeWearFleet-v0: any predictor's (:class:`FleetRULObservation`:
each vehicle's estimate and interval, all vehicles through the predictor's fleet API in one
call per shift) and the oracle's in closed form (:class:`ExpectedRULObservation`)."""

from __future__ import annotations

from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from brake_env.env.fleet.config import ENV_ID
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.pads import ShiftEvents
from brake_env.env.fleet.routes import HOT, UNIFORM, route_wear_model
from brake_env.env.shared import require_env
from brake_env.model.streams import SENSOR_CHANNELS
from brake_env.prognostics.fleet import Fleet, LoopFleet, vectorises
from brake_env.prognostics.protocol import EventBatch, RULEstimate, RULPredictor

ESTIMATE_FIELDS = ("rul_mean", "rul_lower", "rul_upper")
_RUL_HIGH = 1e7  # events; a wild extrapolation is clipped into the space


class FleetRULObservation(
    gym.ObservationWrapper[NDArray[np.float32], NDArray[np.int64], NDArray[np.float32]]
):
    """Append each vehicle's RUL estimate (in braking events) to the fleet's observation.

    After every shift the events of all vehicles that braked go, concatenated in vehicle
    order, into one :meth:`~brake_env.prognostics.fleet.Fleet.update` of the predictor's
    fleet (a vectorised one where the predictor has it, else one copy per vehicle), which is
    asked for each vehicle's estimate after its last event. A vehicle's slot is reset when a
    new pad's events arrive (they start at event 0); the pads in service at the start of an
    episode are first seen mid-life (the protocol allows a first batch to start anywhere).
    A vehicle whose pad is new and has braked nothing yet shows ``fresh_rul`` (the expected
    life of a pad of mean K on the envelope's uniform mix) for every field; a vehicle that
    did not brake keeps its last estimate. The RUL is the predictor's, in events under its
    own assumption of the operating mix (the paper's predictors assume the envelope's
    uniform one); predictors that give volume and K estimates put them in
    ``info["rul_estimate"]`` too, from which a route's RUL follows
    (:func:`~brake_env.env.fleet.routes.route_wear_model`).

    A predictor without an interval (the oracle, the MLP) gives its estimate as both
    bounds: an interval of zero width. A NaN estimate, or an interval not around its mean
    (lower > mean or mean > upper), raises a ``ValueError`` naming the predictor, the
    vehicle and the values, rather than reaching the observation.

    Observation: the base observation, then ``len(fields)`` values per vehicle (vehicle
    order, fields in the given order), each in [0, 1e7] events.

    Args:
        env: BrakeWearFleet-v0 (possibly wrapped).
        predictor: A fitted RUL predictor.
        fields: Estimate fields to append: ``rul_mean``, ``rul_lower``, ``rul_upper``.
    """

    def __init__(
        self,
        env: gym.Env[NDArray[np.float32], NDArray[np.int64]],
        predictor: RULPredictor,
        fields: tuple[str, ...] = ESTIMATE_FIELDS,
    ) -> None:
        super().__init__(env)
        require_env("FleetRULObservation", env, BrakeWearFleetEnv, ENV_ID)
        bad = [f for f in fields if f not in ESTIMATE_FIELDS]
        if bad or not fields:
            raise ValueError(f"FleetRULObservation: fields must be among {ESTIMATE_FIELDS}")
        base = env.observation_space
        if not isinstance(base, spaces.Box) or len(base.shape) != 1:
            raise ValueError(f"FleetRULObservation needs a 1-D Box observation, got {base}")
        fleet_env = env.unwrapped
        self.n = int(fleet_env.config.n_vehicles)  # type: ignore[attr-defined]
        k = len(fields) * self.n
        self.observation_space = spaces.Box(
            np.concatenate([base.low, np.zeros(k, dtype=np.float32)]),
            np.concatenate([base.high, np.full(k, _RUL_HIGH, dtype=np.float32)]),
            dtype=np.float32,
        )
        self.predictor, self.fields = predictor, tuple(fields)
        wear = fleet_env.config.wear  # type: ignore[attr-defined]
        atlas = fleet_env.atlas  # type: ignore[attr-defined]
        self.fresh_rul = float(route_wear_model(atlas, UNIFORM).life(wear.k_mean))
        self._est = np.full((self.n, len(fields)), self.fresh_rul)
        self._fleet: Fleet | None = None
        self._extra: dict[str, NDArray[np.float64]] = {}

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[NDArray[np.float32], dict[str, Any]]:
        obs, info = self.env.reset(seed=seed, options=options)
        if self._fleet is None:
            self._fleet = (
                self.predictor.fleet(self.n)  # type: ignore[attr-defined]
                if vectorises(self.predictor)
                else LoopFleet(self.predictor, self.n)
            )
        self._fleet.reset(np.arange(self.n))
        self._est[:] = self.fresh_rul
        self._extra = {}
        info["rul_estimate"] = self._info()
        return self.observation(obs), info

    def step(
        self, action: NDArray[np.int64]
    ) -> tuple[NDArray[np.float32], SupportsFloat, bool, bool, dict[str, Any]]:
        obs, reward, terminated, truncated, info = self.env.step(action)
        self._feed(info)
        info["rul_estimate"] = self._info()
        return self.observation(obs), reward, terminated, truncated, info

    def observation(self, observation: NDArray[np.float32]) -> NDArray[np.float32]:
        est = np.clip(self._est, 0.0, _RUL_HIGH).ravel()
        return np.concatenate([observation, est]).astype(np.float32, copy=False)

    def _feed(self, info: dict[str, Any]) -> None:
        base = self.env.unwrapped
        ev: ShiftEvents | None = base.shift_events()  # type: ignore[attr-defined]
        assert self._fleet is not None
        if ev is not None and ev.n_done.any():
            fresh = np.flatnonzero((ev.n_done > 0) & (ev.first_event == 0))
            if fresh.size:
                self._fleet.reset(fresh)
            rul = info["truth"].get("rul_hot")
            batch, vehicles = shift_batch(ev, rul)
            est = self._fleet.update(np.repeat(vehicles, ev.n_done[vehicles]), batch)
            self._store(est, vehicles)
        new = base.pads.pos == 0  # type: ignore[attr-defined]
        self._est[new] = self.fresh_rul
        for x in self._extra.values():
            x[new] = np.nan

    def _store(self, est: RULEstimate, vehicles: NDArray[np.intp]) -> None:
        self._check(est, vehicles)
        for i, f in enumerate(self.fields):
            x = getattr(est, f)
            # A point predictor (the oracle, the MLP) has no interval: its bounds are its
            # estimate, an interval of zero width.
            self._est[vehicles, i] = est.rul_mean if x is None else x
        for f in ("volume_frac", "wear_coeff"):
            x = getattr(est, f)
            if x is not None:
                self._extra.setdefault(f, np.full(self.n, np.nan))[vehicles] = x

    def _check(self, est: RULEstimate, vehicles: NDArray[np.intp]) -> None:
        """Refuse an estimate the observation cannot hold honestly: a NaN RUL or bound
        (outside the space; clipping does not mend it) or an interval not around its mean
        (lower > mean or mean > upper). Infinite RULs pass: they are clipped into
        [0, 1e7] events, as any wild extrapolation is."""
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
        out = {f: self._est[:, i].copy() for i, f in enumerate(self.fields)}
        out.update((k, v.copy()) for k, v in self._extra.items())
        return out


class ExpectedRULObservation(
    gym.ObservationWrapper[NDArray[np.float32], NDArray[np.int64], NDArray[np.float32]]
):
    """The oracle's RUL in closed form: appends, like
    :class:`FleetRULObservation`, each vehicle's RUL, here the
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
        require_env("ExpectedRULObservation", env, BrakeWearFleetEnv, ENV_ID)
        if not fields or any(f not in ESTIMATE_FIELDS for f in fields):
            raise ValueError(f"ExpectedRULObservation: fields must be among {ESTIMATE_FIELDS}")
        base = env.observation_space
        assert isinstance(base, spaces.Box)
        self.fields = tuple(fields)
        self.n = int(env.unwrapped.config.n_vehicles)  # type: ignore[attr-defined]
        self.wear = route_wear_model(env.unwrapped.atlas, HOT)  # type: ignore[attr-defined]
        k = len(fields) * self.n
        self.observation_space = spaces.Box(
            np.concatenate([base.low, np.zeros(k, dtype=np.float32)]),
            np.concatenate([base.high, np.full(k, _RUL_HIGH, dtype=np.float32)]),
            dtype=np.float32,
        )

    def rul(self) -> NDArray[np.float64]:
        """Each vehicle's expected hot-route RUL now [events]."""
        truth = self.env.unwrapped.truth()  # type: ignore[attr-defined]
        v = np.clip(truth["volume_frac"], self.wear.lower_edges[-1], 1.0)
        return self.wear.rul(v, truth["wear_coeff"])

    def observation(self, observation: NDArray[np.float32]) -> NDArray[np.float32]:
        est = np.repeat(np.clip(self.rul(), 0.0, _RUL_HIGH), len(self.fields))
        return np.concatenate([observation, est]).astype(np.float32)


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
