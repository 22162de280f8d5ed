"""The targets ``brakewear compare`` prints at the headline cost ratio (README "Maintenance
cost by predictor"): each is measured on the held-out pads, with its interval."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from agents.policies.rules import PolicyId
from agents.results import Estimate, PolicyRow, RatioResult, Target

if TYPE_CHECKING:
    from agents.results import CompareResult

TWIN_BEST, TWIN_BEST_HIGH = 1.05, 1.10  # the twin's best policy x oracle, its upper bound
FIXED_INTERVAL_LOW = 1.3  # the tuned fixed interval x oracle, at least
PPO_WITHIN = 0.05  # PPO on the twin relative to the tuned twin threshold
HALF_WIDTH = 0.05  # every ratio's interval within +- this


def _ratio(e: Estimate) -> str:
    return f"{e.point:.3f}x ({e.low:.3f}-{e.high:.3f})"


def check_targets(result: CompareResult) -> list[Target]:
    """Each target, what was measured and whether it was met (None: not measured)."""
    head = result.headline
    return [
        _twin_best(head),
        _fixed_interval(head),
        _ood_failures(head),
        _ppo_twin(head),
        _half_widths(head),
    ]


def _twin_best(head: RatioResult) -> Target:
    name = f"twin's best policy <= {TWIN_BEST}x oracle, 95% upper bound <= {TWIN_BEST_HIGH}"
    best = head.best("twin")
    if best is None:
        return Target(name, "no twin policy evaluated", None)
    r = head.policies[best].ratio_to_oracle
    return Target(
        name, f"{best.label}: {_ratio(r)}", r.point <= TWIN_BEST and r.high <= TWIN_BEST_HIGH
    )


def _fixed_interval(head: RatioResult) -> Target:
    name = f"tuned fixed interval >= {FIXED_INTERVAL_LOW}x oracle"
    row = head.policies.get(PolicyId("fixed-interval"))
    if row is None:
        return Target(name, "not evaluated", None)
    r = row.ratio_to_oracle
    return Target(name, _ratio(r), r.point >= FIXED_INTERVAL_LOW)


def _ood_failures(head: RatioResult) -> Target:
    name = "fewer OOD failures per 100 pads with the twin than with the physics predictor"
    twin, physics = head.best("twin"), head.best("physics")
    if twin is None or physics is None or head.ood_failure_gap is None:
        return Target(name, "twin or physics not evaluated", None)

    def rate(p: PolicyId) -> str:
        e = head.policies[p].failures_per_100_pads["ood"]
        return f"{p.label} {e.point:.2f} ({e.low:.2f}-{e.high:.2f})"

    gap = head.ood_failure_gap
    text = (
        f"{rate(twin)} vs {rate(physics)}; difference {gap.point:+.2f}"
        f" ({gap.low:+.2f} to {gap.high:+.2f}, paired)"
    )
    return Target(name, text, gap.point < 0 and gap.high < 0)


def _ppo_twin(head: RatioResult) -> Target:
    name = f"PPO on the twin within {PPO_WITHIN:.0%} of the best tuned twin threshold"
    ppo: PolicyRow | None = head.policies.get(PolicyId("agent", "twin", algo="ppo"))
    rules = [PolicyId(kind, "twin") for kind in ("threshold", "lower-threshold")]
    rows = {p: head.policies[p] for p in rules if p in head.policies}
    if ppo is None or not rows:
        return Target(name, "PPO on the twin or the twin threshold not evaluated", None)
    best = min(rows, key=lambda p: rows[p].ratio_to_oracle.point)
    rule = rows[best].ratio_to_oracle
    rel = ppo.ratio_to_oracle.point / rule.point - 1.0
    text = f"PPO {_ratio(ppo.ratio_to_oracle)} vs {best.label} {_ratio(rule)}: {rel:+.1%}"
    return Target(name, text, rel <= PPO_WITHIN)


def _half_widths(head: RatioResult) -> Target:
    name = f"every ratio's 95% interval within +-{HALF_WIDTH}"
    widths = {
        p.label: row.ratio_to_oracle.half_width
        for p, row in head.policies.items()
        if math.isfinite(row.ratio_to_oracle.half_width)
    }
    worst = max(widths, key=lambda k: widths[k]) if widths else None
    if worst is None:
        return Target(name, "no ratio", None)
    over = sorted(k for k, w in widths.items() if w > HALF_WIDTH)
    text = f"widest {worst} +-{widths[worst]:.3f}" + (f"; over: {', '.join(over)}" if over else "")
    return Target(name, text, not over)
