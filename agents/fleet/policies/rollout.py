"""Multiagent rollout on a fleet rule (Bertsekas 2021): each shift the vehicles are decided
one at a time, each choice scored by simulating the base rule forward in the planning model
(:mod:`.planning`) over sampled futures with common random numbers.

**The decision.** Start from the base rule's action. Take the vehicles in order of least
RUL first (the decisions that matter most first); for vehicle ``i``, every action its mask
allows (hot, mild, park, service) is scored with the vehicles before it at their chosen
actions and those after it at the base rule's: the shift is simulated with that joint
action, then ``horizon - 1`` shifts of the base rule (:mod:`.batch_rule`), in the same
``samples`` futures for every candidate. The score is the mean cost plus a terminal value:
each pad's hot life left at the horizon is worth ``(pad + labour) / mean_life`` a shift
(a new pad's fit cost spread over its mean life), so that using up a pad within the
horizon is not free. The candidate of least score is kept; the current action wins ties
(within ``1e-9``). The order is the base rule's (s, S) on the chosen services. Cost per
shift: ``n x 4 x samples x horizon`` model shifts in ``n`` batches.

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

from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents.fleet.policies import batch_rule
from agents.fleet.policies.planning import FleetState, Futures, PlanningModel
from agents.fleet.policies.rules import FleetRule, reorder
from agents.fleet.policies.view import FleetLayout, FleetView
from brake_env.env.fleet.shop import SERVICE
from brake_env.env.fleet.spaces import read_observation

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]
Z90 = 1.6448536269514722  # a 90% interval's half-width in standard deviations


class RolloutPolicy:
    """Multiagent rollout on ``base`` (module docstring), with SB3's ``predict`` signature.

    Args:
        base: The base rule (a tuned heuristic); its layout says where the RUL is.
        model: The planning model of the env's config and atlas.
        horizon: Shifts simulated per candidate (the first with the candidate).
        samples: Futures per candidate (common to all candidates).
        seed: Seed of the futures (with the shift: the same state, the same futures).
    """

    def __init__(
        self, base: FleetRule, model: PlanningModel, horizon: int = 28, samples: int = 16,
        seed: int = 0,
    ) -> None:  # fmt: skip
        if horizon < 1 or samples < 1:
            raise ValueError(f"RolloutPolicy: horizon and samples must be >= 1, got {horizon}"
                             f" and {samples}")  # fmt: skip
        if base.layout.config != model.config:
            raise ValueError("RolloutPolicy: the base rule and the model have different configs")
        self.base, self.model = base, model
        self.horizon, self.samples, self.seed = horizon, samples, seed
        self.name = f"rollout on {base.name}"
        self._orders: list[tuple[int, int]] = []  # (shift, quantity) this episode

    @property
    def layout(self) -> FleetLayout:
        return self.base.layout

    def predict(
        self,
        observation: NDArray[Any],
        state: tuple[NDArray[Any], ...] | None = None,
        episode_start: NDArray[np.bool_] | None = None,
        deterministic: bool = False,
    ) -> tuple[NDArray[Any], tuple[NDArray[Any], ...] | None]:
        obs = np.asarray(observation)
        if obs.ndim == 2:
            return np.stack([self.act(o) for o in obs]), state
        return self.act(obs), state

    def act(self, observation: NDArray[Any]) -> I64:
        """The action (duties, then the order) for one observation."""
        view = FleetView.read(observation, self.layout)
        duty = self.base.act(view)[:-1].copy()
        rng = np.random.default_rng([self.seed, view.shift])
        start = self.start(observation, view, rng)
        futures = self.model.draw(rng, self.samples, self.horizon)
        n = len(duty)
        allowed = view.mask(self.layout.max_order)[: 4 * n].reshape(n, 4)
        for v in np.argsort(view.rul, kind="stable"):
            choices = np.flatnonzero(allowed[v])
            if len(choices) < 2:
                continue
            joints = np.repeat(duty[None], len(choices), axis=0)
            joints[:, v] = choices
            score = self.scores(start, joints, futures)
            mine = int(np.flatnonzero(choices == duty[v])[0])
            best = int(np.argmin(score))
            if score[best] < score[mine] - 1e-9:
                duty = joints[best]
        p = self.base.params
        fits = int((duty == SERVICE).sum())
        order = reorder(view.stock, view.transit, fits, p.s, p.S, self.layout.max_order)
        self._orders.append((view.shift, order))
        return np.append(duty, order).astype(np.int64)

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
        o = read_observation(observation, lay.n_vehicles, len(lay.fields))
        h = np.repeat(view.rul[None], self.samples, axis=0)
        if "rul_lower" in lay.fields and "rul_upper" in lay.fields:
            lo, hi = (o.appended[:, lay.fields.index(f)] for f in ("rul_lower", "rul_upper"))
            sd = (hi - lo) / (2 * Z90) / lay.events_per_hot_shift
            h = h + sd[None] * rng.standard_normal(h.shape)
        down = np.rint(o.vehicle("down_shifts")).astype(np.int64)
        return self.model.start(
            np.maximum(h, 0.0), view.age, down, view.stock, self.pipeline(view), view.shift
        )

    def scores(self, start: FleetState, joints: I64, futures: Futures) -> F64:
        """Each joint action's mean cost over the futures, plus the terminal value."""
        m, c, p = self.model, self.model.config, self.base.params
        k, s = len(joints), self.samples
        rows = np.tile(np.arange(s), k)
        state = start.take(rows)
        duty = np.repeat(joints, s, axis=0)
        fits = (duty == SERVICE).sum(axis=1)
        position = state.stock + state.transit.sum(axis=1) - fits
        order = np.where(position >= p.s, 0, np.clip(p.S - position, 0, c.max_order))
        cost = m.step(state, duty, order, futures, 0, rows)
        for t in range(1, self.horizon):
            view = batch_rule.BatchView(
                state.h, state.down > 0, state.stock, state.transit.sum(axis=1),
                state.free_bays(c.bays), c.shifts_to_window(state.shift),
            )  # fmt: skip
            duty, order = batch_rule.act(p, c, view)
            cost += m.step(state, duty, order, futures, t, rows)
        cost -= m.fit_cost / m.mean_life * np.maximum(state.h, 0.0).sum(axis=1)
        return cost.reshape(k, s).mean(axis=1)
