"""A Lagrangian lower bound on the expected episode cost of any policy on BrakeWearFleet-v0,
at any fleet size: the constraints that link the vehicles are priced, each vehicle then
solves its own small program (Hawkins 2003; Adelman and Mersereau 2008; DESIGN.md 11).

**Per-vehicle model.** A vehicle's state is ``(h, d)``: ``h`` its pad's expected RUL on
the hot route in clock units of ``1 / units`` of a hot shift, rounded **up**
(``h = ceil(rul_hot * units / events_per_shift)``), and ``d`` the shifts it is still down
in the shop (``0 .. max(failure_repair_shifts, breakdown_repair_shifts)``). A hot shift
uses exactly ``units`` units (the hot RUL is counted in hot events); a mild shift uses
``mild_units = floor(units * r_min)``, ``r_min`` the least, over all atlas layers, of the
mild route's wear per event over the hot route's; parking uses none. The pad fails in a
shift that needs more units than it has. ``h`` is capped at ``episode_shifts * units``: a
pad with more cannot fail within the episode, so the cap is exact.

**Idealisations** (each can only lower the cost, unless said):

- Rounding up and ``r_min`` rounded down: the model's pad never wears faster than the
  expected wear of the real one (relaxation).
- Wear per shift deterministic at its expectation (law of large numbers): an
  **approximation**; the benchmark measures the realised life's spread around it (a
  fraction of a shift) and ``slack_shifts`` gives every pad that much more life, which
  makes the bound hold for every pad whose realised life exceeds its expected one by
  less.
- The current pad's K known once fitted: an information relaxation. New pads' ``h`` is
  drawn from the exact distribution of ``ceil(life(K) * units / events_per_shift)`` under
  the config's normal K (no quantile approximation; regime ``id`` only).
- Spares always in stock, no order nor holding cost, no lead time (non-negative costs and
  a constraint dropped: relaxation); every fit pays ``pad + labour`` (the headline cost
  prices pads when fitted). With ``orders`` (:meth:`BoundModel.build`) a service also pays
  ``order / max_order`` and the bound gives back that much for each pad of the initial
  stock: every pad fitted was in stock at the start or arrived by an order of at most
  ``max_order`` pads (nothing is in transit at the start), so the orders cost at least
  ``order / max_order`` times the fits beyond the initial stock (relaxation: failures'
  fits are not charged, holding still is not).
- A failure costs ``damage + pad + labour`` and ``downtime`` for each of the
  ``failure_repair_shifts`` shifts out that fall within the episode; the vehicle is down
  (cannot drive) for them, with a new pad: the env's rule, exactly.
- Breakdowns as in the env: after a driven shift without failure, down for
  ``breakdown_repair_shifts`` with probability ``breakdown_rate``.

**Prices** (per shift ``t``; :class:`Prices`). With ``c_h = costs.shortfall`` and
``c_m = costs.mild_shortfall``, for ``lam, mu >= 0``, ``mu <= c_m``, ``lam + mu <= c_h``
the shortfall cost ``f(n_h, n_m)`` is at least ``lam (N_h - n_h) + mu (N_h + N_m - n_h -
n_m)`` for all counts: a hot vehicle earns ``lam + mu``, a mild one ``mu`` (no production
at a window). Bays: the env allows ``visits <= max(bays - down, 0)``; the tightest linear
inequality that every (visits, down) of the env satisfies is ``visits + (bays / n) down
<= bays`` (the line through (bays, 0) and (0, n)); ``visits + down <= bays`` is not valid
(more vehicles can be down than there are bays), so a visit pays ``nu``, a shift down
``nu * bays / n``. Window crew: a fit at a window pays ``omega`` (at most
``window_slots`` fits). For any prices in these boxes, the sum over vehicles of their
optimal cost plus the prices' constant is a lower bound on every policy's expected cost
(:func:`bound`); :mod:`.lagrangian_search` searches the prices.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray
from scipy.stats import norm

from agents.fleet.policies.checks import bound_inputs, program_fits, real, whole
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.routes import HOT as HOT_ROUTE
from brake_env.env.fleet.routes import MILD as MILD_ROUTE
from brake_env.env.fleet.routes import route_mean, route_wear_model
from brake_env.env.fleet.shop import HOT, MILD, PARK, SERVICE
from brake_env.model.atlas import Atlas
from brake_env.model.wear import WearModel

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]
ACTIONS = (HOT, MILD, PARK, SERVICE)


@dataclass(frozen=True)
class BoundModel:
    """One vehicle's relaxed model (module docstring).

    Attributes:
        config: The env's config (costs, needs, bays, slots, horizon).
        units: Clock units per hot shift [-].
        mild_units: Units a mild shift uses (at most its expected wear) [-].
        new_prob: Probability that a new pad's state is ``h``, for h = 0..H [-].
        wear: The hot route's wear clock (RUL from volume and K); None in toy models.
        slack: Units added to every pad's state (its own and new pads'): a pad that
            outlives its expected life by up to ``slack`` units (the law of large numbers
            is not exact) is still within the model's.
        credit: Terminal credit per unit of pad life left at the episode's end (0: none;
            :meth:`build` with ``credit=True`` prices it as
            :func:`agents.fleet.evaluation.costs.life_value` does). With it the bound is
            on the cost less that credit (:attr:`EpisodeCost.net`); the state's cap is
            then above every pad's life, so the credit is never cut (a relaxation still:
            rounding up gives more life, more credit).
        order_share: Order cost charged per service (``order / max_order`` with
            ``orders``; module docstring), given back for the initial stock.
    """

    config: FleetConfig
    units: int
    mild_units: int
    new_prob: F64
    wear: WearModel | None = None
    slack: int = 0
    credit: float = 0.0
    order_share: float = 0.0

    @classmethod
    def build(
        cls, config: FleetConfig, atlas: Atlas, units: int = 20, slack_shifts: float = 0.0,
        credit: bool = False, orders: bool = False,
    ) -> BoundModel:  # fmt: skip
        """The model of an env's config and atlas (K of the ``id`` regime), every pad
        given ``slack_shifts`` hot shifts more than its expected life; with ``credit``
        the pad life left at the end is credited (:attr:`credit`), with ``orders`` a
        service pays its least share of an order (:attr:`order_share`)."""
        if config.regime != "id":
            raise ValueError(f"BoundModel: regime must be 'id', got {config.regime!r}")
        units = whole("BoundModel", "units", units, 1)
        slack_shifts = real("BoundModel", "slack_shifts", slack_shifts, 0.0)
        wear = route_wear_model(atlas, HOT_ROUTE)
        r_min = float(np.min(route_mean(atlas, MILD_ROUTE) / route_mean(atlas, HOT_ROUTE)))
        unit_events = config.events_per_shift / units
        # a pad of K six sd below the mean (P ~ 1e-9) outlives the cap only without credit
        longest = wear.life(max(config.k_mean - 6 * config.k_std, 1e-3 * config.k_mean))
        H = config.episode_shifts * units
        if credit:
            H = max(H, int(np.ceil(float(longest) / unit_events)) + units)
        program_fits(config, H + int(np.ceil(slack_shifts * units)), units)
        # P(ceil(life(K) / u) = j) = P(life_work / (j u) <= K < life_work / ((j - 1) u))
        j = np.arange(H + 1, dtype=np.float64)
        with np.errstate(divide="ignore"):
            k_edge = wear.life_work / (j * unit_events)  # K at which the life is j units
        cdf = norm.cdf(k_edge, config.k_mean, config.k_std)  # P(K < edge), decreasing in j
        prob = np.zeros(H + 1)
        prob[1:] = cdf[:-1] - cdf[1:]
        prob[H] += cdf[H] - norm.cdf(0.0, config.k_mean, config.k_std)  # life >= the cap
        prob /= prob.sum()  # (drops P(K <= 0) ~ 1e-23: no pad has it)
        slack = int(np.ceil(slack_shifts * units))
        if slack > 0:
            prob = np.concatenate([np.zeros(slack), prob[:-slack]])
            prob[-1] += 1.0 - prob.sum()
        per_unit = (
            (config.costs.pad + config.costs.labour) * unit_events / float(wear.life(config.k_mean))
        )
        mild = int(np.floor(units * r_min))
        share = config.costs.order / config.max_order if orders else 0.0
        return cls(config, units, mild, prob, wear, slack, per_unit if credit else 0.0, share)

    @property
    def H(self) -> int:
        """Largest state (the cap)."""
        return int(self.new_prob.size - 1)

    @property
    def D(self) -> int:
        """Shop states 0 (available) .. the longest stay."""
        c = self.config
        return max(c.failure_repair_shifts, c.breakdown_repair_shifts) + 1

    def state(self, volume_frac: F64, k: F64) -> I64:
        """Each pad's state: its expected hot RUL in units, rounded up, in [0, H]."""
        if self.wear is None:
            raise ValueError("BoundModel.state: a toy model has no wear clock")
        v = np.clip(volume_frac, self.wear.lower_edges[-1], 1.0)
        x = self.wear.rul(v, k) * self.units / self.config.events_per_shift
        return np.clip(np.ceil(x - 1e-9) + self.slack, 0, self.H).astype(np.int64)

    @property
    def fit_cost(self) -> float:
        c = self.config.costs
        return c.labour + c.pad

    def fail_cost(self, t: int) -> float:
        """A failure in shift ``t``: damage, the fit, and the downtime of the shifts out
        that fall within the episode."""
        c = self.config
        out = min(c.failure_repair_shifts, c.episode_shifts - 1 - t)
        return c.costs.damage + self.fit_cost + c.costs.downtime * out


@dataclass(frozen=True)
class Prices:
    """Prices of the linking constraints per shift, shape (episode_shifts,) each.

    Attributes:
        hot: ``lam``: the hot need's price (0 at windows).
        work: ``mu``: the working need's price (hot + mild; 0 at windows).
        bay: ``nu``: a bay's price between windows (0 at windows).
        crew: ``omega``: a window slot's price (0 between windows).
    """

    hot: F64
    work: F64
    bay: F64
    crew: F64

    @classmethod
    def zeros(cls, config: FleetConfig) -> Prices:
        z = np.zeros(config.episode_shifts)
        return cls(z, z.copy(), z.copy(), z.copy())

    def constant(self, config: FleetConfig) -> float:
        """The prices' constant, added to the vehicles' costs in the bound: the needs'
        prices times the needs (the vehicles earn them back by working), less the
        capacities' prices times the capacities (the vehicles pay them per use)."""
        c = config
        needs = self.hot * c.hot_need + self.work * (c.hot_need + c.mild_need)
        return float(needs.sum() - c.bays * self.bay.sum() - c.window_slots * self.crew.sum())

    def project(self, config: FleetConfig) -> Prices:
        """The nearest prices in the boxes of the module docstring (Euclidean, per shift)."""
        w = np.array([config.is_window(t) for t in range(config.episode_shifts)])
        lam, mu = project_needs(self.hot, self.work, config.costs.shortfall,
                                config.costs.mild_shortfall)  # fmt: skip
        pos = np.maximum
        return Prices(
            np.where(w, 0.0, lam), np.where(w, 0.0, mu),
            np.where(w, 0.0, pos(self.bay, 0.0)), np.where(w, pos(self.crew, 0.0), 0.0),
        )  # fmt: skip


def project_needs(lam: F64, mu: F64, c_h: float, c_m: float) -> tuple[F64, F64]:
    """Euclidean projection of each (lam, mu) onto {lam >= 0, 0 <= mu <= c_m, lam + mu <=
    c_h} (c_m <= c_h assumed; else c_m is taken as c_h)."""
    c_m = min(c_m, c_h)
    corners = np.array([[0.0, 0.0], [c_h, 0.0], [c_h - c_m, c_m], [0.0, c_m]])
    p = np.stack([lam, mu], axis=-1)
    inside = (p[:, 0] >= 0) & (p[:, 1] >= 0) & (p[:, 1] <= c_m) & (p.sum(axis=1) <= c_h)
    best, best_d = p.copy(), np.full(len(p), np.inf)
    for a, b in zip(corners, np.roll(corners, -1, axis=0), strict=True):
        e = b - a
        s = np.clip(((p - a) @ e) / max(float(e @ e), 1e-300), 0.0, 1.0)
        q = a + s[:, None] * e
        d = ((p - q) ** 2).sum(axis=1)
        better = d < best_d
        best[better], best_d[better] = q[better], d[better]
    out = np.where(inside[:, None], p, best)
    return out[:, 0], out[:, 1]


@dataclass(frozen=True)
class Program:
    """A vehicle's optimal costs under some prices.

    Attributes:
        values: ``V[t, h, d]`` for t = 0..episode_shifts (0 at the end).
        policy: An optimal action (0 hot, 1 mild, 2 park, 3 service) ``[t, h, d]``.
    """

    values: F64
    policy: NDArray[np.int8]


def q_values(model: BoundModel, prices: Prices, t: int, v_next: F64) -> F64:
    """Cost of each action (hot, mild, park, service; stacked first) from every state at
    shift ``t``, then optimally, given the values ``v_next`` of shift t + 1; +inf where
    not allowed (driving when down or at a window)."""
    c = model.config
    H, D, m, cm = model.H, model.D, model.units, model.mild_units
    window = c.is_window(t)
    dec = np.maximum(np.arange(D) - 1, 0)
    new = model.new_prob @ v_next  # (D,): after a new pad, by shop state
    q = np.full((4, H + 1, D), np.inf)
    q[PARK] = v_next[:, dec]
    fit = np.full(D, model.fit_cost + model.order_share)
    if window:
        fit += prices.crew[t]
    else:
        fit[0] += c.costs.shop_visit + prices.bay[t]
    q[SERVICE] = (fit + new[dec])[None, :]
    if not window:
        q[PARK, :, 1:] += prices.bay[t] * c.bays / c.n_vehicles  # a shift down in a bay
        q[SERVICE, :, 1:] += prices.bay[t] * c.bays / c.n_vehicles
        p, R, F = c.breakdown_rate, c.breakdown_repair_shifts, c.failure_repair_shifts
        drive = (1 - p) * v_next[:, 0] + p * v_next[:, R] if p > 0 else v_next[:, 0]
        fail = model.fail_cost(t) + new[F]
        for action, used, earn in ((HOT, m, prices.hot[t] + prices.work[t]),
                                   (MILD, cm, prices.work[t])):  # fmt: skip
            after = np.full(H + 1, fail)
            after[used:] = drive[: H + 1 - used]
            q[action, :, 0] = after - earn
    return q


def solve(model: BoundModel, prices: Prices) -> Program:
    """Backward induction over the episode (terminal value: minus the credit for the pad
    life left, 0 without credit)."""
    bound_inputs("solve", model, prices)
    T = model.config.episode_shifts
    values = np.zeros((T + 1, model.H + 1, model.D))
    values[T] = -model.credit * np.arange(model.H + 1)[:, None]  # the pad life left
    policy = np.zeros((T, model.H + 1, model.D), dtype=np.int8)
    for t in range(T - 1, -1, -1):
        q = q_values(model, prices, t, values[t + 1])
        policy[t] = q.argmin(axis=0)
        values[t] = np.take_along_axis(q, policy[t][None].astype(np.int64), axis=0)[0]
    return Program(values, policy)


@dataclass(frozen=True)
class Occupation:
    """Expected numbers over the vehicles per shift under their optimal policies.

    Attributes:
        hot, mild, visits, down, window_fits: Vehicles on each route, on an unscheduled
            visit, down in the shop (at the shift's start) and fitted at a window.
    """

    hot: F64
    mild: F64
    visits: F64
    down: F64
    window_fits: F64


def occupation(model: BoundModel, program: Program, start: F64) -> Occupation:
    """Propagate the vehicles' state counts forward under ``program``'s policy from
    ``start`` (expected vehicles at each h, nobody down)."""
    c = model.config
    T, H, D = c.episode_shifts, model.H, model.D
    p, R, F = c.breakdown_rate, c.breakdown_repair_shifts, c.failure_repair_shifts
    dec = np.maximum(np.arange(D) - 1, 0)
    x = np.zeros((H + 1, D))
    x[:, 0] = start
    out = {k: np.zeros(T) for k in ("hot", "mild", "visits", "down", "window_fits")}
    for t in range(T):
        a = program.policy[t]
        nxt = np.zeros_like(x)
        for d in range(D):
            nxt[:, dec[d]] += np.where(a[:, d] == PARK, x[:, d], 0.0)
        serviced = np.where(a == SERVICE, x, 0.0).sum(axis=0)  # (D,)
        nxt += np.outer(model.new_prob, np.bincount(dec, weights=serviced, minlength=D))
        failed = 0.0
        for action, used in ((HOT, model.units), (MILD, model.mild_units)):
            drv = np.where(a[:, 0] == action, x[:, 0], 0.0)
            out["hot" if action == HOT else "mild"][t] = drv.sum()
            failed += drv[:used].sum()
            nxt[: H + 1 - used, 0] += (1 - p) * drv[used:]
            nxt[: H + 1 - used, R] += p * drv[used:]
        nxt[:, F] += failed * model.new_prob
        if c.is_window(t):
            out["window_fits"][t] = serviced.sum()
        else:
            out["visits"][t] = serviced[0]
            out["down"][t] = x[:, 1:].sum()
        x = nxt
    return Occupation(**out)


def bound(model: BoundModel, program: Program, prices: Prices, start: F64) -> float:
    """The lower bound: the vehicles' optimal costs from ``start`` (expected vehicles at
    each h, nobody down; counts of one episode's vehicles, or their mean over episodes)
    plus the prices' constant (:meth:`Prices.constant`), less the orders' share of the
    initial stock (:attr:`BoundModel.order_share`)."""
    c = model.config
    bound_inputs("bound", model, prices, start)
    given_back = model.order_share * c.initial_stock
    return float(start @ program.values[0][:, 0] + prices.constant(c) - given_back)


def supergradient(model: BoundModel, occ: Occupation) -> Prices:
    """The slack of each relaxed constraint under the vehicles' optimal policies: a
    supergradient of the bound in the prices."""
    c = model.config
    w = np.array([c.is_window(t) for t in range(c.episode_shifts)])
    g = Prices(
        c.hot_need - occ.hot,
        c.hot_need + c.mild_need - occ.hot - occ.mild,
        occ.visits + occ.down * c.bays / c.n_vehicles - c.bays,
        occ.window_fits - c.window_slots,
    )
    zero = np.zeros(c.episode_shifts)
    return replace(
        g, hot=np.where(w, zero, g.hot), work=np.where(w, zero, g.work),
        bay=np.where(w, zero, g.bay), crew=np.where(w, g.crew, zero),
    )  # fmt: skip


def start_counts(model: BoundModel, states: I64) -> F64:
    """Vehicles at each h (``states``: one row per episode, or one episode's states): the
    mean over episodes."""
    raw = np.atleast_2d(np.asarray(states))
    ok = raw.dtype.kind in "iu" or (raw.dtype.kind == "f" and bool(np.all(raw == np.round(raw))))
    bad = raw[(raw < 0) | (raw > model.H)] if ok else raw[raw != np.round(raw)]
    if bad.size or raw.dtype.kind not in "iuf":
        raise ValueError(
            f"start_counts: states must be integers in [0, {model.H}], got"
            f" {bad.ravel()[0] if bad.size else raw.dtype}"
        )
    s = raw.astype(np.int64)
    return np.bincount(s.ravel(), minlength=model.H + 1).astype(np.float64) / s.shape[0]


__all__ = [
    "ACTIONS", "BoundModel", "Occupation", "Prices", "Program", "bound", "occupation",
    "project_needs", "q_values", "solve", "start_counts", "supergradient",
]  # fmt: skip
