"""Figures of the cost comparison (matplotlib ``Figure`` objects, no pyplot state)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from agents.study.results import RatioResult
from brake_env.output import atomic_path

# Blue: an RUL threshold; orange: a trained agent; grey: the rest.
_COLORS = {"threshold": "#2b8cbe", "lower-threshold": "#7bccc4", "agent": "#e6550d"}


def plot_cost_ratios(result: RatioResult, path: str | Path) -> Path:
    """Cost ratio to the oracle per policy with its 95% paired bootstrap interval, cheapest
    first; "=" between two bars where their difference is not significant."""
    rows = list(result.policies.items())
    names = [k.label for k, _ in rows]
    ratio = np.array([r.ratio_to_oracle.point for _, r in rows])
    lo = ratio - np.array([r.ratio_to_oracle.low for _, r in rows])
    hi = np.array([r.ratio_to_oracle.high for _, r in rows]) - ratio
    fig = Figure(figsize=(8, 0.45 * len(names) + 1.5), layout="constrained")
    ax = fig.add_subplot()
    colors = [_COLORS.get(k.kind, "#636363") for k, _ in rows]
    y = np.arange(len(names))
    ax.barh(y, ratio, xerr=[np.maximum(lo, 0), np.maximum(hi, 0)], color=colors, capsize=3)
    for i, gap in enumerate(result.gaps):
        if not gap.significant:
            ax.annotate("=", (ratio[i + 1], i + 0.5), xytext=(6, 0), textcoords="offset points",
                        va="center", color="#de2d26", fontweight="bold")  # fmt: skip
    ax.axvline(1.0, color="k", lw=0.8)
    ax.set_yticks(y, names)
    ax.invert_yaxis()
    ax.set_xscale("log")
    ax.set_xlabel("maintenance cost / oracle's (log scale; 95% paired bootstrap interval)")
    ax.set_title(
        f"Cost of each policy, failure = {result.failure_to_planned:g} planned"
        " (red =: gap not significant)"
    )
    return _save(fig, path)


def plot_replacement_timing(result: RatioResult, path: str | Path, decision_interval: int) -> Path:
    """True RUL left when each held-out pad was taken off, per policy (failures, in red, at
    1 on the log axis)."""
    items = list(result.policies.items())
    fig = Figure(figsize=(9, 0.45 * len(items) + 1.5), layout="constrained")
    ax = fig.add_subplot()
    rng = np.random.default_rng(0)  # jitter only
    for i, (_, r) in enumerate(items):
        left = r.life_left.astype(float)
        if left.size > 400:  # a readable sample
            left = rng.choice(left, 400, replace=False)
        jitter = rng.uniform(-0.25, 0.25, left.size)
        ok = left > 0
        ax.scatter(left[ok], i + jitter[ok], s=6, alpha=0.5, color="#2b8cbe")
        ax.scatter(np.full((~ok).sum(), 1.0), i + jitter[~ok], s=12, marker="x", color="#de2d26")
    ax.axvline(decision_interval, color="k", lw=0.8, ls="--", label="one decision interval")
    ax.set_xscale("log")
    ax.set_yticks(range(len(items)), [k.label for k, _ in items])
    ax.invert_yaxis()
    ax.set_xlabel("true RUL left at replacement [events]  (x at 1: brake failure)")
    ax.legend(loc="lower right")
    ax.set_title("Replacement timing against the true remaining life (400 pads a row)")
    return _save(fig, path)


def plot_sensitivity(sensitivity: Mapping[float, RatioResult], path: str | Path) -> Path:
    """Cost ratio to the oracle of each predictor's best policy, per failure cost ratio,
    with 95% intervals."""
    ratios = sorted(sensitivity)
    preds = sorted({k.predictor for v in sensitivity.values() for k in v.policies if k.predictor})
    fig = Figure(figsize=(7, 4), layout="constrained")
    ax = fig.add_subplot()
    for p in preds:
        pts = []
        for r in ratios:
            best = sensitivity[r].best(p)
            pts.append(sensitivity[r].policies[best].ratio_to_oracle if best else None)
        x = [r for r, e in zip(ratios, pts, strict=True) if e is not None]
        e = [e for e in pts if e is not None]
        y = np.array([v.point for v in e])
        err = [y - [v.low for v in e], np.array([v.high for v in e]) - y]
        ax.errorbar(x, y, yerr=err, marker="o", capsize=3, label=p)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("failure cost / planned replacement cost")
    ax.set_ylabel("best policy's cost / oracle's")
    if preds:
        ax.legend()
    ax.set_title("Predictor ranking under other cost ratios")
    return _save(fig, path)


def plot_learning_curve(
    curves: Mapping[str, Sequence[Mapping[str, float]]],
    path: str | Path,
    references: Mapping[str, float] | None = None,
) -> Path:
    """Cost ratio to the oracle on the curve's fixed pads against training steps, per agent;
    ``references`` (label -> ratio) are drawn as horizontal lines."""
    fig = Figure(figsize=(7, 4), layout="constrained")
    ax = fig.add_subplot()
    for name, points in curves.items():
        steps = [p["timesteps"] for p in points]
        ax.plot(steps, [p["ratio_to_oracle"] for p in points], marker="o", ms=3, label=name)
    styles = iter(["--", ":", "-."] * 4)
    for label, value in (references or {}).items():
        ax.axhline(value, ls=next(styles), lw=1.0, color="#636363", label=label)
    ax.axhline(1.0, color="k", lw=0.8)
    ax.set_yscale("log")
    ax.set_xlabel("training steps")
    ax.set_ylabel("cost / oracle's on fixed pads")
    if curves or references:
        ax.legend(fontsize=8)
    ax.set_title("Learning curve")
    return _save(fig, path)


def _save(fig: Figure, path: str | Path) -> Path:
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=120)
    return path
