"""A plan for the fleet as it stands: the decision for the coming shift, what the futures say
of the pads up to and through the next window, and their cost (``brakewear plan``).

``plan_table`` is ``plan.csv``: one row per vehicle. ``plan_summary`` is ``plan.json``: the
expected cost over the horizon with the interval of the realised cost (5th to 95th
percentile over the futures: what the plan's cost will be, not only its mean) and a
bootstrap interval of the mean, the spares to order, the as-of time. The probability of a
failure before the window (``p_fail_before_window``) is the pad's if it kept the coming
shift's duty until the window, from its RUL's lognormal (a parked or serviced vehicle does
not brake: 0); ``p_fail_in_plan`` is how often it failed in the futures, where the policy
goes on deciding.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from agents.fleet.operate.estimates import LEVEL, VehicleEstimates, p_fail_within
from agents.fleet.operate.futures import Futures
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.route_rul import ROUTE_NAMES, duty_clocks
from brake_env.env.fleet.shop import ACTIONS
from brake_env.model.atlas import Atlas
from brake_env.prognostics.duty import DutyClocks

F64 = NDArray[np.float64]
BOOTSTRAP = 2_000


def route_shifts(est: VehicleEstimates, clocks: DutyClocks, per_shift: float) -> dict[str, F64]:
    """Each pad's RUL (mean, lower, upper) on each route in shifts of that route."""
    ratio = clocks.remaining_ratio(est.volume)
    out = {}
    for j, r in enumerate(clocks.names):
        for name, x in (("", est.mean), ("_lo", est.lower), ("_hi", est.upper)):
            out[f"rul_{r}_shifts{name}"] = x * ratio[:, j] / per_shift
    return out


def plan_table(
    est: VehicleEstimates, config: FleetConfig, atlas: Atlas, fut: Futures, shift: int
) -> pd.DataFrame:
    """``plan.csv``: per vehicle the coming shift's duty, whether it gets new pads by the
    end of the next window, its route RULs with intervals and its risk before the window."""
    clocks = duty_clocks(atlas, ROUTE_NAMES)
    per = float(config.events_per_shift)
    n = config.n_vehicles
    duty = fut.first_action[:n]
    to_window = config.shifts_to_window(shift)
    ratio = clocks.remaining_ratio(est.volume)  # base-mix events per route event: 1/ratio
    brakes = np.isin(duty, (0, 1))
    route = np.where(brakes, duty, 0)
    base_events = to_window * per / ratio[np.arange(n), route]
    p_fail = np.where(brakes, p_fail_within(est, base_events), 0.0)
    table = {
        "vehicle": list(est.vehicles),
        "duty": [ACTIONS[int(d)] for d in duty],
        "replace_at_next_window": fut.window_fit.mean(axis=0) >= 0.5,
        "p_new_pads_by_window": fut.fitted.mean(axis=0),
        **route_shifts(est, clocks, per),
        "p_fail_before_window": p_fail,
        "p_fail_in_plan": fut.failed.mean(axis=0),
        "events_since_install": est.age.astype(np.int64),
        "volume_frac": est.volume,
    }
    return pd.DataFrame(table)


def plan_summary(
    est: VehicleEstimates, config: FleetConfig, fut: Futures, context: dict[str, Any]
) -> dict[str, Any]:
    """``plan.json``'s figures; ``context`` (inputs, the fleet, the as-of time) is kept."""
    rng = np.random.default_rng(0)
    idx = rng.integers(0, fut.cost.size, size=(BOOTSTRAP, fut.cost.size))
    means = fut.cost[idx].mean(axis=1)
    lo, hi = (1 - LEVEL) / 2, 1 - (1 - LEVEL) / 2
    stamps = [t for t in est.as_of if t is not None]
    at_window = fut.window_fit.mean(axis=0) >= 0.5
    return {
        **context,
        "as_of": max(stamps) if stamps else None,
        "futures": int(fut.cost.size),
        "expected_cost": float(fut.cost.mean()),
        "expected_cost_interval": [float(np.quantile(means, lo)), float(np.quantile(means, hi))],
        "cost_interval": [float(np.quantile(fut.cost, lo)), float(np.quantile(fut.cost, hi))],
        "cost_interval_level": LEVEL,
        "cost_by_term": {k: float(v.mean()) for k, v in fut.terms.items()},
        "order_now": int(fut.first_action[-1]),
        "coming_shift": fut.coming,
        "pads_ordered_over_horizon": float(fut.ordered.mean()),
        "replace_at_next_window": [est.vehicles[i] for i in np.flatnonzero(at_window)],
        "service_now": [est.vehicles[i] for i in np.flatnonzero(fut.first_action[:-1] == 3)],
        "seconds": round(fut.seconds, 2),
    }


def plot_plan(table: pd.DataFrame, summary: dict[str, Any], path: Any) -> None:
    """Vehicles by risk: the chance of a failure before the window on the coming duty,
    coloured by that duty, hatched where the plan fits new pads by the window."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    colours = {"hot": "#d62728", "mild": "#ff7f0e", "park": "#7f7f7f", "service": "#1f77b4"}
    t = table.sort_values(["p_fail_before_window", "rul_hot_shifts"], ascending=[True, False])
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 0.35 * len(t) + 2), sharey=True)
    y = np.arange(len(t))
    p = t["p_fail_before_window"].to_numpy()
    ax.barh(y, np.maximum(p, 0.01), color=[colours[d] for d in t["duty"]],
            hatch=["//" if r else "" for r in t["replace_at_next_window"]])  # fmt: skip
    for yi, pi in zip(y, p, strict=True):
        ax.text(max(pi, 0.01) + 0.01, yi, f"{pi:.2f}", va="center", fontsize=8)
    ax.set_yticks(y, t["vehicle"])
    ax.set_xlabel("P(failure before the window) on the coming duty")
    ax.set_xlim(0, 1)
    hot = t["rul_hot_shifts"]
    err = [hot - t["rul_hot_shifts_lo"], t["rul_hot_shifts_hi"] - hot]
    bx.errorbar(t["rul_hot_shifts"], y, xerr=err, fmt="o", color="k", capsize=2)
    bx.axvline(summary["shifts_to_window"], color="#1f77b4", ls="--", label="next window")
    bx.set_xlabel("RUL on the hot route [shifts], 90% interval")
    bx.set_xscale("log")
    bx.legend(loc="lower right")
    handles = [plt.Rectangle((0, 0), 1, 1, color=c) for c in colours.values()]
    ax.legend(handles, list(colours), title="coming shift", loc="lower right")
    fig.suptitle(
        f"Plan as of {as_of(summary)}: window in {summary['shifts_to_window']}"
        f" shifts; expected cost {summary['expected_cost']:,.0f} {summary['currency']}"
        f" (90%: {summary['cost_interval'][0]:,.0f}-{summary['cost_interval'][1]:,.0f})"
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def as_of(summary: dict[str, Any]) -> str:
    """The plan's as-of time as printed: the log's clock (``time_s``) of the last event."""
    t = summary["as_of"]
    return "the log's end (no time stamps)" if t is None else f"time_s {t:,.0f}"
