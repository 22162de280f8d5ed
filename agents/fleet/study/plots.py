"""Figures of the fleet study (matplotlib ``Figure`` objects, no pyplot state): one
episode of a policy (vehicles x shifts), the agents' learning curves, and each
predictor's best policy's cost by term."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.colors import ListedColormap
from matplotlib.figure import Figure
from numpy.typing import NDArray

from brake_env.output import atomic_path

# Duty codes of the episode figure and their colours (as the env's rgb frames draw them).
PARK, HOT, MILD, SHOP = 0, 1, 2, 3
_DUTY_COLORS = ["#d9d9d9", "#eb783c", "#5aa0e6", "#f0c419"]
_DUTY_NAMES = ["parked", "hot route", "mild route", "in the shop / refitted"]


def trace_episode(env: Any, policy: Any, seed: int) -> dict[str, NDArray[Any]]:
    """One episode of ``policy``, shift by shift: each vehicle's duty code (PARK, HOT, MILD,
    SHOP), refits, failures and breakdowns, and the windows, stock and pads on order."""
    base = env.unwrapped
    obs, _ = env.reset(seed=seed)
    rows: dict[str, list[Any]] = {k: [] for k in
                                  ("duty", "replaced", "failed", "broke_down", "window", "stock",
                                   "transit")}  # fmt: skip
    done = False
    while not done:
        action, _ = policy.predict(obs, deterministic=True)
        obs, _, terminated, truncated, info = env.step(action)
        veh = info["vehicles"]
        duty = np.where(veh["route"] == 0, HOT, np.where(veh["route"] == 1, MILD, PARK))
        duty[(base.shop.down > 0) | veh["replaced"]] = SHOP
        rows["duty"].append(duty)
        for k in ("replaced", "failed", "broke_down"):
            rows[k].append(np.asarray(veh[k], dtype=bool))
        rows["window"].append(bool(info["window"]))
        rows["stock"].append(int(base.shop.stock))
        rows["transit"].append(int(np.sum(base.shop.in_transit)))
        done = terminated or truncated
    return {k: np.array(v) for k, v in rows.items()}


def plot_episode(trace: Mapping[str, NDArray[Any]], title: str, path: str | Path) -> Path:
    """Vehicles x shifts: duty as colour, refits (|), failures (x), breakdowns (o), windows
    as ticks on top; stock and pads on order below."""
    duty = np.asarray(trace["duty"]).T  # (vehicles, shifts)
    n, t = duty.shape
    fig = Figure(figsize=(11, 1.2 + 0.35 * n + 1.6), layout="constrained")
    ax, ax2 = fig.subplots(2, 1, sharex=True, height_ratios=[max(n, 2), 2])
    ax.imshow(duty, aspect="auto", interpolation="nearest", vmin=0, vmax=3,
              cmap=ListedColormap(_DUTY_COLORS), extent=(0, t, n - 0.5, -0.5))  # fmt: skip
    for key, marker, color in (("replaced", "|", "k"), ("failed", "x", "#b30000"),
                               ("broke_down", "o", "#6a51a3")):  # fmt: skip
        s, v = np.nonzero(np.asarray(trace[key]))
        ax.scatter(s + 0.5, v, marker=marker, color=color, s=30, label=key.replace("_", " "),
                   facecolors="none" if marker == "o" else None, zorder=3)  # fmt: skip
    for w in np.flatnonzero(trace["window"]):
        ax.axvline(w + 0.5, color="k", lw=0.3, alpha=0.4)
    ax.set_yticks(range(n), [f"vehicle {i}" for i in range(n)])
    handles = [ax.scatter([], [], marker="s", color=c, label=lab)
               for c, lab in zip(_DUTY_COLORS, _DUTY_NAMES, strict=True)]  # fmt: skip
    ax.legend(handles=[*handles, *ax.get_legend_handles_labels()[0][: 3]], ncol=7, fontsize=7,
              loc="upper center", bbox_to_anchor=(0.5, -0.02), frameon=False)  # fmt: skip
    ax.set_title(title + " (thin lines: maintenance windows)")
    x = np.arange(t) + 0.5
    ax2.step(x, trace["stock"], where="mid", label="spares in stock")
    ax2.step(x, trace["transit"], where="mid", label="on order")
    ax2.set_ylabel("pads")
    ax2.set_xlabel("shift")
    ax2.legend(fontsize=7, loc="upper right")
    return _save(fig, path)


def plot_curves(agents: Mapping[str, Any], path: str | Path) -> Path:
    """Each agent's learning curve (cost per vehicle-shift on the curve episodes) per
    training seed, and its predictor's best tuned heuristic as a line."""
    fig = Figure(figsize=(7, 4), layout="constrained")
    ax = fig.add_subplot()
    drawn: set[str] = set()  # each predictor's heuristic once
    for i, (label, a) in enumerate(agents.items()):
        color, p = f"C{i}", a.get("predictor", label)
        name = "MaskablePPO" if a.get("kind", "central") == "central" else "shared MaskablePPO"
        for j, c in enumerate(a["curves"]):
            ax.plot(c["timesteps"], c["cost"], color=color, alpha=0.5, lw=1,
                    label=f"{name}, {p}'s RUL (each seed)" if j == 0 else None)  # fmt: skip
        if p not in drawn:
            drawn.add(p)
            tuned = f"{a['heuristic']} tuned, {p}'s RUL (evaluation episodes)"
            ax.axhline(a["heuristic_cost"], color=color, ls="--", label=tuned)
    ax.set_yscale("log")
    ax.set_xlabel("shifts of training")
    ax.set_ylabel("cost per vehicle-shift (log scale)")
    ax.set_title("Learning curves (cost on separate episodes)")
    ax.legend(fontsize=7)
    return _save(fig, path)


def plot_terms(terms: Mapping[str, Mapping[str, float]], path: str | Path) -> Path:
    """Each best policy's cost per vehicle-shift split by term (stacked bars)."""
    names = list(terms)
    keys = [k for k in next(iter(terms.values())) if any(abs(t[k]) > 0 for t in terms.values())]
    fig = Figure(figsize=(8, 0.45 * len(names) + 1.8), layout="constrained")
    ax = fig.add_subplot()
    left = np.zeros(len(names))
    for i, k in enumerate(keys):
        v = np.array([terms[n][k] for n in names])
        ax.barh(names, v, left=left, label=k, color=f"C{i}")
        left += v
    ax.invert_yaxis()
    ax.set_xlabel("cost per vehicle-shift (pads priced when fitted)")
    ax.set_title("Where the cost goes: each predictor's best tuned heuristic")
    ax.legend(fontsize=7, ncol=4, loc="lower right")
    return _save(fig, path)


def plot_distil(summary: Mapping[str, Any], path: str | Path) -> Path:
    """Each distilled policy's seeds (each seed's mean on the evaluation episodes) between
    the tuned heuristic, the rollout planner and the bound; the central policy's learning
    curves if PPO ran."""
    kinds = [k for k in ("central", "shared") if k in summary]
    curves = [r["curve"] for k in kinds for r in summary[k]["seeds"]
              if len(r["curve"].get("timesteps", [])) > 1]  # fmt: skip
    fig = Figure(figsize=(9 if curves else 6, 4), layout="constrained")
    ax = fig.add_subplot(1, 2 if curves else 1, 1)
    fig_name = "net cost" if summary["objective"] == "net" else "cost"
    for x, kind in enumerate(kinds):
        y = [r["figure"] for r in summary[kind]["seeds"]]
        ax.scatter(x + np.linspace(-0.15, 0.15, len(y)), y, color=f"C{x}", zorder=3,
                   label=f"{kind} policy (each seed)")  # fmt: skip
    c = summary[kinds[0]]["compared"]
    for key, label, style in (("base", f"{summary['base']}, tuned", "--"),
                              ("planner", "rollout planner", "-."),
                              ("bound", "Lagrangian bound (net)", ":")):  # fmt: skip
        if key in c and (key != "bound" or summary["objective"] == "net"):
            ax.axhline(c[key]["cost"], color="k", ls=style, lw=1, label=label)
    ax.set_xticks(range(len(kinds)), kinds)
    ax.set_xlim(-0.5, len(kinds) - 0.5)
    ax.set_ylabel(f"{fig_name} per vehicle-shift (evaluation episodes)")
    ax.set_title(f"The planner distilled, {summary['predictor']}'s RUL")
    ax.legend(fontsize=7)
    if curves:
        ax2 = fig.add_subplot(1, 2, 2)
        for cv in curves:
            ax2.plot(cv["timesteps"], cv["cost"], color="C0", alpha=0.5, lw=1)
        ax2.set_xlabel("shifts of PPO after cloning")
        ax2.set_ylabel("cost per vehicle-shift (curve episodes)")
        ax2.set_title("Learning curves")
    return _save(fig, path)


def _save(fig: Figure, path: str | Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format=path.suffix.lstrip("."))
    return path
