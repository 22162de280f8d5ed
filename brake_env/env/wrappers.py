"""RULObservation: any RUL predictor as an observation wrapper of BrakeWear-v0."""

from __future__ import annotations

from typing import Any, SupportsFloat
from weakref import WeakKeyDictionary

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from brake_env.env.pads import PadLife
from brake_env.prognostics.protocol import EventBatch, RULEstimate, RULPredictor

ESTIMATE_FIELDS = ("rul_mean", "rul_lower", "rul_upper")
_RUL_HIGH = 1e7  # events; clip so a wild extrapolation stays inside the space


class RULObservation(gym.ObservationWrapper[NDArray[np.float32], Any, NDArray[np.float32]]):
    """Append a predictor's RUL estimate (in braking events) to the observation.

    The predictor sees every event of every step (``info["events"]``), is reset whenever a
    pad is installed (a planned replacement, a failure, or the episode start: wherever the
    events' installation index restarts at 0), and the estimate after the step's last event
    is appended to the observation. ``observation()`` only appends; ``reset``/``step`` are
    extended because the events arrive in ``info``, which ``observation()`` does not get.
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
        bad = [f for f in fields if f not in ESTIMATE_FIELDS]
        if bad or not fields:
            raise ValueError(
                f"RULObservation: fields must be among {ESTIMATE_FIELDS}, got {fields}"
            )
        base = env.observation_space
        if not isinstance(base, spaces.Box) or len(base.shape) != 1:
            raise ValueError(f"RULObservation needs a 1-D Box observation, got {base}")
        self.predictor = predictor
        self.fields = tuple(fields)
        n = len(fields)
        self.observation_space = spaces.Box(
            np.concatenate([base.low, np.zeros(n, dtype=np.float32)]),
            np.concatenate([base.high, np.full(n, _RUL_HIGH, dtype=np.float32)]),
            dtype=np.float32,
        )
        self._estimate = np.zeros(n, dtype=np.float32)
        self.precompute = precompute
        self._lives: WeakKeyDictionary[PadLife, RULEstimate] = (
            WeakKeyDictionary() if estimate_cache is None else estimate_cache
        )

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
                self._lives[pad] = self.predictor.update(pad.events())
            est = self._lives[pad]
            at = base.pad_age - 1  # type: ignore[attr-defined]
        else:
            events: EventBatch = info["events"]
            fresh = np.flatnonzero(events.event == 0)
            if fresh.size:  # a pad was installed in this step: its events start there
                self.predictor.reset()
                events = events[int(fresh[-1]) :]
            est, at = self.predictor.update(events), -1
        values = []
        for f in self.fields:
            x = getattr(est, f)
            if x is None:
                raise ValueError(f"RULObservation: predictor {self.predictor.name!r} gives no {f}")
            values.append(x[at])
        np.clip(values, 0.0, _RUL_HIGH, out=self._estimate)
        info["rul_estimate"] = _at(est, at)


def _at(est: RULEstimate, i: int) -> dict[str, float]:
    """The estimate after event ``i``, as plain floats (missing fields left out)."""
    out = {}
    for name in ("rul_mean", "rul_lower", "rul_upper", "volume_frac", "wear_coeff"):
        x = getattr(est, name)
        if x is not None:
            out[name] = float(x[i])
    return out
