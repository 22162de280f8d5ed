"""One vehicle's brake over an episode: pads installed, their events served, costs counted.

This is the whole transition logic of BrakeWear-v0. The single env drives one
:class:`PadService`; the vector env drives one per sub-environment, so the logic exists once.

Actions cannot change how a pad wears (the operating conditions do not depend on them), so
a pad's events are a function of its K and its random stream: a :class:`PadLife` simulates
them as they are served, a block at a time, and simulates ahead to failure only where the
config asks for the true RUL (``truth``).
"""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from brake_env.env.config import EnvConfig
from brake_env.env.lazy_truth import LazyTruth, Life
from brake_env.env.pad_life import PadLife
from brake_env.model.atlas import Atlas
from brake_env.model.simulator import simulate_runs
from brake_env.model.streams import NoiseStreams
from brake_env.prognostics.protocol import MEASURED, TRUTH, EventBatch

__all__ = ["COST_TERMS", "PadLife", "PadService", "RetiredPad", "simulate_pad"]

COST_TERMS = ("planned_replacement", "corrective_replacement", "downtime", "damage", "revenue")


@dataclass(frozen=True)
class RetiredPad:
    """A pad taken off in a step (an entry of ``info["retired"]``).

    Attributes:
        life_left: Events of life it still had [events]; 0 for a pad that failed; None
            for a planned replacement in an env without ``truth``.
        life: Events of its whole life [events]; None where ``life_left`` is.
        regime: Its wear regime, ``id``, ``ood-slow`` or ``ood-fast``.
    """

    life_left: int | None
    life: int | None
    regime: str

    @property
    def failed(self) -> bool:
        """It was taken off by a brake failure, not by a planned replacement."""
        return self.life_left == 0


class _PendingRetiredPad(RetiredPad):
    """A pad taken off by a planned replacement in an env with ``truth`` whose end of life
    is not simulated yet: ``life_left`` and ``life`` are simulated when first read
    (:mod:`brake_env.env.lazy_truth`), not when copied or pickled."""

    @classmethod
    def of(cls, life: Life, pos: int, regime: str) -> _PendingRetiredPad:
        """The pad whose events to failure ``life`` gives, taken off after ``pos`` events."""
        obj = object.__new__(cls)
        object.__setattr__(obj, "regime", regime)
        object.__setattr__(obj, "_life_of", life)
        object.__setattr__(obj, "_pos", pos)
        object.__setattr__(obj, "_life", None)
        return obj

    def _resolve(self) -> int:
        if self.__dict__["_life"] is None:
            object.__setattr__(self, "_life", self.__dict__["_life_of"]())
            object.__setattr__(self, "_life_of", None)  # the pad may go
        life: int = self.__dict__["_life"]
        return life

    @property
    def life_left(self) -> int:
        return self._resolve() - self.__dict__["_pos"]

    @property
    def life(self) -> int:
        return self._resolve()

    def __eq__(self, other: object) -> bool:
        """Equal to any RetiredPad of the same values (pending or not)."""
        if not isinstance(other, RetiredPad):
            return NotImplemented
        return (self.life_left, self.life, self.regime) == (
            other.life_left,
            other.life,
            other.regime,
        )

    __hash__ = RetiredPad.__hash__

    def __deepcopy__(self, memo: dict[int, Any]) -> RetiredPad:
        return self.__copy__()

    def __copy__(self) -> RetiredPad:
        """Still pending (sharing ``life``) if this one is; immutable values otherwise."""
        if self.__dict__["_life"] is not None:
            return RetiredPad(self.life_left, self.life, self.regime)
        return _PendingRetiredPad.of(self.__dict__["_life_of"], self.__dict__["_pos"], self.regime)

    def __reduce__(self) -> tuple[Any, ...]:
        """Pickled pending (``life`` pickled, not called); as a plain RetiredPad once read."""
        if self.__dict__["_life"] is not None:
            return (RetiredPad, (self.life_left, self.life, self.regime))
        d = self.__dict__
        return (_PendingRetiredPad.of, (d["_life_of"], d["_pos"], self.regime))


def simulate_pad(
    atlas: Atlas, config: EnvConfig, wear_coeff: float, label: str, seed: np.random.SeedSequence
) -> PadLife:
    """One pad's whole life at once (:func:`simulate_runs` and its sensor noise); a
    streamed :class:`PadLife` of the same arguments gives the same events. ``seed`` spawns
    the operating-condition and the sensor-noise streams, as
    :func:`brake_env.data.datasets.seeded_plan` does for a dataset run (the same
    conditions and truth; the noise is drawn per channel, :mod:`brake_env.model.streams`)."""
    cond_seed, noise_seed = seed.spawn(2)
    (t,) = simulate_runs(atlas, [wear_coeff], [cond_seed], None, config.interpolate_layers)
    measured = np.empty((len(MEASURED), t.n_events))
    noise = NoiseStreams(config.noise, noise_seed.spawn(len(MEASURED)))
    noise.measure(t.speed_mps, t.mass_kg, t.slope_rad, t.temp_mean_c, t.stop_dist_m, list(measured))
    return PadLife.whole(
        wear_coeff, label, measured, t.volume_frac, t.final_volume_frac, config.truth
    )


_POOL: dict[tuple[Any, ...], PadLife] = {}


def _pool_pad(atlas: Atlas, config: EnvConfig, index: int) -> PadLife:
    """Pad ``index`` of the config's pool, made on first use and kept for the process (with
    the events simulated so far)."""
    key = (
        atlas.content_hash,
        config.pad_regime,
        config.noise,
        config.interpolate_layers,
        config.truth,
        config.pad_pool_seed,
        config.pad_pool,
        index,
    )
    if key not in _POOL:
        rng = np.random.default_rng([config.pad_pool_seed, config.pad_pool])
        draws = [(*config.pad_regime.draw(rng), int(rng.integers(2**63))) for _ in range(index + 1)]
        k, label, entropy = draws[index]
        _POOL[key] = PadLife(atlas, config, k, label, np.random.SeedSequence(entropy))
    return _POOL[key]


class PadService:
    """Installs pads, serves braking events and counts the cost terms of one vehicle.

    A failure happens when an event needs a pad that has completed all the events of its
    life: a corrective replacement is forced and that event is braked on the new pad, so a
    step always ends with at least one event on the installed pad.
    """

    def __init__(self, atlas: Atlas, config: EnvConfig) -> None:
        self.atlas = atlas
        self.config = config
        self.regime = config.pad_regime
        w = config.costs
        self._planned = {"planned_replacement": w.planned_replacement}
        self._failure = {
            "corrective_replacement": w.corrective_replacement,
            "downtime": w.downtime,
            "damage": w.damage,
        }
        self.pad: PadLife | None = None
        self.pos = 0  # events the installed pad has completed
        # Pads are a pure function of (K, seed): with cache_pads > 0, the last pads made
        # are kept, so episodes replayed with the same seed (policy comparisons, threshold
        # tuning) simulate each pad once.
        self._cache: OrderedDict[tuple[float, int], PadLife] = OrderedDict()
        self.events_done = 0  # events of the episode so far

    # ------------------------------------------------------------------ transitions
    def start(self, rng: np.random.Generator) -> dict[str, Any]:
        """Begin an episode: a new pad, and its first event. Returns the info dict."""
        self.rng = rng
        self.events_done = 0
        self._install()
        return self._serve(1, replaced=False)

    def step(self, replace: bool) -> dict[str, Any]:
        """Replace the pad first if asked, then serve the step's events. Returns the info."""
        n = min(self.config.decision_interval, self.config.episode_events - self.events_done)
        if n <= 0:
            raise RuntimeError("BrakeWear-v0: the episode is over; call reset()")
        return self._serve(n, replaced=replace)

    @property
    def truncated(self) -> bool:
        return self.events_done >= self.config.episode_events

    def observation(self) -> NDArray[np.float32]:
        """Latest measured event and events since installation."""
        assert self.pad is not None
        obs = np.empty(len(MEASURED) + 1, dtype=np.float32)
        obs[:-1] = self.pad.measured_at(self.pos - 1)
        obs[-1] = self.pos
        return obs

    # ------------------------------------------------------------------ internals
    def _install(self) -> None:
        # With ``truth`` the pad's life is simulated ahead only when the truth is first
        # read (brake_env.env.lazy_truth): exploration that never reads it never pays it.
        self.pad, self.pos = self._new_pad(), 0

    def _new_pad(self) -> PadLife:
        if self.config.pad_pool:
            return _pool_pad(self.atlas, self.config, int(self.rng.integers(self.config.pad_pool)))
        k, label = self.regime.draw(self.rng)
        entropy = int(self.rng.integers(2**63))
        pad = self._cache.get((k, entropy))
        if pad is None:
            pad = PadLife(self.atlas, self.config, k, label, np.random.SeedSequence(entropy))
            if self.config.cache_pads:
                self._cache[(k, entropy)] = pad
                while len(self._cache) > self.config.cache_pads:
                    self._cache.popitem(last=False)
        else:
            self._cache.move_to_end((k, entropy))
        return pad

    def _retire(self, failed: bool = False) -> RetiredPad:
        """The installed pad's record as it is taken off, before the next is installed."""
        pad = self.pad
        assert pad is not None
        if failed:  # it braked all its life
            return RetiredPad(0, self.pos, pad.label)
        if not self.config.truth:
            return RetiredPad(None, None, pad.label)
        if pad.life is None:
            return _PendingRetiredPad.of(pad.life_of, self.pos, pad.label)
        return RetiredPad(pad.n_events - self.pos, pad.n_events, pad.label)

    def _serve(self, n: int, replaced: bool) -> dict[str, Any]:
        costs = dict.fromkeys(COST_TERMS, 0.0)
        retired: list[RetiredPad] = []  # each pad taken off in the step, in order
        if replaced:
            retired.append(self._retire())
            costs.update(self._planned)
            self._install()
        segments = []  # each pad's events of the step, in service order
        failures, left = 0, n
        while left:
            assert self.pad is not None
            take = self.pad.available(self.pos, left)
            if take == 0:  # the next event needs a pad that has no life left: failure
                failures += 1
                retired.append(self._retire(failed=True))
                for key, value in self._failure.items():
                    costs[key] += value
                self._install()
                continue
            segments.append(self.pad.events(self.pos, self.pos + take))
            self.pos += take
            left -= take
        self.events_done += n
        costs["revenue"] = n * self.config.costs.revenue
        return self._info(segments, costs, replaced, failures, retired)

    def _info(
        self,
        segments: list[EventBatch],
        costs: dict[str, float],
        replaced: bool,
        failures: int,
        retired: list[RetiredPad],
    ) -> dict[str, Any]:
        pad = self.pad
        assert pad is not None
        life = pad.life if self.config.truth else None
        truth = {
            "volume_frac": pad.volume_after(self.pos - 1),
            "wear_coeff": pad.wear_coeff,
            "rul_events": None if life is None else life - self.pos,
            "life_events": life,
            "regime": pad.label,
        }
        return {
            "events": _event_columns(segments),
            "costs": costs,
            "replaced": replaced,
            "failures": failures,
            "pads_retired": len(retired),
            "retired": retired,
            "truth": LazyTruth(truth, pad.life_of, self.pos)
            if self.config.truth and life is None
            else truth,
        }


def _event_columns(parts: list[EventBatch]) -> EventBatch:
    """The step's events: views of the pad's arrays, unless a failure split the step between
    two pads. An EventBatch, not a dict, so vector envs keep each sub-env's batch whole
    instead of stacking arrays whose lengths differ between sub-envs."""
    if len(parts) == 1:
        return parts[0]
    merged: dict[str, Any] = {
        k: None if getattr(parts[0], k) is None else np.concatenate([getattr(p, k) for p in parts])
        for k in ("event", *MEASURED, *TRUTH)
    }
    return EventBatch(**merged)
