"""Non-RL rules for BrakeWearFleet-v0, with SB3's ``predict`` signature.

One rule, :class:`FleetRule`, has a part for each decision, and each heuristic of issue 20 is
a setting of it (the constructors below), so that their best combination is the same rule
with every part free. All limits are RUL in shifts of hot duty (:mod:`.view`).

- **Service** (per vehicle): replace when the RUL is below ``must`` anywhere (an unscheduled
  visit between windows); below ``window_limit`` at a scheduled window (labour and pad
  only); below ``shop_limit`` while the vehicle is in the shop anyway (labour and pad only).
  The per-vehicle threshold is one limit for all three (it ignores windows); the
  time-to-window control limit sets ``window_limit`` to the shifts to the next window plus
  a margin; the (n, N) opportunistic limits (Wijnmalen and Hontelez, EJOR 1997) are
  ``must = N`` and ``window_limit = shop_limit = n``.
- **Capacity** (``greedy``): requests are served lowest RUL first within the spares in
  stock and, at a window, the crew's slots, or, for visits, the free bays; the others are
  not sent (so not deferred, and they drive last). Without it every request goes to the
  workshop, whose own rule serves by pad age and defers the rest (the vehicle then loses
  the shift).
- **Duty**: the vehicles able to drive fill the hot need, then the mild need, in vehicle
  order (``roster``), healthiest first (``rul``: the vehicles with the least RUL take
  the mild route, and the spare duty if any), or ``due-first``: a pad that will be
  replaced at the next window anyway (its RUL there, after hot shifts until then, below
  the window limit, but still above ``must``) takes the ramp first, since the life it
  would keep on the mild route is thrown away at the window, and the others are spared
  its wear; then healthiest first; a due pad filling the mild need is sent up the ramp
  too (a ramp truck covers a drift). The others take ``spare_duty``, the mild route or
  parked.
- **Reorder** (s, S): when the inventory position (stock + in transit - fits sent now)
  is below ``s``, order up to ``S`` (at most ``max_order``).

Every action respects the env's :meth:`action_masks` (rebuilt from the observation). The
decisions are written once, over a batch of states, in :mod:`.batch_rule`;
:meth:`FleetRule.act` runs them on a batch of one.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents.fleet.policies import batch_rule
from agents.fleet.policies.base import FleetPolicy
from agents.fleet.policies.batch_rule import DUTIES, SPARE_DUTIES, FleetRuleParams
from agents.fleet.policies.view import FleetLayout, FleetView
from brake_env.env.fleet.spares import reorder  # the rule's one home, re-exported here

__all__ = ["DUTIES", "SPARE_DUTIES", "FleetRule", "FleetRuleParams", "opportunistic_rule",
           "reorder", "threshold_rule", "window_rule", "with_parts"]  # fmt: skip
I64 = NDArray[np.int64]


class FleetRule(FleetPolicy):
    """A fleet rule (module docstring): one observation or a batch in, actions out.

    Args:
        layout: Where the rule finds things in the observation.
        params: Its parts.
        name: Shown in tables.
    """

    def __init__(self, layout: FleetLayout, params: FleetRuleParams, name: str = "rule") -> None:
        self.layout, self.params, self.name = layout, params, name

    def action(self, observation: NDArray[Any]) -> I64:
        return self.act(FleetView.read(observation, self.layout))

    def act(self, view: FleetView) -> I64:
        """The action (duties, then the order) for one observation: the batched rule
        (:func:`.batch_rule.act`) on a batch of one."""
        one = batch_rule.BatchView(
            view.rul[None], view.down[None], np.array([view.stock]), np.array([view.transit]),
            np.array([view.free_bays]), view.to_window,
        )  # fmt: skip
        duty, order = batch_rule.act(self.params, self.layout.config, one)
        return np.append(duty[0], order[0]).astype(np.int64)

    def __repr__(self) -> str:
        return f"FleetRule({self.name}, {self.params})"


# ---------------------------------------------------------------- the heuristics of issue 20
def threshold_rule(layout: FleetLayout, threshold: float, s: int = 2, S: int = 4) -> FleetRule:
    """Per-vehicle RUL threshold: replace below ``threshold`` wherever (ignores windows)."""
    p = FleetRuleParams(must=threshold, window_limit=threshold, shop_limit=threshold, s=s, S=S)
    return FleetRule(layout, p, "threshold")


def window_rule(
    layout: FleetLayout, window_period: int, margin: float, must: float = 1.0,
    s: int = 2, S: int = 4,
) -> FleetRule:  # fmt: skip
    """Time-to-window control limit: at a window replace a pad whose RUL will not last to
    the next window (``window_period - 1`` working shifts) plus ``margin``; between windows
    only below ``must`` (it would fail before the window)."""
    p = FleetRuleParams(must=must, window_limit=window_period - 1 + margin, s=s, S=S)
    return FleetRule(layout, p, "time-to-window")


def opportunistic_rule(
    layout: FleetLayout, n: float, N: float, s: int = 2, S: int = 4
) -> FleetRule:
    """(n, N) opportunistic control limits: must-do below N anywhere, can-do below n (>= N)
    when the vehicle is in the shop or at a window."""
    p = FleetRuleParams(must=N, window_limit=max(n, N), shop_limit=max(n, N), s=s, S=S)
    return FleetRule(layout, p, "(n, N)")


def with_parts(rule: FleetRule, name: str, **parts: Any) -> FleetRule:
    """``rule`` with some parts changed (greedy capacity, duty rule, (s, S)...)."""
    return FleetRule(rule.layout, dataclasses.replace(rule.params, **parts), name)
