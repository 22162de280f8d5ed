"""A Lagrangian lower bound on the expected episode cost of every non-anticipative policy on
BrakeWearFleet-v0, at any fleet size: the constraints that link the vehicles are priced,
each vehicle then solves its own small program (Hawkins 2003; Adelman and Mersereau 2008;
DESIGN.md 11).

**The claim.** For any prices in the boxes below, the vehicles' optimal costs plus the
prices' constant are at most the expected cost of every policy whose decisions at a shift
use only what has happened up to it (the pads' volumes and K included, whatever it
observes of them), on the episode's start. Not of a clairvoyant policy: the env draws the
breakdowns and the pads' conditions ahead, and one that read them could do better. With
:meth:`BoundModel.relaxed` every idealisation below can only lower the cost, but one holds
with a stated probability: each pad's realised wear stays within the slack with
probability ``coverage`` (0.99 by default); for a pad outside it the bound is not proved.

**Per-vehicle model.** A vehicle's state is ``(h, d)``: ``h`` its pad's expected RUL on
the hot route in clock units of ``1 / units`` of a hot shift, rounded **up**
(``h = ceil(rul_hot * units / events_per_shift)``) plus ``slack`` units, and ``d`` the
shifts it is still down in the shop (``0 .. max(failure_repair_shifts,
breakdown_repair_shifts)``). A hot shift uses exactly ``units`` units (the hot RUL is
counted in hot events); a mild shift ``mild_use[h]`` (:mod:`.lagrangian_wear`; without
layers ``floor(units * r_min)``, ``r_min`` the least mild-over-hot wear ratio of the atlas's
layers); parking none. The pad fails in a shift that needs more units than it has. ``h`` is
capped at ``episode_shifts * units`` (a pad with more cannot fail within the episode), or
with credit above every pad's life.

**Idealisations** (each can only lower the cost):

- Rounding up, ``floor`` of the mild use, and the mild use by layer at most the pad's own
  (``K >= k_cut``; a pad below the cut gets its life times ``boost``): the model's pad
  never wears faster than the expected wear of the env's (:mod:`.lagrangian_wear`).
- Wear per shift at its expectation plus ``slack`` units of life: the env's pad wears a
  random amount; :func:`~.lagrangian_wear.realised_slack` sizes the slack so that a share
  ``coverage`` of pads never runs ahead of its expected path by more (an idealisation
  that holds with a probability, not always). ``build`` alone (no slack) is the old
  approximation at the expectation, kept for the policies that plan on it.
- The current pad's K known once fitted: an information relaxation. New pads' ``h`` is
  drawn from the exact distribution of their state under the config's law of K (the
  regime's normals, each truncated at 0: :func:`~.lagrangian_wear.k_cdf`).
- States beyond the cap H (slow pads, outside ``id``): H >= the episode's hot units, so no
  pad there fails within it and the value is the value at H less the credit beyond, exactly;
  a fit is credited the expected units beyond (rounded up, ``new_tail``), the start its
  pads' own (``excess``). With new pads' K taken as at least its ``FLOOR_SHARE`` quantile
  (the slow normal cut at 0 has a density at 0: no finite mean life), it holds on the paths
  where no new pad's K is below (each with probability 1 - 1e-6), like the slack.
- Spares always in stock, no order nor holding cost, no lead time (non-negative costs and
  a constraint dropped); every fit pays ``pad + labour`` (the headline cost prices pads
  when fitted). With ``orders`` a service also pays ``order / max_order`` and the bound
  gives back that much for each pad of the initial stock: every pad fitted was in stock at
  the start or arrived by an order of at most ``max_order`` pads (nothing is in transit at
  the start), so the orders cost at least ``order / max_order`` times the fits beyond the
  initial stock (failures' fits are not charged, holding still is not).
- A failure costs ``damage + pad + labour`` and ``downtime`` for each of the
  ``failure_repair_shifts`` shifts out that fall within the episode; the vehicle is down
  (cannot drive) for them, with a new pad: the env's rule, exactly. Breakdowns as in the
  env: after a driven shift without failure, down for ``breakdown_repair_shifts`` with
  probability ``breakdown_rate``.
- The schedule throws no pad life away beyond the rounding (a fit at any shift), and the
  credit of the life left at the end is per unit of the model's ``h`` (at least the env's).

**Prices**: :mod:`.lagrangian_prices` (what each price charges and why it is a relaxation).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from agents.fleet.policies.checks import bound_inputs, program_fits, real, whole
from agents.fleet.policies.lagrangian_prices import Prices, project_needs
from agents.fleet.policies.lagrangian_wear import (
    k_floor,
    mild_ratios,
    mild_use,
    new_pad_prob,
    new_pad_tail,
    realised_slack,
)
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.episode_cost import credit_life
from brake_env.env.fleet.routes import HOT as HOT_ROUTE
from brake_env.env.fleet.routes import route_wear_model
from brake_env.env.fleet.shop import HOT, MILD, PARK, SERVICE
from brake_env.model.atlas import Atlas
from brake_env.model.wear import WearModel

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]
ACTIONS = (HOT, MILD, PARK, SERVICE)
FLOOR_SHARE = 1e-6  # new pads' K below this quantile count as it in the credit beyond H


@dataclass(frozen=True)
class BoundModel:
    """One vehicle's relaxed model (module docstring).

    Attributes:
        config: The env's config (costs, needs, bays, slots, horizon).
        units: Clock units per hot shift [-].
        mild_units: Units a mild shift uses where ``mild_use`` is None [-].
        new_prob: Probability that a new pad's state is ``h``, for h = 0..H [-].
        wear: The hot route's wear clock (RUL from volume and K); None in toy models.
        slack: Units added to every pad's state (its own and new pads'): a pad that
            outlives its expected life by up to ``slack`` units is still within the model's.
        credit: Terminal credit per unit of pad life left at the episode's end (0: none;
            :meth:`build` with ``credit=True`` prices it as
            :func:`agents.fleet.evaluation.costs.life_value` does). With it the bound is
            on the cost less that credit (:attr:`EpisodeCost.net`); the state's cap is
            then above every pad's life, so the credit is never cut.
        order_share: Order cost charged per service (``order / max_order`` with
            ``orders``; module docstring), given back for the initial stock.
        mild_use: Units a mild shift uses from each state 0..H (by layer,
            :func:`~.lagrangian_wear.mild_use`); None: ``mild_units`` everywhere.
        k_cut: Pads of K below it enter with ``boost`` times their life [-].
        boost: The life factor of pads below ``k_cut`` (>= 1) [-].
        new_tail: A new pad's expected units beyond H (at least), credited at a fit
            (:func:`~.lagrangian_wear.new_pad_tail`; 0 in ``id``: H holds all but P ~ 1e-9).
        k_floor: New pads' K taken as at least this in ``new_tail`` [-].
    """

    config: FleetConfig
    units: int
    mild_units: int
    new_prob: F64
    wear: WearModel | None = None
    slack: int = 0
    credit: float = 0.0
    order_share: float = 0.0
    mild_use: I64 | None = None
    k_cut: float = 0.0
    boost: float = 1.0
    new_tail: float = 0.0
    k_floor: float = 0.0

    @classmethod
    def build(
        cls, config: FleetConfig, atlas: Atlas, units: int = 20, slack_shifts: float = 0.0,
        credit: bool = False, orders: bool = False, *, layers: bool = False,
        k_cut_sd: float = 3.0,
    ) -> BoundModel:  # fmt: skip
        """The model of an env's config and atlas (K of the ``id`` regime), every pad
        given ``slack_shifts`` hot shifts more than its expected life; with ``credit``
        the pad life left at the end is credited (:attr:`credit`), with ``orders`` a
        service pays its least share of an order (:attr:`order_share`), with ``layers``
        a mild shift wears by the pad's layer for K above ``k_mean - k_cut_sd * k_std``."""
        if config.regime != "id" and layers:
            raise ValueError(f"BoundModel: mild wear by layer models the 'id' regime only, got"
                             f" {config.regime!r}")  # fmt: skip
        units = whole("BoundModel", "units", units, 1)
        slack_shifts = real("BoundModel", "slack_shifts", slack_shifts, 0.0)
        k_cut_sd = real("BoundModel", "k_cut_sd", k_cut_sd, 0.0)
        wear, ratios = route_wear_model(atlas, HOT_ROUTE), mild_ratios(atlas)
        k_cut = max(config.k_mean - k_cut_sd * config.k_std, 0.0) if layers else 0.0
        # a pad below the cut: any shifts it survives (>= r_min a mild one) fit in boost x
        boost = max(1.0, np.floor(units * ratios.max() + 1e-9) / (units * ratios.min()))
        boost = boost if k_cut > 0 else 1.0
        unit_events = config.events_per_shift / units
        slack = int(np.ceil(slack_shifts * units))
        # a pad of K six sd below the mean (P ~ 1e-9) outlives the cap only without credit
        longest = wear.life(max(config.k_mean - 6 * config.k_std, 1e-3 * config.k_mean))
        H = config.episode_shifts * units
        if credit:
            H = max(H, int(np.ceil(boost * float(longest) / unit_events)) + units + slack)
        program_fits(config, H, units)
        prob = new_pad_prob(wear, config, unit_events, H - slack, k_cut, boost)
        prob = np.concatenate([np.zeros(slack), prob])
        use = mild_use(wear, ratios, units, H, k_cut, unit_events) if k_cut > 0 else None
        per_unit = (
            (config.costs.pad + config.costs.labour) * unit_events / credit_life(config, wear)
        )
        mild = int(np.floor(units * ratios.min()))
        share = config.costs.order / config.max_order if orders else 0.0
        # outside id, slow pads outlive the cap: their units beyond are credited at a fit
        floor = k_floor(config, FLOOR_SHARE) if credit and config.regime != "id" else 0.0
        tail = new_pad_tail(wear, config, unit_events, H - slack, floor) if floor > 0 else 0.0
        return cls(config, units, mild, prob, wear, slack, per_unit if credit else 0.0, share,
                   use, k_cut, boost, tail, floor)  # fmt: skip

    @classmethod
    def relaxed(
        cls, config: FleetConfig, atlas: Atlas, units: int = 20, coverage: float = 0.99, *,
        credit: bool = False, orders: bool = False, pads: int = 256, seed: int = 0,
        layers: bool = False,
    ) -> BoundModel:  # fmt: skip
        """The bound's model (module docstring's claim): the slack of
        :func:`~.lagrangian_wear.realised_slack` at ``coverage`` (``pads`` simulated from
        ``seed``); with ``layers`` mild wear by layer too. Off by default: at 20 units it
        left the default fleet's bound unchanged (1.5065 at 20 price steps, with or
        without it; at 20 units a layer's use rounds to 3 or 4 twentieths, and the worn
        pads' deep layers to 3) and its cut's boost (3 sd) cost 0.0007."""
        slack = realised_slack(atlas, config, coverage, pads, seed)
        return cls.build(config, atlas, units, max(slack, 0.0), credit, orders, layers=layers)

    @property
    def H(self) -> int:
        """Largest state (the cap)."""
        return int(self.new_prob.size - 1)

    @property
    def D(self) -> int:
        """Shop states 0 (available) .. the longest stay."""
        c = self.config
        return max(c.failure_repair_shifts, c.breakdown_repair_shifts) + 1

    @property
    def mild_step(self) -> I64:
        """Units a mild shift uses from each state 0..H."""
        if self.mild_use is not None:
            return self.mild_use
        return np.full(self.H + 1, self.mild_units, dtype=np.int64)

    def state(self, volume_frac: F64, k: F64) -> I64:
        """Each pad's state: its expected hot RUL in units (times ``boost`` below
        ``k_cut``), rounded up, plus the slack, in [0, H]."""
        if self.wear is None:
            raise ValueError("BoundModel.state: a toy model has no wear clock")
        v = np.clip(volume_frac, self.wear.lower_edges[-1], 1.0)
        x = self.wear.rul(v, k) * self.units / self.config.events_per_shift
        x = np.where(np.asarray(k) < self.k_cut, x * self.boost, x)
        return np.clip(np.ceil(x - 1e-9) + self.slack, 0, self.H).astype(np.int64)

    @property
    def fit_cost(self) -> float:
        c = self.config.costs
        return c.labour + c.pad

    def excess(self, volume_frac: F64, k: F64) -> float:
        """The pads' units beyond the cap H, summed (:meth:`state` without its clip)."""
        if self.wear is None:
            return 0.0
        v = np.clip(volume_frac, self.wear.lower_edges[-1], 1.0)
        x = self.wear.rul(v, k) * self.units / self.config.events_per_shift
        x = np.where(np.asarray(k) < self.k_cut, x * self.boost, x)
        return float(np.maximum(np.ceil(x - 1e-9) + self.slack - self.H, 0.0).sum())

    def fail_cost(self, t: int) -> float:
        """A failure in shift ``t``: damage, the fit, and the downtime of the shifts out
        that fall within the episode."""
        c = self.config
        out = min(c.failure_repair_shifts, c.episode_shifts - 1 - t)
        return c.costs.damage + self.fit_cost + c.costs.downtime * out


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
    H, D, m = model.H, model.D, model.units
    window = c.is_window(t)
    dec = np.maximum(np.arange(D) - 1, 0)
    new = model.new_prob @ v_next - model.credit * model.new_tail  # (D,): after a new pad
    q = np.empty((4, H + 1, D))
    q[[HOT, MILD]] = np.inf  # driving: only from d = 0 between windows (below)
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
        hot = np.full(H + 1, fail)
        hot[m:] = drive[: H + 1 - m]
        q[HOT, :, 0] = hot - prices.hot[t] - prices.work[t]
        left = np.arange(H + 1) - model.mild_step  # the state after a mild shift
        q[MILD, :, 0] = np.where(left >= 0, drive[np.maximum(left, 0)], fail) - prices.work[t]
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
        best, act = values[t], policy[t]
        best[:] = q[0]
        for a in range(1, len(ACTIONS)):  # argmin over actions (the first on ties), fast
            better = q[a] < best
            np.copyto(best, q[a], where=better)
            act[better] = a
    return Program(values, policy)


def bound(
    model: BoundModel, program: Program, prices: Prices, start: F64, excess: float = 0.0
) -> float:
    """The lower bound: the vehicles' optimal costs from ``start`` (expected vehicles at
    each h, nobody down; counts of one episode's vehicles, or their mean over episodes)
    plus the prices' constant (:meth:`Prices.constant`), less the orders' share of the
    initial stock (:attr:`BoundModel.order_share`) and the credit of the start's units
    beyond the cap (``excess``, :meth:`BoundModel.excess`: a vehicle's value is linear in
    its state beyond the cap, which no pad there can wear through within the episode)."""
    c = model.config
    bound_inputs("bound", model, prices, start)
    given_back = model.order_share * c.initial_stock + model.credit * excess
    return float(start @ program.values[0][:, 0] + prices.constant(c) - given_back)


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
    "ACTIONS", "BoundModel", "Prices", "Program", "bound", "project_needs", "q_values", "solve",
    "start_counts",
]  # fmt: skip
