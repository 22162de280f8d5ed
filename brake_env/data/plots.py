"""Figures: the calibration, run-to-failure volume curves and one run's channels (Figure 4)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.figure import Figure  # no pyplot: no global state, no display backend

from brake_env.data.datasets import SimulatedRun
from brake_env.model.atlas import Atlas
from brake_env.model.materials import friction, hardness_mpa
from brake_env.model.physics import simulate_events
from brake_env.output import atomic_path

SPLIT_COLORS = {"train": "tab:blue", "id": "tab:green", "ood": "tab:red"}


def _save(fig: Figure, path: str | Path) -> Path:
    path = Path(path)
    with atomic_path(path) as tmp:  # the temporary name keeps the suffix: PNG
        fig.savefig(tmp, dpi=110, bbox_inches="tight")
    return path


def plot_calibration(
    atlas: Atlas, path: str | Path, compare: dict[str, Atlas] | None = None
) -> Path:
    """Four panels: mu, H and mu*H against T; wear per event, mean temperature and the
    severe event against remaining volume. ``compare`` adds other calibrations' curves."""
    fig = Figure(figsize=(11, 8))
    ax = fig.subplots(2, 2)
    _materials_panel(ax[0, 0], atlas)
    _wear_and_temperature_panels(ax[0, 1], ax[1, 0], {"default": atlas, **(compare or {})})
    _severe_event_panel(ax[1, 1], atlas)
    fig.tight_layout()
    return _save(fig, path)


def _materials_panel(a: Axes, atlas: Atlas) -> None:
    t = np.linspace(0, 900, 400)
    mu, h = friction(t, atlas.spec.model.friction), hardness_mpa(t, atlas.spec.model.hardness)
    a.plot(t, mu * h, "k", label=r"$\mu H$ [MPa]  (wear $\propto E/(\mu H)$)")
    a.plot(t, 200 * mu, "tab:blue", label=r"$200\,\mu$")
    a.plot(t, h, "tab:orange", label="H [MPa]")
    tm = atlas.fields["temp_mean_c"]
    a.axvspan(
        tm.min(),
        np.percentile(tm, 99),
        color="tab:red",
        alpha=0.12,
        label="mean event temperatures (atlas)",
    )
    a.set(xlabel="temperature [°C]", title="Friction and hot hardness (paper Tables 1, 3)")
    a.legend(fontsize=8)


def _wear_and_temperature_panels(wear_ax: Axes, temp_ax: Axes, atlases: dict[str, Atlas]) -> None:
    for name, at in atlases.items():
        w = at.expected("wear_per_k_m3")
        wear_ax.plot(at.volumes * 100, w / w[0], label=f"{name} (end/fresh {w[-1] / w[0]:.3f})")
        temp_ax.plot(at.volumes * 100, at.expected("temp_mean_c"), label=name)
    wear_ax.axhline(1.2, color="grey", ls=":", label="target 1.2")
    wear_ax.set(
        xlabel="remaining pad volume [%]",
        ylabel="mean wear per event / fresh pad",
        title="Wear acceleration (uniform operating conditions)",
    )
    atlas = atlases["default"]
    lo = atlas.fields["temp_mean_c"].reshape(atlas.n_layers, -1)
    temp_ax.fill_between(
        atlas.volumes * 100, lo.min(1), lo.max(1), alpha=0.2, label="default: range over the grid"
    )
    temp_ax.set(
        xlabel="remaining pad volume [%]",
        ylabel="mean event temperature [°C]",
        title="Temperature rises as the pad thins",
    )
    for a in (wear_ax, temp_ax):
        a.invert_xaxis()
        a.legend(fontsize=8)


def _severe_event_panel(a: Axes, atlas: Atlas) -> None:
    v, m, th = atlas.spec.model.envelope.severe_event
    vols = np.linspace(1.0, max(atlas.failure_volume - 0.05, 0.01), 300)
    r = simulate_events(v, m, th, vols, atlas.spec.model)
    lines = a.plot(vols * 100, r.stop_dist_m, "tab:purple", label="stopping distance [m]")
    a2 = a.twinx()
    lines += a2.plot(vols * 100, r.temp_peak_c, "tab:red", label="peak temperature [°C]")
    lines.append(
        a.axvline(
            atlas.failure_volume * 100,
            color="k",
            ls="--",
            label=f"end of life: {atlas.failure_volume:.1%} ({atlas.failure_mode})",
        )
    )
    a.set(
        xlabel="remaining pad volume [%]",
        ylabel="stopping distance [m]",
        title="Severe event (54 t, 15 km/h, 10°)",
    )
    a2.set_ylabel("peak temperature [°C]")
    a.invert_xaxis()
    a.legend(handles=lines, loc="upper left", fontsize=8)


def plot_volume_trajectories(runs: list[SimulatedRun], path: str | Path) -> Path:
    """Pad volume against event for every run, coloured by split (paper Figure 4a)."""
    fig = Figure(figsize=(9, 5))
    ax = fig.subplots()
    seen = set()
    for split, t in ((r.split, r.trajectory) for r in runs):
        step = max(1, t.n_events // 2000)
        ax.plot(
            np.arange(0, t.n_events, step),
            t.volume_frac[::step] * 100,
            lw=1,
            color=SPLIT_COLORS.get(split, "k"),
            label=None if split in seen else split,
        )
        seen.add(split)
    if runs:
        ax.axhline(
            runs[0].trajectory.final_volume_frac * 100, color="grey", ls=":", label="failure"
        )
    ax.set(
        xlabel="braking event",
        ylabel="remaining pad volume [%]",
        title="Run-to-failure pad volume (10 train, 10 ID, 10 OOD)",
    )
    ax.legend()
    return _save(fig, path)


def plot_trace(log: pd.DataFrame, run_id: str, path: str | Path) -> Path:
    """Measured channels and ground truth of one run against event (paper Figure 4b)."""
    df = log[log["run_id"] == run_id]
    if df.empty:
        raise ValueError(f"run {run_id!r} is not in the log")
    step = max(1, len(df) // 3000)
    d = df.iloc[::step]
    chans = [
        ("speed_kmh", "speed [km/h]"),
        ("mass_kg", "mass [kg]"),
        ("slope_rad", "slope [rad]"),
        ("energy_j", "kinetic energy [J]"),
        ("temp_c", "mean temperature [°C]"),
        ("stop_dist_m", "stopping distance [m]"),
        ("volume_frac", "volume (truth)"),
        ("rul_events", "RUL [events] (truth)"),
    ]
    fig = Figure(figsize=(11, 9))
    axes = fig.subplots(4, 2, sharex=True)
    for a, (c, label) in zip(axes.ravel(), chans, strict=True):
        a.plot(d["event"], d[c], ".", ms=1.5, alpha=0.5)
        if c in ("temp_c", "stop_dist_m"):
            roll = df[c].rolling(2000, center=True, min_periods=200).mean().iloc[::step]
            a.plot(d["event"], roll, "k", lw=1.2, label="rolling mean (2000 events)")
            a.legend(fontsize=7)
        a.set_ylabel(label, fontsize=8)
    for a in axes[-1]:
        a.set_xlabel("braking event")
    fig.suptitle(f"Run {run_id}: {len(df)} events (every {step}th shown)")
    fig.tight_layout()
    return _save(fig, path)
