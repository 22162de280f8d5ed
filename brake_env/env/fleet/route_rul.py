"""Any predictor's RUL on the fleet's routes (issue 31): the duty clocks of the routes, the
shift's events in base-mix events, and each vehicle's route RUL after every shift
(:class:`RouteTracker`, which :class:`~brake_env.env.fleet.wrappers.FleetRULObservation`
drives). The method is :mod:`brake_env.prognostics.duty`'s.

The predictors are fitted on the envelope's uniform mix (the base duty). A vehicle's shift
is on a known route (the dispatch, ``info["vehicles"]["route"]``, not truth), so its
events are handed to the predictor re-indexed in base-mix events: the k-th event of a
shift on a route worth ``rate`` base-mix events per event (the route's wear over the base
mix's in the layer of the pad's volume estimate) gets the index ``ceil(age + rate (k +
1)) - 1``. On the ramp (rate 1.8-2.1) indices skip, which the protocol reads as events
braked and not logged (each worth the expected wear: here that of the base mix, by
construction); in the drifts (rate 0.3-0.4) several events share an index and only the
last of them is handed over (the others' temperatures are left out: the predictor sees a
base-mix pad of that age, with about a third of the drifts' readings). The first pads of
an episode were aged on the base mix, so their age is their pad age.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from brake_env.env.fleet.pads import ShiftEvents
from brake_env.env.fleet.routes import ROUTE_INDEX, ROUTES, UNIFORM, route_wear_model
from brake_env.model.atlas import Atlas
from brake_env.model.streams import SENSOR_CHANNELS
from brake_env.prognostics.duty import DutyClocks, RouteRUL, equivalent_events, route_rul
from brake_env.prognostics.events import EventBatch, RULEstimate
from brake_env.prognostics.fleet import ESTIMATE_FIELDS as ALL_FIELDS
from brake_env.prognostics.fleet import Fleet

F64 = NDArray[np.float64]
ROUTE_NAMES = ("hot", "mild")  # the duties a vehicle can be sent on


def duty_clocks(atlas: Atlas, names: tuple[str, ...] = ROUTE_NAMES) -> DutyClocks:
    """The base mix's (the envelope's uniform one) and the named routes' wear clocks."""
    bad = [n for n in names if n not in ROUTE_INDEX]
    if bad or not names:
        raise ValueError(f"duty_clocks: unknown route(s) {bad}; valid are {list(ROUTE_INDEX)}")
    routes = tuple(route_wear_model(atlas, ROUTES[ROUTE_INDEX[n]]) for n in names)
    return DutyClocks(route_wear_model(atlas, UNIFORM), routes, tuple(names))


def equivalent_batch(
    ev: ShiftEvents, age: F64, rate: F64, last: NDArray[np.int64]
) -> tuple[EventBatch, NDArray[np.intp], NDArray[np.intp], F64]:
    """The shift's events in base-mix indices (module docstring).

    Args:
        ev: The shift's events (measured).
        age: Each vehicle's base-mix events done before the shift.
        rate: Base-mix events one of its events is worth this shift.
        last: The last index handed over for each vehicle's pad (-1: none yet).

    Returns:
        (the events handed over, concatenated in vehicle order; the vehicle of each row;
        the vehicles with rows; every vehicle's age after the shift).
    """
    if ev.measured is None:
        raise ValueError("equivalent_batch needs the measured channels of the shift")
    done, after = equivalent_events(age, ev.n_done, rate)
    width = ev.valid.shape[1]
    if done.shape[1] < width:
        done = np.pad(done, ((0, 0), (0, width - done.shape[1])), constant_values=np.nan)
    done = done[:, :width]
    with np.errstate(invalid="ignore"):
        index = np.ceil(done - 1e-9) - 1.0
        # of the events sharing an index, the last: its base-mix events done are nearest
        # the index's own (index + 1)
        nxt = np.concatenate([index[:, 1:], np.full((len(index), 1), np.nan)], axis=1)
        keep = ev.valid & (index > last[:, None]) & (index >= 0) & ~(nxt == index)
    rows = np.nonzero(keep)[0]
    cols: dict[str, Any] = {c: ev.measured[i][keep] for i, c in enumerate(SENSOR_CHANNELS)}
    batch = EventBatch(
        event=index[keep].astype(np.int64),
        volume_frac=ev.volume_frac[keep],
        wear_coeff=ev.wear_coeff[rows],
        **cols,
    )
    return batch, rows.astype(np.intp), np.unique(rows).astype(np.intp), after


class RouteTracker:
    """One predictor's route RUL for every vehicle of a fleet, shift after shift.

    Args:
        fleet: The predictor's fleet (one slot per vehicle).
        atlas: The env's atlas.
        names: Routes whose RUL is asked for.
        k_mean: Mean K of new pads: a pad not yet read shows the expected life at it.
    """

    def __init__(self, fleet: Fleet, atlas: Atlas, names: tuple[str, ...], k_mean: float) -> None:
        self.fleet, self.n = fleet, fleet.n_pads
        self.clocks = duty_clocks(atlas, names)
        self.driven = duty_clocks(atlas, tuple(r.name for r in ROUTES))  # by env route index
        self.k_mean = float(k_mean)
        self.age = np.zeros(self.n)
        self.last = np.full(self.n, -1, dtype=np.int64)
        self.base = np.full((len(ALL_FIELDS), self.n), np.nan)  # the latest estimate
        self.known = np.zeros(self.n, dtype=bool)

    def reset(self, pad_age: F64) -> None:
        """A new episode: every slot's pad is new to the predictor, aged ``pad_age`` events
        on the base mix."""
        self.fleet.reset(np.arange(self.n))
        self.age[:] = pad_age
        self.last[:] = -1
        self.base[:] = np.nan
        self.known[:] = False

    def new_pads(self, vehicles: NDArray[np.intp]) -> None:
        """New pads were installed on ``vehicles`` (none of their events read yet)."""
        if vehicles.size:
            self.fleet.reset(vehicles)
            self.age[vehicles], self.last[vehicles] = 0.0, -1
            self.base[:, vehicles] = np.nan
            self.known[vehicles] = False

    def after_step(
        self, ev: ShiftEvents | None, route: NDArray[np.int64], pos: NDArray[np.int64]
    ) -> tuple[RULEstimate | None, NDArray[np.intp]]:
        """Take a shift in: its events ``ev`` on env routes ``route`` (``info["vehicles"]
        ["route"]``), then the pads at age ``pos`` 0 (installed after their events) as new;
        the predictor's estimate and the vehicles it is for (none: nobody braked)."""
        est, read = None, np.zeros(0, dtype=np.intp)
        if ev is not None and ev.n_done.any():
            self.new_pads(np.flatnonzero((ev.n_done > 0) & (ev.first_event == 0)))
            est = self.feed(ev, route)
            read = np.flatnonzero(self.known & (ev.n_done > 0))
        self.new_pads(np.flatnonzero(pos == 0))
        return est, read

    def feed(self, ev: ShiftEvents, route: NDArray[np.int64]) -> RULEstimate | None:
        """Hand the shift's events (on env routes ``route``) to the predictor; its estimate
        after each vehicle's last event (None if nobody's events were handed over)."""
        volume = self._volume()
        rate = self.driven.rate_ratio(volume)[np.arange(self.n), np.maximum(route, 0)]
        batch, rows, vehicles, after = equivalent_batch(ev, self.age, rate, self.last)
        self.age = np.where(ev.n_done > 0, after, self.age)
        if vehicles.size == 0:
            return None
        est = self.fleet.update(rows, batch)
        ends = np.flatnonzero(np.r_[rows[1:] != rows[:-1], True])
        self.last[vehicles] = batch.event[ends]
        for i, f in enumerate(ALL_FIELDS):
            x = getattr(est, f)
            if x is None:  # no interval: the estimate itself; no volume or K: unknown
                x = est.rul_mean if i < 3 else np.nan
            self.base[i, vehicles] = x
        self.known[vehicles] = True
        return est

    def route_rul(self) -> RouteRUL:
        """Every vehicle's RUL on each route [events of that route]; a pad not read yet
        shows the expected life of a new pad of mean K on each route (interval: the same)."""
        est = RULEstimate(*(np.where(self.known, x, 0.0) for x in self.base))
        if np.isnan(self.base[3]).all():  # the predictor gives no volume
            est = RULEstimate(est.rul_mean, est.rul_lower, est.rul_upper, None, None)
        out = route_rul(est, self.age, self.clocks)
        fresh = np.array([c.life(self.k_mean) for c in self.clocks.routes])
        for x in (out.mean, out.lower, out.upper):
            x[~self.known] = fresh
        return out

    def estimate_info(self) -> dict[str, F64]:
        """The predictor's latest base-mix estimate per vehicle (events; NaN where none)."""
        out = {f: self.base[i].copy() for i, f in enumerate(ALL_FIELDS)}
        out["base_age"] = self.age.copy()
        return out

    def _volume(self) -> F64:
        """Each pad's volume estimate now (1 for a pad not read yet)."""
        if not self.known.any():
            return np.ones(self.n)
        v = self.route_rul().volume
        return np.where(self.known, v, 1.0)
