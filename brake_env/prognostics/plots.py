"""Figures of the prognostics evaluation, after the paper's Figures 10-13.

Each function takes an :class:`~brake_env.prognostics.evaluation.Evaluation`, draws on a matplotlib
``Figure`` (no pyplot: no global state, no display backend) and saves a PNG. The oracle is
the truth itself, so it is left out of the figures (the black line shows the truth).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from brake_env.csv_safe import plain_text
from brake_env.output import atomic_path
from brake_env.prognostics.evaluation import Evaluation

MODEL_COLORS = {
    "physics": "tab:orange",
    "data": "tab:blue",
    "twin": "tab:green",
    "none": "tab:gray",
}
_SKIP = ("oracle",)


def _save(fig: Figure, path: str | Path) -> Path:
    path = Path(path)
    with atomic_path(path) as tmp:  # the temporary name keeps the suffix: PNG
        fig.savefig(tmp, dpi=110, bbox_inches="tight")
    return path


def _color(name: str, i: int) -> str:
    return MODEL_COLORS.get(name, f"C{(i + 4) % 10}")


def _models_with(ev: Evaluation, column: str) -> list[str]:
    """Models (oracle excepted) whose traces carry ``column``."""
    out = []
    for name in ev.models:
        if name in _SKIP:
            continue
        split = next(iter(ev.traces[name]))
        run = next(iter(ev.traces[name][split].values()))
        if column in run:
            out.append(name)
    return out


def _single_run(
    ev: Evaluation, column: str, truth: str, ylabel: str, title: str, path: str | Path
) -> Path | None:
    names = _models_with(ev, column)
    if not names:
        return None
    splits = ev.splits
    fig = Figure(figsize=(10, 3.6 * len(splits)), layout="constrained")
    axes = np.atleast_1d(fig.subplots(len(splits), 1, squeeze=False)[:, 0])
    for ax, split in zip(axes, splits, strict=True):
        run = ev.samples[split]
        first = ev.traces[names[0]][split][run]
        if truth in first:
            ax.plot(first["event"], first[truth], "k", lw=2, label="truth")
        for i, name in enumerate(names):
            tr = ev.traces[name][split][run]
            c = _color(name, i)
            ax.plot(tr["event"], tr[column], color=c, lw=1, label=name)
            if column == "rul_mean" and "rul_lower" in tr and "rul_upper" in tr:
                ax.fill_between(tr["event"], tr["rul_lower"], tr["rul_upper"], color=c, alpha=0.15)
        ax.set(
            xlabel="braking event since installation",
            ylabel=ylabel,
            title=f"{split.upper()} sample {plain_text(run)}",
        )
        ax.legend(fontsize=8)
    fig.suptitle(title)
    return _save(fig, path)


def plot_volume_estimates(ev: Evaluation, path: str | Path) -> Path | None:
    """Pad volume estimates against the truth, ID and OOD sample (paper Figure 10)."""
    return _single_run(
        ev,
        "volume_frac",
        "volume_true",
        "pad volume fraction [-]",
        "Brake pad volume estimates (paper Figure 10)",
        path,
    )


def plot_wear_coeff_estimates(ev: Evaluation, path: str | Path) -> Path | None:
    """Archard coefficient estimates against the true K (paper Figure 11)."""
    return _single_run(
        ev,
        "wear_coeff",
        "k_true",
        "Archard wear coefficient K [-]",
        "Wear coefficient estimates (paper Figure 11)",
        path,
    )


def plot_rul_estimates(ev: Evaluation, path: str | Path) -> Path | None:
    """RUL estimates of every model against the truth (paper Figure 12)."""
    return _single_run(
        ev,
        "rul_mean",
        "rul_true",
        "RUL [braking events]",
        "Remaining useful life estimates (paper Figure 12)",
        path,
    )


def plot_convergence(ev: Evaluation, path: str | Path) -> Path:
    """Convergence event per error tolerance, mean over runs +- half a std (paper Figure 13).

    Left in braking events, as the paper; right as a fraction of each run's life, which
    compares runs of very different lives (the OOD runs span a factor ~7).
    """
    names = [n for n in ev.models if n not in _SKIP]
    splits = ev.splits
    fig = Figure(figsize=(11, 3.6 * len(splits)), layout="constrained")
    axes = fig.subplots(len(splits), 2, squeeze=False)
    for row, split in zip(axes, splits, strict=True):
        _convergence_panel(row[0], ev, names, split, "convergence_event")
        _convergence_panel(row[1], ev, names, split, "convergence_frac")
    fig.suptitle("RUL convergence sensitivity (paper Figure 13)")
    return _save(fig, path)


def _convergence_panel(ax: Axes, ev: Evaluation, names: list[str], split: str, key: str) -> None:
    lives = np.asarray(ev.metrics["splits"][split]["life_events"], dtype=np.float64)
    for i, name in enumerate(names):
        s = ev.metrics["models"][name]["splits"][split]
        tols = list(s["mean"][key])
        mean = np.array([s["mean"][key][t] for t in tols], dtype=np.float64)
        std = np.array([s["std"][key][t] for t in tols], dtype=np.float64)
        x = 100 * np.array([float(t) for t in tols])
        c = _color(name, i)
        ax.plot(x, mean, "o-", color=c, label=name)
        ax.fill_between(x, mean - 0.5 * std, mean + 0.5 * std, color=c, alpha=0.2)
    never = lives.mean() if key == "convergence_event" else 1.0
    ax.axhline(never, color="k", ls=":", label="end of life (never converges)")
    ax.set(
        xlabel="RUL error tolerance [% of life]",
        ylabel="convergence event" if key == "convergence_event" else "convergence / life",
        title=f"{split.upper()} runs (mean ± ½ std over {lives.size})",
    )
    ax.legend(fontsize=8)


def plot_all(ev: Evaluation, out_dir: str | Path) -> dict[str, Path]:
    """Every figure that applies to ``ev`` under ``out_dir``; name -> file."""
    out = Path(out_dir)
    figs = {
        "volume": plot_volume_estimates(ev, out / "volume_estimates.png"),
        "wear_coeff": plot_wear_coeff_estimates(ev, out / "wear_coeff_estimates.png"),
        "rul": plot_rul_estimates(ev, out / "rul_estimates.png"),
        "convergence": plot_convergence(ev, out / "convergence.png"),
    }
    return {k: v for k, v in figs.items() if v is not None}
