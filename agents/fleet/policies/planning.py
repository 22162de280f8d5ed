"""A planning model of BrakeWearFleet-v0 for look-ahead policies: the fleet's state in a
batch of sampled futures, stepped together under the env's rules, vectorised over the batch.

**State** of future ``b``: per vehicle ``h`` (the pad's expected hot life left, in shifts
of hot duty, continuous), ``age`` (events since its installation: the workshop's order),
``down`` (shifts left in the shop), ``failed`` (down after a brake failure: downtime is
paid) and ``waiting`` (failed, waiting for a spare); the ``stock``, the orders in
``transit`` (arrivals in 1..lead_time shifts) and how many pads each vehicle has been
given (``installs``, the index into its draws of new pads). The shift is common.

**Transitions** are :meth:`BrakeWearFleetEnv.step`'s, in its order, with the env's own
rules (the functions of :mod:`brake_env.env.fleet.model` the env calls): services
(window crew, stock, bays; deferred by pad age), refusals, new pads, a shift of wear,
failures (down ``failure_repair_shifts``, a spare fitted at once if there is one),
breakdowns, the order, the end of the shift, arrivals and the waiting vehicles' fits.

**What it simplifies** (its error against the env is measured by
``benchmarks/analysis/rollout_model_error.py``):

- Wear per shift at its expectation (the law of large numbers over ~400 events): a hot
  shift uses 1 of ``h``; a mild shift ``r(h)``, the mild route's wear per event over the
  hot route's in the layer a pad of mean K is in at ``h`` (the reference's clock, 0.15 to
  0.21); a pad fails in a shift that needs more than it has left.
- New pads' hot lives from the config's K distribution (``Futures``), drawn once per
  future and vehicle: common random numbers across the candidates a planner compares.
- Breakdowns: one uniform per future, shift and vehicle, common across candidates.
- Costs are the headline's (:attr:`EpisodeCost.per_vehicle_shift`): every fit pays
  ``pad + labour`` (pads priced when fitted, not ordered), visits, damage, downtime,
  shortfalls, the order's fixed cost and holding.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np
from numpy.typing import NDArray

from agents.fleet.policies.lagrangian import BoundModel, Program
from brake_env.env.fleet import model as fleet
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.routes import HOT as HOT_ROUTE
from brake_env.env.fleet.routes import MILD as MILD_ROUTE
from brake_env.env.fleet.routes import route_mean, route_wear_model
from brake_env.env.fleet.shop import HOT, MILD, SERVICE
from brake_env.model.atlas import Atlas

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]
B = NDArray[np.bool_]


@dataclass
class FleetState:
    """The fleet in a batch of futures (module docstring); arrays have the batch first."""

    h: F64
    age: F64
    down: I64
    failed: B
    waiting: B
    stock: I64
    transit: I64
    installs: I64
    shift: int

    @property
    def size(self) -> int:
        return int(self.h.shape[0])

    def take(self, rows: I64) -> FleetState:
        """The futures ``rows`` (a copy)."""
        arrays = {f.name: getattr(self, f.name)[rows] for f in fields(self) if f.name != "shift"}
        return FleetState(**arrays, shift=self.shift)

    def free_bays(self, bays: int) -> I64:
        """Bays left for visits after the vehicles down, per future."""
        return fleet.free_bays(bays, self.down)


@dataclass(frozen=True)
class Futures:
    """Common random numbers of a batch of futures.

    Attributes:
        breakdown: Uniforms, shape (shifts, futures, n_vehicles): a vehicle that drove
            breaks down when its uniform is below ``breakdown_rate``.
        new_life: Hot lives [shifts] of each vehicle's next pads, shape (futures,
            n_vehicles, pads): its i-th new pad in the future gets ``new_life[..., i]``
            (the last one again beyond them).
    """

    breakdown: F64
    new_life: F64


@dataclass(frozen=True)
class PlanningModel:
    """The fleet's planning model (module docstring).

    Attributes:
        config: The env's config.
        r_mild: Hot shifts a mild shift uses at each whole ``h`` (index ``floor(h)``).
        life_per_k: Hot life of a pad times its K [shifts x K]: ``life_per_k / K``.
    """

    config: FleetConfig
    r_mild: F64
    life_per_k: float

    @classmethod
    def build(cls, config: FleetConfig, atlas: Atlas) -> PlanningModel:
        """The model of an env's config and atlas."""
        wear = route_wear_model(atlas, HOT_ROUTE)
        e = config.events_per_shift
        # a slow pad's life (5 sd below the mean K, at least a twentieth of it: a wide
        # spread the env accepts puts that below 0); longer lives read the last layer's
        k_slow = max(config.k_mean - 5 * config.k_std, config.k_mean / 20)
        h_max = int(np.ceil(wear.life(k_slow)[()] / e)) + 1
        h = np.arange(h_max + 1) + 0.5  # the layer half a hot shift into state floor(h)
        work = wear.life_work - h * e * config.k_mean
        layer = wear.layer_at_work(np.clip(work, 0.0, wear.life_work))
        ratio = route_mean(atlas, MILD_ROUTE) / route_mean(atlas, HOT_ROUTE)
        return cls(config, np.asarray(ratio[layer], dtype=np.float64), wear.life_work / e)

    @property
    def fit_cost(self) -> float:
        return self.config.costs.pad + self.config.costs.labour

    @property
    def mean_life(self) -> float:
        """Hot life [shifts] over which a fit's cost prices the life left: a new pad's, each
        wear label at its mean K (:func:`~brake_env.env.fleet.episode_cost.credit_life`; the
        mean-K pad's in ``id``)."""
        return float(sum(s * self.life_per_k / k for s, k in self.config.pad_regime.components()))

    def draw(self, rng: np.random.Generator, futures: int, shifts: int, pads: int = 3) -> Futures:
        """Random numbers of ``futures`` futures of ``shifts`` shifts."""
        c = self.config
        n = c.n_vehicles
        size = futures * n * pads
        k = c.wear.draw(rng, "id", size)
        if c.regime != "id":  # the env's PadRegime.draw, vectorised
            ood = rng.random(size) < (1.0 if c.regime == "ood" else c.ood_share)
            fast = rng.random(size) < 0.5
            k = np.where(ood & fast, c.wear.draw(rng, "ood-fast", size), k)
            k = np.where(ood & ~fast, c.wear.draw(rng, "ood-slow", size), k)
        life = (self.life_per_k / k).reshape(futures, n, pads)
        return Futures(rng.random((shifts, futures, n)), life)

    def start(
        self, h: F64, age: F64, down: I64, stock: int, transit: int | I64, shift: int
    ) -> FleetState:
        """A batch of futures from one observed state; ``h`` of shape (futures, n) (a
        belief sampled per future) and ``transit`` the pads on order (all due in
        ``lead_time`` shifts if given as a total) or the arrivals by shift."""
        c = self.config
        b = h.shape[0]
        t = np.zeros(c.lead_time, dtype=np.int64)
        if np.ndim(transit) == 0:
            t[-1] = int(transit)
        else:
            t[:] = transit
        n = c.n_vehicles
        return FleetState(
            h=np.array(h, dtype=np.float64),
            age=np.broadcast_to(np.asarray(age, dtype=np.float64), (b, n)).copy(),
            down=np.broadcast_to(np.asarray(down, dtype=np.int64), (b, n)).copy(),
            failed=np.zeros((b, n), dtype=bool),
            waiting=np.zeros((b, n), dtype=bool),
            stock=np.full(b, int(stock), dtype=np.int64),
            transit=np.tile(t, (b, 1)),
            installs=np.zeros((b, n), dtype=np.int64),
            shift=int(shift),
        )

    def mild_use(self, h: F64) -> F64:
        idx = np.clip(np.floor(h).astype(np.int64), 0, len(self.r_mild) - 1)
        return self.r_mild[idx]

    def step(
        self, s: FleetState, duty: I64, order: I64, futures: Futures, t: int, rows: I64
    ) -> F64:
        """One shift of every future in place: actions ``duty`` (batch, n) and ``order``
        (batch,); ``t`` the shift's index into ``futures``, ``rows`` each future's row in
        them. Returns each future's cost of the shift."""
        c, w = self.config, self.config.costs
        window = c.is_window(s.shift)
        cost = w.downtime * ((s.down > 0) & s.failed).sum(axis=1).astype(np.float64)
        fit, visit = _serve(c, s, duty == SERVICE, window)
        drives = ((duty == HOT) | (duty == MILD)) & fleet.can_drive(s.down, window)
        self._install(s, fit, futures, rows)
        use = np.where(duty == HOT, 1.0, self.mild_use(s.h))
        failed = drives & (s.h < use)
        s.h = np.where(drives & ~failed, s.h - use, s.h)
        s.age = np.where(drives, s.age + c.events_per_shift, s.age)
        on_hot, on_mild = (drives & (duty == HOT)).sum(1), (drives & (duty == MILD)).sum(1)
        cost += fleet.shortfall_cost(c, on_hot, on_mild, window)
        fleet.fail(c, s.down, s.failed, s.waiting, failed)
        corrective = self._fit_waiting(s, futures, rows)
        broke = fleet.breaks(c, drives, failed, futures.breakdown[t, rows])
        fleet.break_down(c, s.down, s.failed, broke)
        fleet.place_order(s.transit, order)
        s.down = fleet.end_shift(s.down, s.waiting, failed | broke)
        s.failed &= s.down > 0
        cost += w.holding * s.stock + w.order * (order > 0)
        s.shift += 1
        arrived, s.transit = fleet.receive(s.transit)
        s.stock += arrived
        corrective += self._fit_waiting(s, futures, rows)
        fits = fit.sum(1) + corrective
        return cost + self.fit_cost * fits + w.shop_visit * visit.sum(1) + w.damage * failed.sum(1)

    def _install(self, s: FleetState, fit: B, futures: Futures, rows: I64) -> None:
        if not fit.any():
            return
        b, v = np.nonzero(fit)
        i = np.minimum(s.installs[b, v], futures.new_life.shape[2] - 1)
        s.h[b, v] = futures.new_life[rows[b], v, i]
        s.age[b, v] = 0.0
        s.installs[b, v] += 1

    def _fit_waiting(self, s: FleetState, futures: Futures, rows: I64) -> I64:
        """Failed vehicles waiting get a spare, in vehicle order; fits per future."""
        if not s.waiting.any():
            return np.zeros(s.size, dtype=np.int64)
        fit = fleet.fit_waiting(s.waiting, s.stock)
        s.stock -= fit.sum(1)
        s.waiting &= ~fit
        self._install(s, fit, futures, rows)
        return fit.sum(1)


@dataclass(frozen=True)
class ProgramValue:
    """A terminal value for look-ahead from the relaxed per-vehicle program of the
    Lagrangian bound (:mod:`.lagrangian`): each vehicle's optimal cost-to-go ``V[t, h, d]``
    at the searched prices, summed over the vehicles. ``t`` is the program's first shift
    at the same place in the window cycle as the horizon's end (far from the program's
    own end, so that the values do not plan for an episode that stops).

    Attributes:
        values: ``V[t, h, d]`` for t = 0 .. window_period - 1.
        units: Clock units per hot shift of the program's ``h``.
    """

    values: F64
    units: int

    @classmethod
    def of(cls, model: BoundModel, program: Program) -> ProgramValue:
        w = model.config.window_period
        return cls(np.array(program.values[:w]), model.units)

    def __call__(self, h: F64, down: I64, shift: int) -> F64:
        """The value of every future's fleet (rows) at ``shift``."""
        v = self.values[shift % len(self.values)]
        hu = np.clip(np.ceil(h * self.units - 1e-9), 0, v.shape[0] - 1).astype(np.int64)
        return v[hu, np.clip(down, 0, v.shape[1] - 1)].sum(axis=1)


def _serve(c: FleetConfig, s: FleetState, asks: B, window: bool) -> tuple[B, B]:
    """The workshop's rule (:meth:`Workshop.plan`) over the batch: (fitted, visits). A
    request without a spare, slot or bay is deferred (the vehicle is parked)."""
    if not asks.any():
        return np.zeros_like(asks), np.zeros_like(asks)
    down = s.down > 0
    order = fleet.workshop_order(s.age, down, window)
    fit, _ = fleet.admit(c, asks, order, down=down, window=window, stock=s.stock,
                         free=s.free_bays(c.bays))  # fmt: skip
    s.stock -= fit.sum(axis=1)
    s.waiting &= ~fit
    return fit, fit & ~(down | window)
