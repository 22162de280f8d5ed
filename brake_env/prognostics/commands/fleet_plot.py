"""``fleet.png`` of ``brakewear predict``: the pads' RUL at a glance (matplotlib imported
only when the figure is drawn: it costs start-up time)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from brake_env.csv_safe import plain_text

if TYPE_CHECKING:
    from matplotlib.figure import Figure

TRACE_PADS = 12  # pads drawn in the figure's trace panel (the most urgent)


def plot_fleet(fleet: pd.DataFrame, traces: pd.DataFrame, name: str, log_name: str) -> Figure:
    """PNG of the fleet: current RUL per pad with its interval (most urgent on top), and the
    RUL along the logged events of the most urgent pads."""
    from matplotlib.figure import Figure  # matplotlib only when plotting (start-up time)

    n = len(fleet)
    fig = Figure(figsize=(12, max(3.5, 1.0 + 0.28 * n)), layout="constrained")
    bars, lines = fig.subplots(1, 2, width_ratios=(1, 1.4))
    y = np.arange(n)[::-1]
    rul = fleet["rul_mean"].to_numpy()
    flagged = fleet["missing_channels"].to_numpy() != ""
    bars.barh(y, rul, color=np.where(flagged, "tab:red", "tab:green"), alpha=0.8)
    if "rul_lower" in fleet:
        err = np.vstack([rul - fleet["rul_lower"], fleet["rul_upper"] - rul]).clip(0)
        bars.errorbar(rul, y, xerr=err, fmt="none", ecolor="k", capsize=2, lw=0.8)
    pairs = zip(fleet["run_id"], fleet["missing_channels"], strict=True)
    labels = [plain_text(r) + (f" (no {m})" if m else "") for r, m in pairs]
    bars.set_yticks(y, labels, fontsize=8)
    note = " (red: a channel missing for the whole pad)" if flagged.any() else ""
    bars.set_xlabel("RUL now [braking events]" + note)
    bars.set_title(f"{name}: {n} pads of {plain_text(log_name)}, most urgent on top")
    for run_id in fleet["run_id"][:TRACE_PADS]:
        t = traces[traces["run_id"] == run_id]
        step = max(1, len(t) // 2000)
        lines.plot(
            t["event"].to_numpy()[::step],
            t["rul_mean"].to_numpy()[::step],
            label=plain_text(run_id),
        )
    lines.set_xlabel("events since installation")
    lines.set_ylabel("RUL [braking events]")
    lines.set_title(f"RUL along the log ({min(n, TRACE_PADS)} most urgent pads)")
    lines.legend(fontsize=7, ncols=2)
    lines.set_ylim(bottom=0)
    return fig
