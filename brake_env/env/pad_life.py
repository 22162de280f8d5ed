"""A pad's life, simulated as the environment uses it (docs/environments.md).

A replacement should cost what the pad is used for, not its whole life. A :class:`PadLife`
simulates its events a block at a time (about one atlas layer, at most
``brake_env.model.simulator.BLOCK_MAX`` events) when they are asked for, with their sensor
noise. The blocks and the random streams are those of the whole-life simulation, so the
events are bit for bit those of :func:`simulate_pad` (tested).

The end of life (and so the true RUL) is known only once the pad has been simulated to
failure: :attr:`PadLife.n_events` simulates ahead on a copy of the same stream when it is
asked for (with ``truth``, the first time the env's truth is read).

Memory stays bounded whatever K: a pad keeps its events from installation up to
``BUFFER_EVENTS``, so a pad replayed from a cache, or looked at twice, is simulated once;
past that only the events from the latest request on are kept, and an event asked for
again after it was dropped is simulated again from installation.
"""

from __future__ import annotations

import sys
from typing import Any

import numpy as np

from brake_env.env.atlases import default_atlas, shared_atlas_key
from brake_env.env.config import EnvConfig
from brake_env.env.lazy_truth import PendingRULEvents
from brake_env.model.atlas import Atlas
from brake_env.model.simulator import F64, Block, Runs
from brake_env.model.streams import NoiseStreams
from brake_env.model.wear import WearModel
from brake_env.prognostics.protocol import MEASURED, EventBatch

BUFFER_EVENTS = 1 << 19  # ~29 MB of events, more than any pad's life at the default K range
_RUN = np.zeros(1, dtype=np.intp)  # the one run of a pad's Runs


class PadLife:
    """One pad, from installation to failure, simulated as its events are asked for.

    Args:
        atlas: The atlas to run through.
        config: The env's config (sensor noise, layer blending, ``truth``).
        wear_coeff: Its Archard coefficient K [-].
        label: Its wear regime, ``id``, ``ood-slow`` or ``ood-fast``.
        seed: Spawns its operating-condition and sensor-noise streams (see
            :func:`~brake_env.env.pads.simulate_pad`).

    Attributes:
        wear_coeff: Its K [-].
        label: Its wear regime.
        truth: Whether its events carry the true RUL (``rul_events``).
    """

    def __init__(
        self,
        atlas: Atlas,
        config: EnvConfig,
        wear_coeff: float,
        label: str,
        seed: np.random.SeedSequence,
    ) -> None:
        cond_seed, noise_seed = seed.spawn(2)
        self.wear_coeff, self.label, self.truth = wear_coeff, label, config.truth
        # The seeds, to simulate dropped events again from installation.
        self._origin = (atlas, config, cond_seed, noise_seed.spawn(len(MEASURED)))
        self._life: int | None = None
        self._start_over()

    @classmethod
    def whole(
        cls,
        wear_coeff: float,
        label: str,
        measured: F64,
        volume_frac: F64,
        final_volume_frac: float,
        truth: bool = True,
    ) -> PadLife:
        """A pad simulated whole beforehand: ``measured`` (6, n), rows in ``MEASURED`` order,
        ``volume_frac`` at the start of each event, ``final_volume_frac`` after the last."""
        pad = cls.__new__(cls)
        pad.wear_coeff, pad.label, pad.truth = wear_coeff, label, truth
        pad._runs = pad._noise = None
        pad._life = len(volume_frac)
        pad._set_rows(0, measured, volume_frac, len(volume_frac))
        pad._vol_end = final_volume_frac
        return pad

    # ------------------------------------------------------------------ what is known
    @property
    def life(self) -> int | None:
        """Events of its life if already known (simulated to failure), else None."""
        return self._life

    @property
    def n_events(self) -> int:
        """Events the pad completes; after the last one it can no longer stop the vehicle.

        Simulates ahead if not known yet: the events up to ``BUFFER_EVENTS`` are kept
        (the env will serve them), the rest only counted on a copy of the stream.
        """
        if self._life is None:
            if self._n == 0:  # room for its expected life at once, rather than doubling
                expected = WearModel.from_atlas(self._origin[0]).life(self.wear_coeff)
                self._regrow(0, min(int(1.1 * expected) + 1000, BUFFER_EVENTS))
            self._fill(self._lo, max(self._hi, BUFFER_EVENTS))
        if self._life is None:
            assert self._runs is not None
            runs = self._runs.clone()
            while not runs.done[0]:
                runs.advance(_RUN, response=False)
            self._life = int(runs.pos[0])
        return self._life

    @property
    def life_of(self) -> LifeOf:
        """:attr:`n_events` as a callable that copies and pickles without simulating: what
        the lazy truth (:mod:`brake_env.env.lazy_truth`) holds. A new one each time: kept
        on the pad, it would make a reference cycle that keeps a retired pad's buffers
        alive until the garbage collector runs."""
        return LifeOf(self)

    def available(self, start: int, n: int) -> int:
        """How many of events ``start`` to ``start + n - 1`` the pad completes (simulating
        them): n, or fewer if it reaches the end of its life first."""
        self._fill(start, start + n)
        return max(min(self._hi, start + n) - start, 0)

    def events(self, start: int = 0, stop: int | None = None) -> EventBatch:
        """Events ``start`` to ``stop`` (default: to the end of life) with ground truth:
        ``volume_frac`` and ``wear_coeff``, and ``rul_events`` if the pad has ``truth``
        (computed when first read if the end of life is not simulated yet:
        :mod:`brake_env.env.lazy_truth`)."""
        self._fill(start, sys.maxsize if stop is None else stop)
        b = self._hi if stop is None else stop
        if not self._lo <= start <= b <= self._hi:
            raise ValueError(f"PadLife.events: no events {start} to {b} in a life of {self._hi}")
        i, j = start - self._lo, b - self._lo
        cols: dict[str, Any] = {"event": np.arange(start, b)}
        cols.update(zip(MEASURED, self._measured[:, i:j], strict=True))
        cols["volume_frac"] = self._volume[i:j]
        cols["wear_coeff"] = np.full(b - start, self.wear_coeff)
        if self.truth and self._life is None:  # simulated ahead when first read
            return PendingRULEvents.of(cols, self.life_of, start)
        if self.truth:
            life = self.n_events
            cols["rul_events"] = np.arange(life - 1 - start, life - 1 - b, -1)
        return EventBatch(**cols)

    def measured_at(self, event: int) -> F64:
        """Measured channels of an event served last (``MEASURED`` order)."""
        return self._measured[:, event - self._lo]

    def volume_after(self, event: int) -> float:
        """True volume after an event served [-]."""
        if event + 1 < self._hi:
            return float(self._volume[event + 1 - self._lo])
        if event + 1 == self._hi:
            return self._vol_end
        raise ValueError(f"PadLife.volume_after: event {event} is not simulated yet")

    # ------------------------------------------------------------------ simulation
    def _set_rows(self, lo: int, measured: F64, volume: F64, n: int) -> None:
        """Columns 0 to n - 1 of ``measured`` and ``volume`` hold events ``lo`` to
        ``_hi - 1``."""
        self._lo, self._measured, self._volume, self._n = lo, measured, volume, n
        self._hi = lo + n

    def _regrow(self, first: int, cap: int) -> None:
        """Move the events from row ``first`` on into new arrays of ``cap`` rows."""
        n = self._n
        measured, volume = np.empty((len(MEASURED), cap)), np.empty(cap)
        measured[:, : n - first], volume[: n - first] = (
            self._measured[:, first:n],
            self._volume[first:n],
        )
        self._set_rows(self._lo + first, measured, volume, n - first)

    def _start_over(self) -> None:
        """Back to installation: nothing simulated, the streams at their start."""
        atlas, config, cond_seed, noise_seeds = self._origin
        self._runs: Runs | None = Runs(
            atlas, [self.wear_coeff], [cond_seed], config.interpolate_layers
        )
        self._noise: NoiseStreams | None = NoiseStreams(config.noise, noise_seeds)
        self._set_rows(0, np.empty((len(MEASURED), 0)), np.empty(0), 0)
        self._vol_end = 1.0  # volume after the last event simulated

    def _fill(self, start: int, stop: int) -> None:
        """Simulate until event ``stop - 1`` (or the end of life), keeping events from
        ``start`` on."""
        if start < self._lo:  # dropped: simulate again from installation
            self._start_over()
        while self._hi < stop and self._runs is not None and not self._runs.done[0]:
            (block,) = self._runs.advance(_RUN)
            self._append(block, start)
            if self._runs.done[0]:
                self._life = self._hi

    def _append(self, block: Block, keep_from: int) -> None:
        """Measure a block and store it. Rows handed out (views in earlier EventBatches)
        are never overwritten: the store grows, or drops its oldest rows, into new arrays."""
        c = len(block.speed_mps)
        if self._n + c > len(self._volume):
            first = 0
            if self._n + c > BUFFER_EVENTS:  # full: the events before the request can go
                first = min(max(keep_from - self._lo, 0), self._n)
            keep = self._n - first
            self._regrow(first, max(min(2 * len(self._volume), BUFFER_EVENTS), keep + c))
        n = self._n
        assert block.temp_mean_c is not None and block.stop_dist_m is not None
        assert self._noise is not None and self._runs is not None
        self._noise.measure(
            block.speed_mps,
            block.mass_kg,
            block.slope_rad,
            block.temp_mean_c,
            block.stop_dist_m,
            list(self._measured[:, n : n + c]),
        )
        self._volume[n : n + c] = block.volume_frac
        self._n += c
        self._hi += c
        self._vol_end = float(self._runs.vol[0])


class LifeOf:
    """A pad's :attr:`PadLife.n_events`, simulated when called, never when copied.

    A deep copy is this object itself: the copy's truth, when read, reads the same pad
    (which is then simulated once for both). A pickle holds what the life is a function of
    (the pad's K, config and seeds, and the atlas, by its key if it is a shared one:
    :mod:`brake_env.env.atlases`), or the life itself once known; unpickled, it simulates
    a new pad of those seeds when called, which gives the same life (the same code on the
    same streams).
    """

    __slots__ = ("_pad",)

    def __init__(self, pad: PadLife) -> None:
        self._pad = pad

    def __call__(self) -> int:
        return self._pad.n_events

    def __deepcopy__(self, memo: dict[int, Any]) -> LifeOf:
        return self

    def __reduce__(self) -> tuple[Any, ...]:
        pad = self._pad
        if pad.life is not None:
            return (_known_life, (pad.life,))
        atlas, config, cond_seed, noise_seeds = pad._origin
        key = shared_atlas_key(atlas)
        seeds = (cond_seed, noise_seeds)
        return (_life_of_seeds, (key, None if key else atlas, config, pad.wear_coeff, seeds))


class _KnownLife:
    __slots__ = ("life",)

    def __init__(self, life: int) -> None:
        self.life = life

    def __call__(self) -> int:
        return self.life


def _known_life(life: int) -> _KnownLife:
    return _KnownLife(life)


def _life_of_seeds(
    key: tuple[str, str | None] | None,
    atlas: Atlas | None,
    config: EnvConfig,
    wear_coeff: float,
    seeds: tuple[np.random.SeedSequence, list[np.random.SeedSequence]],
) -> LifeOf:
    """An unpickled :class:`LifeOf`: a new pad on the same streams, not simulated yet."""
    if atlas is None:
        assert key is not None
        atlas = default_atlas(*key)
    pad = PadLife.__new__(PadLife)
    pad.wear_coeff, pad.label, pad.truth = wear_coeff, "", config.truth
    pad._origin = (atlas, config, *seeds)
    pad._life = None
    pad._start_over()
    return pad.life_of
