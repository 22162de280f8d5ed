"""RUL under a stated future duty (issue 31): any predictor's estimate carried onto the
routes a pad may run next, through the atlas's wear clocks (docs/results/prognostics.md).

The predictors are fitted on the paper's logs, whose events are drawn from the envelope's
uniform mix (the *base* duty), so each states its RUL in events of that mix. Two facts of
the wear clock (:class:`~brake_env.model.wear.WearModel`) carry it onto any duty:

- **The future.** At volume ``V`` and coefficient ``K`` the expected events to failure on
  duty ``r`` are ``work_r(V -> failure) / K``. The route's RUL over the base mix's is then
  ``ratio_r(V) = work_r(V -> failure) / work_base(V -> failure)``, whatever ``K``: a
  predictor's RUL (and each bound of its interval) on route ``r`` is its base-mix RUL times
  ``ratio_r`` at the pad's volume. For the twin, whose base-mix RUL is
  ``work_base(V -> failure) / K`` at its own ``V`` and ``K``, this is exactly
  ``route_clock.rul(V, K)`` (tested). Predictors that give a volume (twin, physics) use
  theirs; the others (MLP, window, none) get the volume of the expected base-mix path at
  the share of life they state used, ``done / (done + RUL)``. That assumes the pad is
  where an average pad with that share used would be; it is wrong by as much as the
  predictor's own RUL is, and the ratio moves slowly with the volume (the hot route's
  1.8x the base mix's on a fresh pad, 2.1x on the last layer), so a wrong volume costs
  far less than a wrong RUL.
- **The past.** A pad that ran duty ``r`` in layer ``j`` wore ``w_r(j) / w_base(j)`` base-mix
  events' worth per event. :func:`equivalent_events` turns a shift of events on a known
  duty into base-mix events, so a predictor fitted on the base mix reads a pad whose
  history is its own units (the twin's K is then the pad's K, not a K inflated by the
  ramp). The rate is taken at the layer of the pad's volume estimate before the shift.

The interval of a route RUL is the predictor's interval scaled by the same ratio: it
carries the predictor's uncertainty about the pad (K, its state), not the spread of the
route's own operating conditions beyond what the predictor's interval holds.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from brake_env.model.wear import WearModel
from brake_env.prognostics.events import RULEstimate

F64 = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class DutyClocks:
    """The wear clocks of the base mix (the predictors' unit) and of each stated duty.

    Attributes:
        base: The clock of the mix the predictors' RUL is stated in.
        routes: One clock per duty, on the base clock's layers.
        names: The duties' names, in the order of ``routes``.
    """

    base: WearModel
    routes: tuple[WearModel, ...]
    names: tuple[str, ...]

    def __post_init__(self) -> None:
        if not self.routes or len(self.routes) != len(self.names):
            raise ValueError(
                f"DutyClocks: {len(self.routes)} clocks for {len(self.names)} names; give one"
                " clock per named duty, at least one"
            )
        for name, r in zip(self.names, self.routes, strict=True):
            if not np.array_equal(r.lower_edges, self.base.lower_edges):
                raise ValueError(f"DutyClocks: duty {name!r} has other layers than the base")

    def index(self, name: str) -> int:
        """The position of duty ``name``; one ``ValueError`` listing the duties if unknown."""
        if name not in self.names:
            raise ValueError(f"DutyClocks: unknown duty {name!r}; known are {list(self.names)}")
        return self.names.index(name)

    def remaining_ratio(self, volume: F64) -> F64:
        """(pads, duties): events to failure on each duty over the base mix's, at
        ``volume`` (the limit at the failure volume: the last layer's wear ratio)."""
        v = self._clip(volume)
        base = self.base.life_work - self.base.work_at_volume(v)
        out = np.empty((v.size, len(self.routes)))
        last = self.rate_ratio(np.full(1, self.base.lower_edges[-1]))[0]
        for i, r in enumerate(self.routes):
            rest = r.life_work - r.work_at_volume(v)
            with np.errstate(invalid="ignore", divide="ignore"):
                out[:, i] = np.where(base > 0, rest / np.where(base > 0, base, 1.0), 1 / last[i])
        return out

    def rate_ratio(self, volume: F64) -> F64:
        """(pads, duties): wear per event on each duty over the base mix's, in the layer of
        ``volume``: base-mix events an event of that duty is worth."""
        layer = self.base.layer_at_work(self.base.work_at_volume(self._clip(volume)))
        base = np.diff(self.base.work_edges, prepend=0.0)[layer]
        return np.stack(
            [base / np.diff(r.work_edges, prepend=0.0)[layer] for r in self.routes], axis=1
        )

    def _clip(self, volume: F64) -> F64:
        v = np.asarray(volume, dtype=np.float64)
        if np.isnan(v).any():
            raise ValueError("DutyClocks: a volume is NaN")
        return np.clip(v.ravel(), self.base.lower_edges[-1], 1.0)


@dataclass(frozen=True, eq=False)
class RouteRUL:
    """Each pad's RUL on each duty: arrays (pads, duties) [events of that duty].

    Attributes:
        mean, lower, upper: The estimate and its interval (the predictor's bounds carried
            over; both equal to ``mean`` for a predictor without an interval).
        volume: The volume the ratios were taken at, (pads,) [-].
    """

    mean: F64
    lower: F64
    upper: F64
    volume: F64

    def field(self, name: str) -> F64:
        """``rul_mean``, ``rul_lower`` or ``rul_upper``."""
        fields = {"rul_mean": self.mean, "rul_lower": self.lower, "rul_upper": self.upper}
        if name not in fields:
            raise ValueError(f"RouteRUL: unknown field {name!r}; known are {list(fields)}")
        return fields[name]


# An estimated volume fraction above a fresh pad's read as fresh up to this (a filter's
# noise); above it, no pad's.
VOLUME_MAX = 1.05


def volume_estimate(est: RULEstimate, done: F64, base: WearModel) -> F64:
    """Each pad's volume: the predictor's own where it gives one (a NaN: none for that pad
    alone), else the expected base-mix path's at the share of life it states used,
    ``done / (done + rul_mean)``.

    Args:
        est: Estimates, one per pad.
        done: Base-mix events each pad has done [events].
        base: The base mix's clock.

    Raises:
        ValueError: A volume of another length than the estimates, or one no pad can have
            (below 0, above :data:`VOLUME_MAX`, infinite), naming the pad and value.
    """
    done = np.maximum(np.asarray(done, dtype=np.float64), 0.0)
    life = done + np.maximum(est.rul_mean, 0.0)
    share = np.divide(done, life, out=np.zeros_like(life), where=life > 0)
    path = base.volume_at_work(np.clip(share, 0.0, 1.0) * base.life_work)
    if est.volume_frac is None:
        return path
    v = np.asarray(est.volume_frac, dtype=np.float64)
    if v.shape != path.shape:
        raise ValueError(f"route_rul: {v.size} volumes for {path.size} estimates")
    bad = np.flatnonzero(~np.isnan(v) & ~((v >= 0) & (v <= VOLUME_MAX)))
    if bad.size:
        i = int(bad[0])
        raise ValueError(
            f"route_rul: the estimate's volume_frac of pad {i} is {v[i]}: a pad's volume"
            f" fraction is in [0, 1] (up to {VOLUME_MAX} read as a fresh pad)"
        )
    return np.where(np.isnan(v), path, np.clip(v, base.lower_edges[-1], 1.0))


def route_rul(est: RULEstimate, done: F64, clocks: DutyClocks) -> RouteRUL:
    """Every pad's RUL on every duty of ``clocks``, in one vectorised call (module doc).

    Args:
        est: The predictor's estimates, one per pad, in base-mix events.
        done: Base-mix events each pad has done (its age in the predictor's units).
        clocks: The base mix's and the duties' clocks.

    Returns:
        Mean and interval on each duty, in events of that duty.
    """
    mean = np.asarray(est.rul_mean, dtype=np.float64)
    if np.shape(done) != mean.shape:
        raise ValueError(f"route_rul: {np.size(done)} ages for {mean.size} estimates")
    if np.isnan(mean).any():
        raise ValueError("route_rul: an estimate's rul_mean is NaN")
    volume = volume_estimate(est, np.asarray(done, dtype=np.float64), clocks.base)
    ratio = clocks.remaining_ratio(volume)

    def on_routes(x: F64 | None) -> F64:
        base = mean if x is None else np.asarray(x, dtype=np.float64)
        return np.maximum(base, 0.0)[:, None] * ratio

    return RouteRUL(on_routes(mean), on_routes(est.rul_lower), on_routes(est.rul_upper), volume)


def equivalent_events(age: F64, n_events: NDArray[np.int64], rate: F64) -> tuple[F64, F64]:
    """A shift of events on known duties in base-mix events: (each event's base-mix events
    done after it, rows (pads, events) with NaN past ``n_events``; each pad's age after).

    Args:
        age: Base-mix events each pad had done before the shift [events].
        n_events: Events each pad braked in the shift.
        rate: Base-mix events one event of the pad's duty is worth (:meth:`DutyClocks.rate_ratio`).
    """
    n = np.asarray(n_events, dtype=np.int64)
    k = np.arange(max(int(n.max(initial=0)), 1))
    done = age[:, None] + rate[:, None] * (k[None, :] + 1.0)
    done[k[None, :] >= n[:, None]] = np.nan
    return done, age + rate * n
