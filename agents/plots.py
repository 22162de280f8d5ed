"""Figures of the cost comparison (matplotlib ``Figure`` objects, no pyplot state)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from agents.evaluation import CostReport
from agents.policies import PolicyId
from agents.results import RatioResult

# Blue: an RUL threshold; orange: a trained agent; grey: the rest.
_COLORS = {"threshold": "#2b8cbe", "agent": "#e6550d"}


def plot_cost_ratios(reports: Mapping[PolicyId, CostReport], path: str | Path) -> Path:
    """Cost ratio to the oracle per policy, with 95% intervals over seeds, cheapest first."""
    items = sorted(reports.items(), key=lambda kv: kv[1].cost)
    names = [k.label for k, _ in items]
    ratio = np.array([r.ratio_to_oracle or np.nan for _, r in items])
    lo, hi = [], []
    for (_, r), x in zip(items, ratio, strict=True):
        per = np.asarray(r.episode_ratio_to_oracle or [x])
        per = per[np.isfinite(per)]
        half = 1.96 * per.std(ddof=1) / np.sqrt(per.size) if per.size > 1 else 0.0
        lo.append(x - (per.mean() - half) if per.size > 1 else 0.0)
        hi.append((per.mean() + half) - x if per.size > 1 else 0.0)
    fig = Figure(figsize=(8, 0.45 * len(names) + 1.5), layout="constrained")
    ax = fig.add_subplot()
    colors = [_COLORS.get(k.kind, "#636363") for k, _ in items]
    y = np.arange(len(names))
    ax.barh(y, ratio, xerr=[np.maximum(lo, 0), np.maximum(hi, 0)], color=colors, capsize=3)
    ax.axvline(1.0, color="k", lw=0.8)
    ax.set_yticks(y, names)
    ax.invert_yaxis()
    ax.set_xscale("log")
    ax.set_xlabel("maintenance cost / oracle's (log scale; 95% interval over seeds)")
    ax.set_title("Cost of each replacement policy (blue: RUL threshold, orange: agent)")
    return _save(fig, path)


def plot_replacement_timing(
    reports: Mapping[PolicyId, CostReport], path: str | Path, decision_interval: int
) -> Path:
    """True RUL left when each pad was taken off, per policy (failures at 0, in red)."""
    items = sorted(reports.items(), key=lambda kv: kv[1].cost)
    fig = Figure(figsize=(9, 0.45 * len(items) + 1.5), layout="constrained")
    ax = fig.add_subplot()
    rng = np.random.default_rng(0)  # jitter only
    for i, (_, r) in enumerate(items):
        left = np.array([pad.life_left for pad in r.retired], dtype=float)
        jitter = rng.uniform(-0.25, 0.25, left.size)
        ok = left > 0
        ax.scatter(left[ok], i + jitter[ok], s=8, alpha=0.6, color="#2b8cbe")
        ax.scatter(np.full((~ok).sum(), 1.0), i + jitter[~ok], s=14, marker="x", color="#de2d26")
    ax.axvline(decision_interval, color="k", lw=0.8, ls="--", label="one decision interval")
    ax.set_xscale("log")
    ax.set_yticks(range(len(items)), [k.label for k, _ in items])
    ax.invert_yaxis()
    ax.set_xlabel("true RUL left at replacement [events]  (x at 1: brake failure)")
    ax.legend(loc="lower right")
    ax.set_title("Replacement timing against the true remaining life")
    return _save(fig, path)


def plot_sensitivity(sensitivity: Mapping[float, RatioResult], path: str | Path) -> Path:
    """Cost ratio to the oracle of each predictor's best policy, per failure cost ratio."""
    ratios = sorted(sensitivity)
    preds = sorted({k.predictor for v in sensitivity.values() for k in v.policies if k.predictor})
    fig = Figure(figsize=(7, 4), layout="constrained")
    ax = fig.add_subplot()
    for p in preds:
        ys = []
        for r in ratios:
            rows = sensitivity[r].policies
            ys.append(min(v.ratio_to_oracle for k, v in rows.items() if k.predictor == p))
        ax.plot(ratios, ys, marker="o", label=p)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("failure cost / planned replacement cost")
    ax.set_ylabel("best policy's cost / oracle's")
    ax.legend()
    ax.set_title("Predictor ranking under other cost ratios")
    return _save(fig, path)


def _save(fig: Figure, path: str | Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    return path
