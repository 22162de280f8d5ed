"""Any RUL predictor as an observation wrapper of BrakeWear-v0: :class:`RULObservation`
for one env, :class:`RULVectorObservation` for its vector env (one fleet for all)."""

from __future__ import annotations

from typing import Any, SupportsFloat
from weakref import WeakKeyDictionary

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.vector import VectorEnv, VectorObservationWrapper
from gymnasium.vector.utils import batch_space
from numpy.typing import NDArray

from brake_env.env.brake_wear import BrakeWearEnv
from brake_env.env.pads import PadLife
from brake_env.env.shared import require_env
from brake_env.prognostics.fleet import (
    Fleet,
    LoopFleet,
    concat_events,
    one_per_event,
    vectorises,
)
from brake_env.prognostics.protocol import EventBatch, RULEstimate, RULPredictor

ESTIMATE_FIELDS = ("rul_mean", "rul_lower", "rul_upper")
_RUL_HIGH = 1e7  # events; clip so a wild extrapolation stays inside the space


class RULObservation(gym.ObservationWrapper[NDArray[np.float32], Any, NDArray[np.float32]]):
    """Append a predictor's RUL estimate (in braking events) to the observation.

    The predictor sees every event of every step (``info["events"]``), is reset whenever a
    pad is installed (a planned replacement, a failure, or the episode start: wherever the
    events' installation index restarts at 0), and the estimate after the step's last event
    is appended to the observation. A predictor with a fleet of its own
    (:meth:`~brake_env.prognostics.protocol.Predictor.fleet`, made at the first reset) is
    asked for that estimate only, not one per event. ``observation()`` only appends;
    ``reset``/``step`` are extended because the events arrive in ``info``, which
    ``observation()`` does not get.
    The latest estimate is also put in ``info["rul_estimate"]``.

    Args:
        env: BrakeWear-v0 (possibly wrapped).
        predictor: A fitted RUL predictor (:class:`brake_env.prognostics.protocol.RULPredictor`).
        fields: Which estimate fields to append: ``rul_mean`` and optionally ``rul_lower``,
            ``rul_upper`` (the predictor must give them).
        precompute: Run the predictor over each pad's whole simulated life once, when the
            pad is installed, and look the estimates up by pad age afterwards (kept per pad,
            so an episode replayed with the same seed and the env's ``cache_pads`` costs no
            predictor time at all). The observations are the same as without it for any
            causal predictor that gives the same estimates whatever the batch sizes (the
            protocol's contract; tested for every predictor). Needs a bare BrakeWear-v0
            underneath.
        estimate_cache: The per-pad store of precomputed estimates, to share between
            wrappers of the same (fitted) predictor; default a new one.
    """

    def __init__(
        self,
        env: gym.Env[NDArray[np.float32], Any],
        predictor: RULPredictor,
        fields: tuple[str, ...] = ("rul_mean",),
        precompute: bool = False,
        estimate_cache: WeakKeyDictionary[PadLife, RULEstimate] | None = None,
    ) -> None:
        super().__init__(env)
        require_env("RULObservation", env, BrakeWearEnv, "BrakeWear-v0")
        self.observation_space = _with_estimates("RULObservation", env.observation_space, fields)
        self.predictor = predictor
        self.fields = tuple(fields)
        self._estimate = np.zeros(len(fields), dtype=np.float32)
        self.precompute = precompute
        self._lives: WeakKeyDictionary[PadLife, RULEstimate] = (
            WeakKeyDictionary() if estimate_cache is None else estimate_cache
        )
        self._fleet: Fleet | None = None

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[NDArray[np.float32], dict[str, Any]]:
        obs, info = self.env.reset(seed=seed, options=options)
        self._feed(info)
        return self.observation(obs), info

    def step(
        self, action: Any
    ) -> tuple[NDArray[np.float32], SupportsFloat, bool, bool, dict[str, Any]]:
        obs, reward, terminated, truncated, info = self.env.step(action)
        self._feed(info)
        return self.observation(obs), reward, terminated, truncated, info

    def observation(self, observation: NDArray[np.float32]) -> NDArray[np.float32]:
        return np.concatenate([observation, self._estimate]).astype(np.float32, copy=False)

    def _feed(self, info: dict[str, Any]) -> None:
        if self.precompute:
            base = self.env.unwrapped
            pad: PadLife = base.installed_pad  # type: ignore[attr-defined]
            if pad not in self._lives:
                self.predictor.reset()
                events = pad.events()
                est = self.predictor.update(events)
                self._lives[pad] = one_per_event(est, len(events), self.predictor)
            est = self._lives[pad]
            at = base.pad_age - 1  # type: ignore[attr-defined]
        else:
            est, at = self._latest(info["events"]), -1
        np.clip(_values(est, self.fields, self.predictor, at), 0.0, _RUL_HIGH, out=self._estimate)
        info["rul_estimate"] = _at(est, at)

    def _latest(self, events: EventBatch) -> RULEstimate:
        """The estimate after the step's events (of the installed pad), last one last."""
        events, fresh = _installed(events)
        if self._fleet is None and vectorises(self.predictor):
            self._fleet = self.predictor.fleet(1)  # type: ignore[attr-defined]
        if self._fleet is None:
            if fresh:
                self.predictor.reset()
            return one_per_event(self.predictor.update(events), len(events), self.predictor)
        if fresh:
            self._fleet.reset(0)
        return self._fleet.update(np.zeros(len(events), dtype=np.intp), events)


class RULVectorObservation(
    VectorObservationWrapper[NDArray[np.float32], Any, NDArray[np.float32], Any]
):
    """:class:`RULObservation` for a vector env of BrakeWear-v0 (``gym.make_vec`` or a
    ``SyncVectorEnv``), with one fleet of the predictor for all sub-environments.

    After each step the events of every sub-environment go into one fleet update, which is
    asked for each sub-environment's estimate after its last event only; a slot is reset
    where a pad is installed. The observations equal those of one :class:`RULObservation`
    per sub-environment (tested). The estimates are also in ``infos["rul_estimate"]`` (a
    dict of arrays over the sub-environments).

    Args:
        env: The vector env; each step's infos carry every sub-environment's ``events``.
        predictor: A fitted RUL predictor (its own fleet made at the first reset; any other
            runs as one copy per sub-environment).
        fields: As :class:`RULObservation`.
    """

    def __init__(
        self,
        env: VectorEnv[NDArray[np.float32], Any, Any],
        predictor: RULPredictor,
        fields: tuple[str, ...] = ("rul_mean",),
    ) -> None:
        super().__init__(env)
        self.single_observation_space = _with_estimates(
            "RULVectorObservation", env.single_observation_space, fields
        )
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.predictor = predictor
        self.fields = tuple(fields)
        self._estimates = np.zeros((self.num_envs, len(fields)), dtype=np.float32)
        self._fleet: Fleet | None = None

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[NDArray[np.float32], dict[str, Any]]:
        obs, infos = self.env.reset(seed=seed, options=options)
        self._feed(infos)
        return self.observations(obs), infos

    def step(self, actions: Any) -> tuple[NDArray[np.float32], Any, Any, Any, dict[str, Any]]:
        obs, rewards, terminations, truncations, infos = self.env.step(actions)
        self._feed(infos)
        return self.observations(obs), rewards, terminations, truncations, infos

    def observations(self, observations: NDArray[np.float32]) -> NDArray[np.float32]:
        return np.concatenate([observations, self._estimates], axis=1).astype(np.float32)

    def _feed(self, infos: dict[str, Any]) -> None:
        if self._fleet is None:
            self._fleet = (
                self.predictor.fleet(self.num_envs)  # type: ignore[attr-defined]
                if vectorises(self.predictor)
                else LoopFleet(self.predictor, self.num_envs)
            )
        envs = np.flatnonzero(infos.get("_events", np.zeros(self.num_envs, dtype=bool)))
        if envs.size == 0:
            return
        parts = []
        for i in envs:
            events, fresh = _installed(infos["events"][i])
            if fresh:
                self._fleet.reset(i)
            parts.append(events)
        pads = np.repeat(envs, [len(p) for p in parts])
        est = self._fleet.update(pads, concat_events(parts))  # each env's last event
        values = _values(est, self.fields, self.predictor, slice(None))
        self._estimates[envs] = np.clip(values, 0.0, _RUL_HIGH)
        mask = np.zeros(self.num_envs, dtype=bool)
        mask[envs] = True
        infos["rul_estimate"], infos["_rul_estimate"] = _by_env(est, envs, self.num_envs), mask


def _with_estimates(
    who: str, base: Any, fields: tuple[str, ...]
) -> spaces.Space[NDArray[np.float32]]:
    """``base`` (a 1-D Box) with one bounded entry per estimate field appended."""
    bad = [f for f in fields if f not in ESTIMATE_FIELDS]
    if bad or not fields:
        raise ValueError(f"{who}: fields must be among {ESTIMATE_FIELDS}, got {fields}")
    if not isinstance(base, spaces.Box) or len(base.shape) != 1:
        raise ValueError(f"{who} needs a 1-D Box observation, got {base}")
    n = len(fields)
    return spaces.Box(
        np.concatenate([base.low, np.zeros(n, dtype=np.float32)]),
        np.concatenate([base.high, np.full(n, _RUL_HIGH, dtype=np.float32)]),
        dtype=np.float32,
    )


def _installed(events: EventBatch) -> tuple[EventBatch, bool]:
    """The events of the pad installed last, and whether it was installed during them
    (its events start where the installation index restarts at 0)."""
    fresh = np.flatnonzero(events.event == 0)
    return (events[int(fresh[-1]) :], True) if fresh.size else (events, False)


def _values(
    est: RULEstimate, fields: tuple[str, ...], predictor: RULPredictor, rows: int | slice
) -> NDArray[Any]:
    """The estimate's ``fields`` at ``rows``, stacked on the last axis."""
    cols = []
    for f in fields:
        x = getattr(est, f)
        if x is None:
            raise ValueError(f"RULObservation: predictor {predictor.name!r} gives no {f}")
        cols.append(x[rows])
    return np.stack(cols, axis=-1)


def _by_env(est: RULEstimate, envs: NDArray[np.intp], n: int) -> dict[str, NDArray[np.float64]]:
    """Each estimate field as an array over ``n`` sub-environments (NaN where none)."""
    out = {}
    for name in ("rul_mean", "rul_lower", "rul_upper", "volume_frac", "wear_coeff"):
        x = getattr(est, name)
        if x is not None:
            out[name] = np.full(n, np.nan)
            out[name][envs] = x
    return out


def _at(est: RULEstimate, i: int) -> dict[str, float]:
    """The estimate after event ``i``, as plain floats (missing fields left out)."""
    out = {}
    for name in ("rul_mean", "rul_lower", "rul_upper", "volume_frac", "wear_coeff"):
        x = getattr(est, name)
        if x is not None:
            out[name] = float(x[i])
    return out
