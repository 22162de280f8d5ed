"""The random streams of one run: operating conditions and sensor noise, drawn in pieces.

The environment simulates a pad a block of events at a time, as it serves them; its events
must be bit for bit those of the pad simulated whole. Each stream here is therefore drawn
in event order, so where it is cut into pieces does not change a single number: uniform
conditions come from one generator filled in order (the datasets' runs use the same), and
each sensor channel has a generator of its own, so a channel's noise for event k is its
k-th draw however many events were measured at once. (A dataset's logs draw their noise
channel after channel from one generator, :func:`brake_env.data.datasets.measure`, which
needs the whole run at once; the statistics are the same.)
"""

from __future__ import annotations

import copy
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from brake_env._validate import check_nonnegative, plain_numbers

F64 = NDArray[np.float64]
# Measured channels in the order of the event-log schema and of the env's observation.
SENSOR_CHANNELS = ("speed_kmh", "mass_kg", "slope_rad", "energy_j", "temp_c", "stop_dist_m")
_CHUNK_MIN, _CHUNK_MAX = 1024, 16_384  # events of conditions drawn at a time


@dataclass(frozen=True)
class SensorNoise:
    """Standard deviations of additive Gaussian sensor noise (paper 2.1.1: about 5% of scale).

    Attributes:
        temp_c: Brake temperature [K].
        stop_dist_m: Stopping distance [m]; readings are floored at 0 (a distance is never
            negative).
        energy_j: Kinetic energy at brake onset [J].
        slope_rad: Road slope [rad].
        speed_kmh: Wheel speed [km/h]; the paper gives none, so 0.
        mass_kg: Vehicle mass [kg]; the paper gives none, so 0.
    """

    temp_c: float = 5.0
    stop_dist_m: float = 1.0
    energy_j: float = 2000.0
    slope_rad: float = 0.01
    speed_kmh: float = 0.0
    mass_kg: float = 0.0

    def __post_init__(self) -> None:
        plain_numbers(self)
        check_nonnegative(
            self, "temp_c", "stop_dist_m", "energy_j", "slope_rad", "speed_kmh", "mass_kg"
        )

    @classmethod
    def none(cls) -> SensorNoise:
        return cls(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


class NoiseStreams:
    """What the sensors log for a run's events, measured in order in any number of pieces.

    Each channel (``SENSOR_CHANNELS`` order) draws from a generator of its own, seeded by
    one of ``seeds`` (drawn only when its noise is > 0), so the same seeds give the same
    noise however the events are split.

    Args:
        noise: The standard deviations.
        seeds: One per channel (``SeedSequence.spawn`` of the run's noise seed).
    """

    def __init__(self, noise: SensorNoise, seeds: Sequence[np.random.SeedSequence]) -> None:
        if len(seeds) != len(SENSOR_CHANNELS):
            raise ValueError(f"NoiseStreams: give {len(SENSOR_CHANNELS)} seeds, got {len(seeds)}")
        self.sigmas = tuple(float(getattr(noise, c)) for c in SENSOR_CHANNELS)
        self.rngs = [
            np.random.default_rng(s) if sigma > 0 else None
            for s, sigma in zip(seeds, self.sigmas, strict=True)
        ]

    def measure(
        self,
        speed_mps: F64,
        mass_kg: F64,
        slope_rad: F64,
        temp_c: F64,
        stop_dist_m: F64,
        out: Sequence[F64],
    ) -> None:
        """Readings of the next events: true values plus noise, written into ``out`` (one
        contiguous array per channel). Energy and distance are never negative, so noise
        around a small true value is floored at 0."""
        truth = (
            speed_mps * 3.6,
            mass_kg,
            slope_rad,
            0.5 * mass_kg * speed_mps**2,
            temp_c,
            stop_dist_m,
        )
        for x, o, rng, sigma in zip(truth, out, self.rngs, self.sigmas, strict=True):
            if rng is None:
                o[:] = x
            else:  # x + N(0, sigma^2), drawn in place
                rng.standard_normal(len(o), out=o)
                o *= sigma
                o += x
        np.maximum(out[3], 0.0, out=out[3])
        np.maximum(out[5], 0.0, out=out[5])


@dataclass(frozen=True)
class AlternatingRoutes:
    """A duty cycle that alternates between two routes in blocks of events.

    Blocks 0, 2, 4... run on the haul road (speeds in the upper half of the envelope's
    range), blocks 1, 3, 5... in the pit (the lower half); mass and slope stay uniform. The
    overall mix is the uniform one of the paper; only its order in time changes. With
    independent conditions from event to event, a wear law that scales each event's wear by
    a function of its conditions only rescales the pad's K; alternating routes make such a
    law show in the wear path (sim2real's validation uses this).

    Attributes:
        block_events: Events per block [-], >= 1.
    """

    block_events: int

    def __post_init__(self) -> None:
        plain_numbers(self)
        if not isinstance(self.block_events, int) or self.block_events < 1:
            raise ValueError(
                f"AlternatingRoutes.block_events must be an int >= 1, got {self.block_events!r}"
            )

    def apply(self, u: F64, first: int) -> F64:
        """Uniform triples (n, 3) of events ``first``, ``first + 1``... on their routes."""
        haul = ((first + np.arange(len(u))) // self.block_events) % 2 == 0
        out = u.copy()
        out[:, 0] = 0.5 * (u[:, 0] + haul)
        return out


class ConditionStream:
    """A run's operating conditions: uniform triples drawn in order, in chunks, as taken.

    A run only moves forward, so the triples before the latest ``take`` are dropped when
    the stream grows: it holds about one block of events, whatever the length of the run.

    Args:
        rng: The run's operating-condition generator.
        capacity: Events to draw at first (default: none until the first ``take``).
        duty: Order of the conditions in time (default: independent draws).
    """

    def __init__(
        self, rng: np.random.Generator, capacity: int = 0, duty: AlternatingRoutes | None = None
    ) -> None:
        self.rng, self.duty = rng, duty
        self.first = 0  # event of self.u[0]
        self.u = self._draw(capacity, 0)

    def _draw(self, n: int, first: int) -> F64:
        u = self.rng.random((n, 3))
        return u if self.duty is None else self.duty.apply(u, first)

    def clone(self) -> ConditionStream:
        """An independent copy at the same point of the stream."""
        new = copy.copy(self)
        new.rng = copy.deepcopy(self.rng)
        return new  # self.u is never written in place, so the copy may share it

    def take(self, start: int, n: int) -> F64:
        """Triples of events ``start`` to ``start + n - 1``."""
        have = self.first + len(self.u)
        if not self.first <= start <= have:
            raise ValueError(
                f"ConditionStream: event {start} is outside [{self.first}, {have}]: a run's"
                " events are taken in order"
            )
        if start + n > have:
            # As many as drawn so far (so a short run draws little, a long one seldom).
            keep, more = have - start, min(max(have, _CHUNK_MIN), _CHUNK_MAX)
            u = np.empty((keep + max(start + n - have, more), 3))
            u[:keep] = self.u[start - self.first :]
            self.rng.random(out=u[keep:])
            if self.duty is not None:
                u[keep:] = self.duty.apply(u[keep:], have)
            self.u, self.first = u, start
        return self.u[start - self.first : start + n - self.first]
