"""Multiagent rollout on a fleet rule (Bertsekas 2021): each shift the vehicles are decided
one at a time, each choice scored by simulating the base rule forward in the planning model
(:mod:`.planning`) over sampled futures with common random numbers.

**The decision.** Start from the base's action. A first pass scores, in one batch,
every single deviation from it (one vehicle's other allowed action, the others at the
base's); the vehicles where some deviation wins are then decided one at a time, least RUL
first: for vehicle ``i`` every action its mask allows is scored with the vehicles decided
before it at their chosen actions and the others at the base's. A score is a cost per
sampled future: the shift simulated with that joint action, then ``horizon - 1`` shifts
of the base rule (:mod:`.batch_rule`), plus a terminal value of the fleet at the horizon:
the per-vehicle programs' cost-to-go (:class:`~.planning.ProgramValue`; :func:`program_value`
builds it at the index policy's floored prices) when given, else each pad's hot life left
priced at ``(pad + labour) / mean_life`` a shift, so that using a pad up is not free.

**Common random numbers.** Every candidate and the base are scored on the same ``samples``
futures: the same sampled pad lives at the start, new pads and breakdowns (a difference
between two candidates is the effect of the action, not of the draws).

**Acceptance** (issue 43): the candidate of least mean cost replaces the current action only
if a one-sided paired t-test of its per-future difference rejects "no better" at
``alpha / m``, ``m`` the candidates compared in that pass (Bonferroni: with ~36 deviations a
shift, an uncorrected test would take a noise win most shifts). A candidate identical to the
current action has a difference of exactly 0 in every future and is never taken.
``confidence`` (standard errors, no correction) is the old rule, kept as an option.

**Bases.** A tuned :class:`~.rules.FleetRule`, simulated in the futures; or the index policy
(:class:`~.index.IndexPolicy`, its MILP a shift is too slow to run in thousands of futures):
then ``horizon`` is 1 and the terminal value is the index's own program, the base's
cost-to-go in the per-vehicle relaxation. Service is a candidate only below
``service_below`` shifts of hot life (or where the base sends it). The order is the base's
(s, S) on the chosen services. Cost per shift: about ``(3n + 1) x samples x horizon`` model
shifts in one batch, then as many again per vehicle contested.

**Measured** (``benchmarks/analysis/rollout_stability.py --mode agreement --predictors
oracle,twin --episodes 5 --every 15 --samples old,16,64``; 120 states of the tuned oracle
rule's dev episodes 0-4, 2026-11-28): two planner seeds decide the same joint duties at 96.7%
of states with 16 futures (departures from the base 5.0% and 4.2%), 95.0% with 64, and 94.2%
with the old planner (departures 6.7% and 8.3%); half the departures are repeated by the
other seed either way, so the agreement target holds because the planner rarely departs, not
because its departures are stable. With the twin's RUL: 93.3% with 16 futures (old 91.7%).
On the index policy (``--base index --predictors oracle --samples 16,64``, the same
states): 98.3% with 16 futures, 99.2% with 64 (departures 2.5%). Paired on dev episodes 0-9
(``--mode paired --samples 16 --episodes 10``), the mean over 3 planner seeds minus the tuned
rule: oracle 2.097 against 2.159, -0.062 [-0.174, -0.020] (seeds' means sd 0.021; per seed
-0.086, -0.046, -0.055); twin 2.184 against 2.405, -0.222 [-0.556, -0.079] (sd 0.068; per
seed -0.286, -0.151, -0.229); 123 and 186 CPU s for 10 episodes a seed.

**Beliefs, never the truth.** The futures start from what the observation shows: each pad's
hot life is sampled around the RUL the predictor gives, normal with the spread of its
interval where the layout has ``rul_lower`` and ``rul_upper`` (a 90% interval: half-width
over 1.645), the point estimate otherwise (the oracle's, or a predictor without an
interval); new pads from the config's K distribution; breakdowns by the config's rate. A
vehicle down in the shop is taken as down after a breakdown (the observation does not say
which). Inside the futures the base rule acts on the sampled lives (it sees the future's
pads as they are there).

**It does not exploit the episode's end**: futures run past it, with the terminal value,
as for a mine that goes on.
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents.fleet.policies import batch_rule
from agents.fleet.policies.base import FleetPolicy
from agents.fleet.policies.checks import fits_memory, real, whole
from agents.fleet.policies.index import CHOSEN as INDEX_CHOSEN
from agents.fleet.policies.index import IndexPolicy, floored, searched
from agents.fleet.policies.lagrangian import solve
from agents.fleet.policies.planning import FleetState, Futures, PlanningModel, ProgramValue
from agents.fleet.policies.rules import FleetRule, reorder
from agents.fleet.policies.view import FleetLayout, FleetView
from brake_env.env.fleet import model as fleet_model
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.rules import fits_capacity
from brake_env.env.fleet.shop import SERVICE
from brake_env.env.fleet.spaces import read_observation
from brake_env.model.atlas import Atlas

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]
Z90 = 1.6448536269514722  # a 90% interval's half-width in standard deviations
MAX_HORIZON, MAX_SAMPLES = 100_000, 1_000_000  # the env's longest episode; futures


class RolloutPolicy(FleetPolicy):
    """Multiagent rollout on ``base`` (module docstring), with SB3's ``predict`` signature.

    Args:
        base: A tuned rule, or the index policy (then ``horizon`` must be 1); its layout says
            where the RUL is.
        model: The planning model of the env's config and atlas.
        horizon: Shifts simulated per candidate (the first with the candidate).
        samples: Futures per candidate (common to all candidates).
        seed: Seed of the futures (with the shift: the same state, the same futures).
        alpha: Family-wise level of the acceptance test (Bonferroni over the candidates).
        confidence: If given, the old acceptance instead: the best candidate by more than
            this many standard errors of the paired difference, no correction.
        service_below: Hot life [shifts] below which service is a candidate.
        terminal: The terminal value (None: the index base's program, or pad life priced
            linearly for a rule).
    """

    def __init__(
        self, base: FleetRule | IndexPolicy, model: PlanningModel, horizon: int = 28,
        samples: int = 16, seed: int = 0, *, alpha: float = 0.05,
        confidence: float | None = None, service_below: float = 28.0,
        terminal: ProgramValue | None = None,
    ) -> None:  # fmt: skip
        who = "RolloutPolicy"
        horizon = whole(who, "horizon", horizon, 1, MAX_HORIZON)
        samples = whole(who, "samples", samples, 1, MAX_SAMPLES)
        seed = whole(who, "seed", seed, 0)
        self.alpha = real(who, "alpha", alpha, 0.0, 1.0)
        if confidence is None and (self.alpha in (0.0, 1.0) or samples < 2):
            raise ValueError(f"{who}: the test at alpha needs 0 < alpha < 1 and samples >= 2,"
                             f" got alpha={alpha}, samples={samples}")  # fmt: skip
        self.confidence = None if confidence is None else real(who, "confidence", confidence, 0.0)
        service_below = real(who, "service_below", service_below, 0.0, infinite=True)
        if not isinstance(base, FleetRule | IndexPolicy):
            raise ValueError(f"{who}: base must be a FleetRule or an IndexPolicy, got"
                             f" {type(base).__name__}")  # fmt: skip
        if isinstance(base, IndexPolicy):
            if horizon != 1:
                raise ValueError(f"{who}: with the index policy as base the horizon must be 1"
                                 f" (its program is the cost-to-go), got {horizon}")  # fmt: skip
            terminal = terminal or ProgramValue.of(base.model, base.program)
        if base.layout.config != model.config:
            raise ValueError("RolloutPolicy: the base and the model have different configs")
        n = model.config.n_vehicles
        fits_memory(
            who, 8.0 * samples * n * (horizon + 48 * (3 * n + 1)),
            f"{samples} futures of {horizon} shifts for {n} vehicles",
            "use fewer samples or a shorter horizon",
        )  # fmt: skip
        self.base, self.model = base, model
        self.horizon, self.samples, self.seed = horizon, samples, seed
        self.service_below, self.terminal = service_below, terminal
        self.name = f"rollout on {base.name}"
        self._orders: list[tuple[int, int]] = []  # (shift, quantity) this episode

    @property
    def layout(self) -> FleetLayout:
        return self.base.layout

    @property
    def reorder_points(self) -> tuple[int, int]:
        """The base's (s, S)."""
        b = self.base
        return (b.s, b.S) if isinstance(b, IndexPolicy) else (b.params.s, b.params.S)

    def action(self, observation: NDArray[Any]) -> I64:
        return self.act(observation)

    def act(self, observation: NDArray[Any]) -> I64:
        """The action (duties, then the order) for one observation."""
        view = FleetView.read(observation, self.layout)
        for name in ("rul", "rul_lower", "rul_upper"):
            x = getattr(view, name)
            if x is not None and not np.isfinite(x).all():
                v = int(np.flatnonzero(~np.isfinite(x))[0])
                raise ValueError(
                    f"{self.name}: the observation's {name.replace('rul', 'RUL')} of vehicle"
                    f" {v} is {x[v]}: the planner cannot sample a pad's life from it"
                )
        base = self.base
        duty = (base.act(observation) if isinstance(base, IndexPolicy) else base.act(view))[:-1]
        duty = duty.copy()
        rng = np.random.default_rng([self.seed, view.shift])
        start = self.start(observation, view, rng)
        futures = self.model.draw(rng, self.samples, self.horizon)
        n = len(duty)
        allowed = view.mask(self.layout.max_order)[: 4 * n].reshape(n, 4)
        allowed[:, SERVICE] &= (view.rul < self.service_below) | (duty == SERVICE)
        for v in self._contested(start, duty, allowed & self._room(view, duty), futures, view.rul):
            choices = np.flatnonzero(allowed[v] & self._room(view, duty)[v])
            joints = np.repeat(duty[None], len(choices), axis=0)
            joints[:, v] = choices
            mine = int(np.flatnonzero(choices == duty[v])[0])
            better = self.better(self.costs(start, joints, futures), mine)
            if better is not None:
                duty = joints[better]
        s, S = self.reorder_points
        fits = int((duty == SERVICE).sum())
        order = reorder(view.stock, view.transit, fits, s, S, self.layout.max_order)
        self._orders.append((view.shift, order))
        return np.append(duty, order).astype(np.int64)

    def _room(self, view: FleetView, duty: I64) -> NDArray[np.bool_]:
        """(n, 4): False where service would not fit the spares, slots and bays with the
        other vehicles' services in ``duty`` (the workshop would defer it: the vehicle
        loses the shift)."""
        ok = np.ones((len(duty), 4), dtype=bool)
        c = self.model.config
        for v in np.flatnonzero(duty != SERVICE):
            fits = duty == SERVICE
            fits[v] = True
            ok[v, SERVICE] = fits_capacity(c, view.window, fits, view.down, view.stock,
                                           view.free_bays)  # fmt: skip
        return ok

    def _contested(
        self, start: FleetState, duty: I64, allowed: NDArray[np.bool_], futures: Futures,
        rul: F64,
    ) -> I64:  # fmt: skip
        """The vehicles, least RUL first, for which some other action beats the base
        joint action on its own (every single deviation scored in one batch, each tested
        against the base at the level corrected for all of them)."""
        v, a = np.nonzero(allowed & (np.arange(4)[None, :] != duty[:, None]))
        if len(v) == 0:
            return v
        joints = np.repeat(duty[None], len(v) + 1, axis=0)
        joints[np.arange(1, len(v) + 1), v] = a
        cost = self.costs(start, joints, futures)
        d = cost[1:] - cost[0]
        found = np.unique(v[self.wins(d, len(v))])
        return found[np.argsort(rul[found], kind="stable")]

    def wins(self, d: F64, m: int) -> NDArray[np.bool_]:
        """Which rows of per-future differences ``d`` (candidate minus current) pass the
        acceptance test, ``m`` candidates compared (module docstring)."""
        s = d.shape[1]
        se = d.std(axis=1, ddof=1) / np.sqrt(s) if s > 1 else np.zeros(len(d))
        z = self.confidence if self.confidence is not None else critical(self.alpha / m, s - 1)
        return np.asarray(d.mean(axis=1) < -z * se - 1e-9)

    def better(self, cost: F64, mine: int) -> int | None:
        """The candidate (row of per-future ``cost``) of least mean cost, if it beats row
        ``mine`` by the acceptance test over the ``len(cost) - 1`` others."""
        best = int(np.argmin(cost.mean(axis=1)))
        if best == mine:
            return None
        win = self.wins((cost[best] - cost[mine])[None], max(len(cost) - 1, 1))[0]
        return best if win else None

    def pipeline(self, view: FleetView) -> I64:
        """Arrivals in 1..lead_time shifts from the orders this policy placed (the
        observation shows only their total); what it did not place (a policy swapped in
        mid-episode) is taken as due last."""
        if self._orders and view.shift <= self._orders[-1][0]:
            self._orders = []  # a new episode
        lead = self.model.config.lead_time
        due = np.zeros(lead, dtype=np.int64)
        for shift, quantity in self._orders:
            i = shift + lead - view.shift - 1
            if 0 <= i < lead:
                due[i] += quantity
        due[-1] += max(view.transit - int(due.sum()), 0)
        return due

    def start(
        self, observation: NDArray[Any], view: FleetView, rng: np.random.Generator
    ) -> FleetState:
        """The futures' common start: the belief over each pad's hot life, sampled."""
        lay = self.layout
        o = read_observation(observation, lay.n_vehicles, lay.per_vehicle)
        h = np.repeat(view.rul[None], self.samples, axis=0)
        if view.rul_lower is not None and view.rul_upper is not None:
            sd = (view.rul_upper - view.rul_lower) / (2 * Z90)
            h = h + sd[None] * rng.standard_normal(h.shape)
        down = np.rint(o.vehicle("down_shifts")).astype(np.int64)
        return self.model.start(
            np.maximum(h, 0.0), view.age, down, view.stock, self.pipeline(view), view.shift
        )

    def costs(self, start: FleetState, joints: I64, futures: Futures) -> F64:
        """Each joint action's cost in each future (rows: joints), terminal value
        included."""
        return self.simulate(start, joints, futures)[0]

    def simulate(self, start: FleetState, joints: I64, futures: Futures) -> tuple[F64, FleetState]:
        """(each joint action's cost in each future, shape (joints, samples), terminal value
        included; the futures' states at the horizon, joint-major)."""
        m, c = self.model, self.model.config
        k, s = len(joints), self.samples
        rows = np.tile(np.arange(s), k)
        state = start.take(rows)
        duty = np.repeat(joints, s, axis=0)
        fits = (duty == SERVICE).sum(axis=1)
        lo, hi = self.reorder_points
        order = fleet_model.reorder(state.stock, state.transit.sum(axis=1), fits, lo, hi,
                                    c.max_order)  # fmt: skip
        cost = m.step(state, duty, order, futures, 0, rows)
        for t in range(1, self.horizon):  # (a rule base: the index's horizon is 1)
            assert isinstance(self.base, FleetRule)
            view = batch_rule.BatchView(
                state.h, state.down > 0, state.stock, state.transit.sum(axis=1),
                state.free_bays(c.bays), c.shifts_to_window(state.shift),
            )  # fmt: skip
            duty, order = batch_rule.act(self.base.params, c, view)
            cost += m.step(state, duty, order, futures, t, rows)
        if self.terminal is not None:
            cost += self.terminal(state.h, state.down, state.shift)
        else:
            cost -= m.fit_cost / m.mean_life * np.maximum(state.h, 0.0).sum(axis=1)
        return cost.reshape(k, s), state


@functools.lru_cache(maxsize=64)
def critical(level: float, df: int) -> float:
    """The one-sided t quantile at ``level`` with ``df`` degrees of freedom."""
    from scipy.stats import t

    return float(t.ppf(1.0 - level, df))


def program_value(
    config: FleetConfig, atlas: Atlas, floor: float = INDEX_CHOSEN["floor"]
) -> ProgramValue:
    """The terminal value of the per-vehicle programs at the index policy's prices (the
    bound's search from the tuning seeds' starts, the needs' prices raised by ``floor``:
    at the searched prices an idle pad is nearly free, :func:`~.index.floored`)."""
    model, prices, _ = searched(config, atlas)
    share = real("program_value", "floor", floor, 0.0, 1.0)
    return ProgramValue.of(model, solve(model, floored(prices, config, share)))
