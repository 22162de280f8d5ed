"""The cost comparison as people read it: the terminal table, the ranking under each cost
ratio, the figures and the demo's Markdown section. Tables are built from the
content of ``costs.json``, so the terminal and the report show the same figures."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from agents.study.results import CompareResult
from brake_env.output import table

HEADER = [
    "policy",
    "tuned parameter",
    "cost/1000 ev",
    "x oracle (95% CI)",
    "gap to next (95% CI)",
    "fail/100 pads",
    "OOD fail/100 (95% CI)",
    "unused life",
]


def _param(p: dict[str, Any]) -> str:
    v = p["parameter"]
    if v is None:
        return "-"
    return "never" if p["note"] or math.isinf(v) else f"{v:g}"


def _ci(e: dict[str, float], digits: int = 3, sign: str = "") -> str:
    v, lo, hi = (format(e[k], f"{sign}.{digits}f") for k in ("value", "low", "high"))
    return f"{v} ({lo} to {hi})"


def cost_rows(head: dict[str, Any], skipped: dict[str, str] | None = None) -> list[list[str]]:
    """Rows of the cost table (the first is the header), cheapest first, from the content
    of ``costs.json`` at one cost ratio; a gap marked ``n.s.`` is not significant. Policies
    given no figure are listed last with the reason."""
    rows = [list(HEADER)]
    gaps = {g["cheaper"]: g for g in head["gaps"]}
    for label in head["ranking"]:
        p = head["policies"][label]
        g = gaps.get(label)
        gap = "" if g is None else _ci(g["difference"], sign="+")
        if g is not None and not g["significant"]:
            gap += " n.s."
        ood = p["failures_per_100_pads"]["ood"]
        rows.append(
            [
                label,
                _param(p),
                f"{p['cost_per_1000_events']['value']:.3f}",
                _ci(p["ratio_to_oracle"]),
                gap,
                f"{p['failures_per_100_pads']['all']['value']:.1f}",
                "-" if ood["value"] is None or math.isnan(ood["value"]) else _ci(ood, 1),
                f"{p['mean_unused_life_frac']:.1%}",
            ]
        )
    for label, why in (skipped or {}).items():
        rows.append([label, why, *[""] * (len(HEADER) - 2)])
    return rows


def print_report(result: CompareResult, cost_table: str) -> None:
    """The headline table, the ranking under each cost ratio and the notes."""
    c = result.config
    tune, held = sum(result.tune_pads.values()), sum(result.eval_pads.values())
    print(
        f"\nregime {c.env.regime}, failure/planned cost {result.failure_to_planned:g};"
        f" {held} held-out pads ({_labels(result.eval_pads)}), every policy on the same;"
        f" thresholds and the fixed interval tuned on {tune} other pads"
    )
    print(cost_table)
    for label, why in result.skipped.items():
        print(f"{label}: {why}")
    for r, s in result.sensitivity.items():
        order = " < ".join(p.label for p in s.policies)
        print(f"failure/planned {r:>3g}: predictors {' < '.join(s.predictor_ranking)}")
        print(f"  policies {order}")


def _labels(counts: dict[str, int]) -> str:
    return ", ".join(f"{n} {k}" for k, n in counts.items())


def write_figures(result: CompareResult, directory: Path) -> list[Path]:
    """Cost ratios, replacement timing, the sensitivity and (with agents) learning curves."""
    from agents.commands.plots import (
        plot_cost_ratios,
        plot_learning_curve,
        plot_replacement_timing,
        plot_sensitivity,
    )

    head = result.headline
    paths = [
        plot_cost_ratios(head, directory / "cost_ratio.png"),
        plot_replacement_timing(
            head, directory / "replacement_timing.png", result.config.decision_interval
        ),
        plot_sensitivity(result.sensitivity, directory / "cost_sensitivity.png"),
    ]
    if result.learning_curves:
        refs = {
            f"{p.label} (tuned rule, held-out)": row.ratio_to_oracle.point
            for p, row in head.policies.items()
            if p.kind in ("threshold", "lower-threshold") and p.predictor in result.learning_curves
        }
        paths.append(
            plot_learning_curve(result.learning_curves, directory / "learning_curve.png", refs)
        )
    return paths


def markdown_section(summary: dict[str, Any], folder: str) -> str:
    """The demo report's section on the comparison (``folder``: where its figures are)."""
    rows = cost_rows(summary, summary["skipped"])
    tune = sum(summary["pads"]["tune"].values())
    held = summary["pads"]["evaluate"]
    return f"""## Maintenance cost by predictor (small budget)

Mixed regime, failure = {summary["failure_to_planned"]:g} planned replacements;
{sum(held.values())} held-out pads ({_labels(held)}), every policy on the same pads;
thresholds and the fixed interval tuned on {tune} other pads. 95% intervals are paired
bootstrap intervals over pads; `n.s.`: the gap to the next policy is not significant.
`brakewear compare` runs the full budget (1,000 held-out pads of each label, agents).

{table(rows, markdown=True)}

![cost ratio]({folder}/figures/cost_ratio.png)
![replacement timing]({folder}/figures/replacement_timing.png)
"""
