"""The perfect-information reference of BrakeWearFleet-v0 on a small fleet: an exact dynamic
program and the policy that follows it in the env.

Model (what is idealised). Each vehicle's state is its pad's RUL in whole shifts of hot
duty, ``h = floor(rul_hot / events_per_shift)``, and the shifts it is still in the shop
after a breakdown, ``d``. The pad's true volume and K are known; ``rul_hot`` is the
expected events to failure on the hot route, in closed form from the atlas's layer wear
(:func:`~brake_env.env.fleet.routes.route_wear_model`). A shift on the hot route lowers
``h`` by exactly one: the wear of a shift's ~400 events is nearly deterministic (law of
large numbers), and the hot RUL is counted in those shifts whatever the layer. A shift on
the mild route uses ``r(h)`` of a hot shift, the mild route's wear per event over the hot
route's in the layer the pad is in at state ``h`` (the atlas's route means, 0.15-0.21):
the program lowers ``h`` by one with probability ``r(h)`` (its expected wear; the one
approximation of the program's clock). Parking does not wear. A new pad's ``h`` is drawn
from ``n_k`` equal-probability quantiles of K; once fitted its K is known (perfect
information on the pads, not on future pads' K).

Idealised: spares are always in stock (each fit pays the pad; no order nor holding cost,
no lead time); a failure costs damage, ``failure_repair_shifts`` shifts of downtime,
labour and pad, and the vehicle is back with a new pad next shift (the shifts out are not
modelled; the optimum avoids failures). As in the env: other breakdowns (a vehicle that
drove breaks down with probability ``breakdown_rate`` and is in the shop for
``breakdown_repair_shifts``, where it may get pads for labour and pad alone); window
shifts (nobody drives, fits cost labour and pad, at most ``window_slots`` of them);
between windows a fit is a visit (visit cost, labour, pad; the vehicle is out for the
shift). Bays are not modelled: on two vehicles a second visit in one shift is never
worth it; the policy in the env respects them anyway.

Per shift the decision is joint over the vehicles: hot, mild, park or service each; a
shortfall costs ``shortfall`` per vehicle short of ``hot_need`` and ``mild_shortfall``
per vehicle short of ``mild_need`` (hot vehicles beyond the hot need count towards it).
The value is solved by backward induction over the episode plus a ``tail`` of shifts (so
that the plan does not exploit the episode's end: a mine does not stop after the
episode); the predicted cost of an episode is the value of following that plan for the
episode's shifts from its first state.
The state space is ``((H + 1) * (R + 1)) ** n`` per shift (R the breakdown repair shifts),
so the program is for one or two vehicles.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.stats import norm

from agents.fleet.policies.base import FleetPolicy
from agents.fleet.policies.rules import reorder
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.model import can_drive
from brake_env.env.fleet.routes import HOT as HOT_ROUTE
from brake_env.env.fleet.routes import MILD as MILD_ROUTE
from brake_env.env.fleet.routes import route_mean, route_wear_model
from brake_env.env.fleet.rules import fits_capacity, shortfall_cost
from brake_env.env.fleet.shop import HOT, MILD, PARK, SERVICE
from brake_env.model.atlas import Atlas
from brake_env.model.wear import WearModel

F64 = NDArray[np.float64]
MAX_VEHICLES = 2
CHOICES = (HOT, MILD, PARK, SERVICE)


@dataclass(frozen=True)
class ReferenceModel:
    """The idealised small fleet (module docstring).

    Attributes:
        config: The env's config (costs, window period, hot need, horizon).
        wear: The hot route's wear clock (RUL from volume and K).
        h_new: Hot-shift lives of a new pad at the K quantiles, shape (n_k,).
        w_new: Their probabilities (equal), shape (n_k,).
        r_mild: Hot shifts a mild shift uses at each state h (the probability the program
            lowers h by one on the mild route), shape (H + 1,).
    """

    config: FleetConfig
    wear: WearModel
    h_new: NDArray[np.int64]
    w_new: F64
    r_mild: F64

    @classmethod
    def build(cls, config: FleetConfig, atlas: Atlas, n_k: int = 16) -> ReferenceModel:
        """The model of an env's config and atlas; K quantiles of the ``id`` regime."""
        if config.n_vehicles > MAX_VEHICLES:
            raise ValueError(
                f"ReferenceModel: the exact program is for <= {MAX_VEHICLES} vehicles,"
                f" got n_vehicles={config.n_vehicles}"
            )
        if config.regime != "id":
            raise ValueError(f"ReferenceModel: regime must be 'id', got {config.regime!r}")
        if n_k < 1:
            raise ValueError(f"ReferenceModel: n_k must be >= 1, got {n_k}")
        q = (np.arange(n_k) + 0.5) / n_k
        k = config.k_mean + config.k_std * norm.ppf(q)
        wear = route_wear_model(atlas, HOT_ROUTE)
        h_new = np.floor(wear.life(k) / config.events_per_shift).astype(np.int64)
        # the layer a pad of the mean K is in, half a hot shift into state h
        h = np.arange(int(h_new.max()) + 1) + 0.5
        work = wear.life_work - h * config.events_per_shift * config.k_mean
        layer = wear.layer_at_work(np.clip(work, 0.0, wear.life_work))
        ratio = route_mean(atlas, MILD_ROUTE) / route_mean(atlas, HOT_ROUTE)
        return cls(config, wear, h_new, np.full(n_k, 1.0 / n_k), ratio[layer])

    @property
    def H(self) -> int:
        """Largest state (a new pad of the lowest K quantile)."""
        return int(self.h_new.max())

    def state(self, volume_frac: F64, k: F64, safety: float = 0.0) -> NDArray[np.int64]:
        """Each pad's state: whole hot shifts left, less ``safety`` shifts, in [0, H]."""
        v = np.clip(volume_frac, self.wear.lower_edges[-1], 1.0)
        h = self.wear.rul(v, k) / self.config.events_per_shift - safety
        return np.clip(np.floor(h), 0, self.H).astype(np.int64)

    @property
    def D(self) -> int:
        """Shop states of a vehicle: 0 (available) .. breakdown_repair_shifts."""
        return self.config.breakdown_repair_shifts + 1

    @property
    def shape(self) -> tuple[int, ...]:
        """Shape of a value array: (h, d) axes of each vehicle in turn."""
        return (self.H + 1, self.D) * self.config.n_vehicles

    def flat(self, h: NDArray[np.int64], d: NDArray[np.int64]) -> NDArray[np.int64]:
        """A vehicle's flat state index ``h * D + d`` (``d`` clipped into the model)."""
        return h * self.D + np.clip(d, 0, self.D - 1)

    @property
    def fit_cost(self) -> float:
        c = self.config.costs
        return c.labour + c.pad

    @property
    def visit_cost(self) -> float:
        return self.config.costs.shop_visit + self.fit_cost

    @property
    def fail_cost(self) -> float:
        c = self.config.costs
        return c.damage + c.downtime * self.config.failure_repair_shifts + self.fit_cost


def _new_pad(model: ReferenceModel, v: F64, axis: int) -> F64:
    """Expected value after a new pad on the h-axis ``axis`` (that axis of size 1)."""
    taken = np.take(v, model.h_new, axis=axis)
    mean = np.tensordot(taken, model.w_new.astype(v.dtype), axes=([axis], [0]))
    return np.expand_dims(mean, axis)


def _along(x: F64, axis: int, ndim: int) -> F64:
    return x.reshape([-1 if a == axis else 1 for a in range(ndim)])


def _after_each(model: ReferenceModel, v: F64, i: int, window: bool) -> dict[int, F64]:
    """Cost-to-go before vehicle ``i`` takes each choice, given the value ``v`` after it
    (axes ``2i`` its RUL h, ``2i + 1`` its shifts left in the shop d)."""
    ha, da = 2 * i, 2 * i + 1
    dec = np.maximum(np.arange(model.D) - 1, 0)  # a shift in the shop done
    new = _new_pad(model, v, ha)
    out = {PARK: np.take(v, dec, axis=da)}
    in_shop = np.arange(model.D) > 0
    fit = np.where(in_shop | window, model.fit_cost, model.visit_cost).astype(v.dtype)
    out[SERVICE] = np.take(np.broadcast_to(new, v.shape), dec, axis=da) + _along(fit, da, v.ndim)
    if window:
        return out
    # HOT, only from d = 0: one shift of hot life, then a breakdown with probability p; at
    # h = 0 the pad fails (corrective fit, the vehicle back next shift: idealised).
    p = v.dtype.type(model.config.breakdown_rate)
    d0 = np.take(v, [0], axis=da)
    # (p = 0 kept apart: 0 * inf, a blocked state of another vehicle, would be nan)
    drive = d0 if p == 0 else (1 - p) * d0 + p * np.take(v, [model.D - 1], axis=da)
    fail = v.dtype.type(model.fail_cost) + np.take(new, [0], axis=da)
    hot = np.concatenate([fail, np.take(drive, np.arange(model.H), axis=ha)], axis=ha)
    # MILD: a hot shift's step with probability r(h), else the pad stays at h
    r = _along(model.r_mild.astype(v.dtype), ha, v.ndim)
    with np.errstate(invalid="ignore"):  # 0 * inf where another vehicle cannot drive
        mild = r * hot + (1 - r) * drive
    mild = np.where(r == 0, drive, np.where(r == 1, hot, mild))
    shape = list(hot.shape)
    shape[da] = model.D - 1
    blocked = np.full(shape, np.inf, dtype=v.dtype)  # in the shop: it cannot drive
    out[HOT] = np.concatenate([hot, blocked], axis=da)
    out[MILD] = np.concatenate([mild, blocked], axis=da)
    return out


def joint_choices(model: ReferenceModel, window: bool) -> list[tuple[int, ...]]:
    """Joint decisions of a shift: at a window park or service (at most ``window_slots``
    services), else hot, mild, park or service."""
    if not window:
        return list(itertools.product(CHOICES, repeat=model.config.n_vehicles))
    c = model.config
    joints = itertools.product((PARK, SERVICE), repeat=c.n_vehicles)
    no_one_down = np.zeros(c.n_vehicles, dtype=bool)  # spares always in stock (the model's)
    return [j for j in joints if fits_capacity(c, True, np.array(j) == SERVICE, no_one_down,
                                               c.n_vehicles, 0)]  # fmt: skip


def shift_cost(model: ReferenceModel, joint: tuple[int, ...], window: bool) -> float:
    """The shortfall of a joint decision (its fits are priced in :func:`_after_each`)."""
    return shortfall_cost(model.config, joint.count(HOT), joint.count(MILD), window)


def q_values(model: ReferenceModel, v_next: NDArray[Any], window: bool) -> NDArray[Any]:
    """Cost-to-go of every joint decision (:func:`joint_choices` order, stacked first) in
    every state; +inf where a vehicle in the shop would drive. Built from the last vehicle
    back, sharing each partial result among the decisions that have it."""
    partial: dict[tuple[int, ...], F64] = {(): v_next}
    for i in range(model.config.n_vehicles - 1, -1, -1):
        partial = {
            (choice, *rest): x
            for rest, v in partial.items()
            for choice, x in _after_each(model, v, i, window).items()
        }
    joints = joint_choices(model, window)
    q = np.empty((len(joints), *v_next.shape), dtype=v_next.dtype)
    for k, joint in enumerate(joints):
        q[k] = partial[joint] + shift_cost(model, joint, window)
    return q


@dataclass(frozen=True)
class Solution:
    """The program's values.

    Attributes:
        values: Optimal cost-to-go ``V[t]`` (axes (h, d) per vehicle) for t in
            0..episode_shifts (float32).
        plan_cost: Cost of following the optimal decisions for the episode's shifts only
            (terminal 0 at the episode's end), same shape: the predicted episode cost.
    """

    values: NDArray[np.float32]
    plan_cost: NDArray[np.float32]

    def predicted(self, model: ReferenceModel, h: NDArray[np.int64]) -> float:
        """Predicted episode cost from shift 0 with RUL states ``h``, nobody in the shop."""
        return float(self.plan_cost[0][tuple(x for hv in h for x in (int(hv), 0))])


def solve(model: ReferenceModel, tail: int = 0) -> Solution:
    """Backward induction over ``episode_shifts + tail`` shifts (terminal value 0)."""
    c = model.config
    T = c.episode_shifts
    values = np.zeros((T + 1, *model.shape), dtype=np.float32)
    plan = np.zeros((T + 1, *model.shape), dtype=np.float32)
    v = np.zeros(model.shape, dtype=np.float32)  # float32: half the memory traffic
    for t in range(T + tail - 1, -1, -1):  # values[T] is the tail's value (0 if none)
        window = c.is_window(t)
        q = q_values(model, v, window)
        best = q.argmin(axis=0)[None]
        v = np.take_along_axis(q, best, axis=0)[0]
        if t <= T:
            values[t] = v
        if t < T:
            qp = q_values(model, plan[t + 1], window)
            plan[t] = np.take_along_axis(qp, best, axis=0)[0]
    return Solution(values, plan)


class ReferencePolicy(FleetPolicy):
    """Follows the program in the env: each shift, among the joint decisions the env allows
    (down vehicles only park or get pads; services within stock and free bays), the one of
    least shift cost plus expected value of the next shift's state (one-step look-ahead on
    the solved values, which is the program's own decision wherever the env is in the
    model). It reads the env's truth (true volume and K): a reference, never deployable.
    Spares are reordered by (s, S).

    Args:
        env: The BrakeWearFleet-v0 it acts on (any wrapper; its ``unwrapped`` is read).
        model: The reference model of that env.
        solution: ``solve(model, tail)``.
        s, S: Reorder rule of the spares.
        safety: Shifts taken off each pad's RUL (the law of large numbers is not exact).
    """

    def __init__(
        self, env: Any, model: ReferenceModel, solution: Solution, s: int = 1, S: int = 2,
        safety: float = 0.0,
    ) -> None:  # fmt: skip
        self.env, self.model, self.solution = env, model, solution
        self.s, self.S, self.safety = s, S, safety

    def action(self, observation: NDArray[Any]) -> NDArray[np.int64]:
        """The decision on the env's truth (the observation is not read)."""
        base = self.env.unwrapped
        c, shop = base.config, base.shop
        truth = base.truth()
        h = self.model.state(truth["volume_frac"], truth["wear_coeff"], self.safety)
        joint = self.decide(base.shift, h, shop.down.copy(), shop.stock, shop.free_bays())
        fits = sum(j == SERVICE for j in joint)
        order = reorder(shop.stock, shop.in_transit, fits, self.s, self.S, c.max_order)
        return np.array([*joint, order], dtype=np.int64)

    def decide(
        self, shift: int, h: NDArray[np.int64], down: NDArray[np.int64], stock: int, bays: int
    ) -> tuple[int, ...]:
        """The best joint decision the env allows at ``shift`` with RUL states ``h`` and
        shifts left in the shop ``down`` (a vehicle down after a failure, off the model,
        is taken as in the shop after a breakdown)."""
        m, c = self.model, self.model.config
        window = c.is_window(shift)
        v_next = self.solution.values[min(shift + 1, c.episode_shifts)].astype(np.float64)
        v_next = v_next.reshape((m.D * (m.H + 1),) * c.n_vehicles)
        options = [CHOICES if d else (PARK, SERVICE) for d in can_drive(down, window)]
        best, best_q = tuple(PARK for _ in down), np.inf
        for joint in itertools.product(*options):
            fits = np.array([j == SERVICE for j in joint])
            if not fits_capacity(c, window, fits, down > 0, stock, bays):
                continue
            q = self._q(h, down, joint, window, v_next)
            if q < best_q:
                best, best_q = joint, q
        return best

    def _q(
        self, h: NDArray[np.int64], down: NDArray[np.int64], joint: tuple[int, ...],
        window: bool, v_next: F64,
    ) -> float:  # fmt: skip
        """Shift cost plus expected next value of one joint decision (flat states)."""
        m = self.model
        states, probs, cost = [], [], shift_cost(m, joint, window)
        for hv, dv, choice in zip(h, down, joint, strict=True):
            x, p, c = _outcomes(m, int(hv), int(dv), choice, window)
            states.append(x)
            probs.append(p)
            cost += c
        return float(cost + _expect(v_next[np.ix_(*states)], probs))


Outcomes = tuple[NDArray[np.int64], F64, float]


def _outcomes(m: ReferenceModel, h: int, d: int, choice: int, window: bool) -> Outcomes:
    """A vehicle's next flat states, their probabilities and the expected cost of its
    choice from state (h, d), by the program's transitions."""
    d_next = max(min(d, m.D - 1) - 1, 0)
    if choice == PARK:
        return m.flat(np.array([h]), np.array([d_next])), np.ones(1), 0.0
    if choice == SERVICE:
        fit = m.fit_cost if (window or d > 0) else m.visit_cost
        return m.flat(m.h_new, np.full(m.h_new.size, d_next)), m.w_new, fit
    p = m.config.breakdown_rate

    def drive(hh: int) -> Outcomes:  # one shift driven, then a breakdown with probability p
        return m.flat(np.array([hh, hh]), np.array([0, m.D - 1])), np.array([1 - p, p]), 0.0

    fail = (m.flat(m.h_new, np.zeros(m.h_new.size, dtype=np.int64)), m.w_new, m.fail_cost)
    step = drive(h - 1) if h >= 1 else fail
    if choice == HOT:
        return step
    r = float(m.r_mild[h])
    stay = drive(h)
    return (
        np.concatenate([step[0], stay[0]]),
        np.concatenate([r * step[1], (1 - r) * stay[1]]),
        r * step[2],
    )


def _expect(value: F64, probs: list[F64]) -> float:
    """Expectation of the rest of the axes of ``value`` under ``probs`` (one per axis)."""
    for p in probs:
        value = np.tensordot(p, value, axes=([0], [0]))
    return float(value)
