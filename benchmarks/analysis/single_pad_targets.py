"""The single-pad cost study's targets (docs/results/single-pad.md), read from a
``costs.json`` that ``brakewear compare`` wrote: each target with its measured figure and
interval, met or missed. The product reports results; the targets are ours, so they live here.

Run: ``.venv/bin/python benchmarks/analysis/single_pad_targets.py out/compare/costs.json``
"""

from __future__ import annotations

import json
import math
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

TWIN_BEST, TWIN_BEST_HIGH = 1.05, 1.10  # the twin's best policy x oracle, its upper bound
FIXED_INTERVAL_LOW = 1.3  # the tuned fixed interval x oracle, at least
PPO_WITHIN = 0.05  # PPO on the twin relative to the tuned twin threshold
HALF_WIDTH = 0.05  # every ratio's interval within +- this


@dataclass(frozen=True)
class Target:
    """One target: what is aimed at, what was measured, met (None: not measured)."""

    name: str
    measured: str
    met: bool | None


def _ratio(r: dict[str, float]) -> str:
    return f"{r['value']:.3f}x ({r['low']:.3f}-{r['high']:.3f})"


def _best(costs: dict[str, Any], predictor: str) -> str | None:
    """The predictor's cheapest policy in the ranking."""
    return next((p for p in costs["ranking"] if p.split("/")[0] == predictor), None)


def twin_best(costs: dict[str, Any]) -> Target:
    name = f"twin's best policy <= {TWIN_BEST}x oracle, 95% upper bound <= {TWIN_BEST_HIGH}"
    best = _best(costs, "twin")
    if best is None:
        return Target(name, "no twin policy evaluated", None)
    r = costs["policies"][best]["ratio_to_oracle"]
    return Target(
        name, f"{best}: {_ratio(r)}", r["value"] <= TWIN_BEST and r["high"] <= TWIN_BEST_HIGH
    )


def fixed_interval(costs: dict[str, Any]) -> Target:
    name = f"tuned fixed interval >= {FIXED_INTERVAL_LOW}x oracle"
    row = costs["policies"].get("fixed-interval")
    if row is None:
        return Target(name, "not evaluated", None)
    r = row["ratio_to_oracle"]
    return Target(name, _ratio(r), r["value"] >= FIXED_INTERVAL_LOW)


def ood_failures(costs: dict[str, Any]) -> Target:
    name = "fewer OOD failures per 100 pads with the twin than with the physics predictor"
    twin, physics = _best(costs, "twin"), _best(costs, "physics")
    gap = costs.get("ood_failure_gap_twin_minus_physics")
    if twin is None or physics is None or gap is None:
        return Target(name, "twin or physics not evaluated", None)

    def rate(p: str) -> str:
        e = costs["policies"][p]["failures_per_100_pads"]["ood"]
        return f"{p} {e['value']:.2f} ({e['low']:.2f}-{e['high']:.2f})"

    text = (
        f"{rate(twin)} vs {rate(physics)}; difference {gap['value']:+.2f}"
        f" ({gap['low']:+.2f} to {gap['high']:+.2f}, paired)"
    )
    return Target(name, text, gap["value"] < 0 and gap["high"] < 0)


def ppo_twin(costs: dict[str, Any]) -> Target:
    name = f"PPO on the twin within {PPO_WITHIN:.0%} of the best tuned twin threshold"
    ppo = costs["policies"].get("twin/ppo")
    rules = {p: costs["policies"][p] for p in ("twin/threshold", "twin/lower-threshold")
             if p in costs["policies"]}  # fmt: skip
    if ppo is None or not rules:
        return Target(name, "PPO on the twin or the twin threshold not evaluated", None)
    best = min(rules, key=lambda p: rules[p]["ratio_to_oracle"]["value"])
    rule = rules[best]["ratio_to_oracle"]
    rel = ppo["ratio_to_oracle"]["value"] / rule["value"] - 1.0
    text = f"PPO {_ratio(ppo['ratio_to_oracle'])} vs {best} {_ratio(rule)}: {rel:+.1%}"
    return Target(name, text, rel <= PPO_WITHIN)


def half_widths(costs: dict[str, Any]) -> Target:
    name = f"every ratio's 95% interval within +-{HALF_WIDTH}"
    widths = {}
    for p, row in costs["policies"].items():
        r = row["ratio_to_oracle"]
        w = max(r["value"] - r["low"], r["high"] - r["value"])
        if math.isfinite(w):
            widths[p] = w
    if not widths:
        return Target(name, "no ratio", None)
    worst = max(widths, key=lambda k: widths[k])
    over = sorted(k for k, w in widths.items() if w > HALF_WIDTH)
    text = f"widest {worst} +-{widths[worst]:.3f}" + (f"; over: {', '.join(over)}" if over else "")
    return Target(name, text, not over)


RULES = (twin_best, fixed_interval, ood_failures, ppo_twin, half_widths)


def check(costs: dict[str, Any]) -> list[Target]:
    """Each target at the headline cost ratio."""
    return [rule(costs) for rule in RULES]


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 1:
        print(__doc__.strip().splitlines()[-1], file=sys.stderr)
        return 2
    costs = json.loads(Path(args[0]).read_text())
    for t in check(costs):
        mark = {True: "met", False: "MISSED", None: "not measured"}[t.met]
        print(f"[{mark}] {t.name}: {t.measured}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
