"""The checks of runs counted as failures: lives too short, and unmarked censoring found by
reverse inference of the end volume through the atlas (:mod:`brake_env.data.plausibility`)."""

from __future__ import annotations

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from brake_env.data.plausibility.findings import Finding, PlausibilityConfig
from brake_env.data.plausibility.readings import F64, atlas_profiles
from brake_env.data.runs import run_ends
from brake_env.model.atlas import Atlas
from brake_env.model.regime import WearRegime
from brake_env.model.wear import WearModel


def end_volumes(
    log: pd.DataFrame, atlas: Atlas, rows: NDArray[np.intp], cfg: PlausibilityConfig
) -> F64:
    """The pad volume most likely at ``rows`` (one group of events of one run, last ones):
    the layer whose atlas temperatures at the events' conditions fit their readings best,
    Gaussian noise ``temp_sigma_c`` plus the slope noise through the atlas (the twin's
    reverse inference, without a prior on K)."""
    temp_at, dslope, ok = atlas_profiles(log, atlas, rows)
    t = log["temp_c"].to_numpy(dtype=np.float64)[rows]
    var = (dslope * cfg.slope_sigma_rad) ** 2 + cfg.temp_sigma_c**2
    ll = -0.5 * ((np.where(ok > 0, t, 0.0)[:, None] - temp_at) ** 2 / var + np.log(var))
    ll *= ok[:, None]
    return float(atlas.volumes[int(np.argmax(ll.sum(axis=0)))])  # type: ignore[return-value]


def lives(log: pd.DataFrame, atlas: Atlas, cfg: PlausibilityConfig) -> list[Finding]:
    ends = run_ends(log, "plausibility")
    out: list[Finding] = []
    life = ends.last_event + 1
    nominal = WearModel.from_atlas(atlas).life(WearRegime().k_mean)
    short = ends.failed & (life * cfg.max_k_ratio <= nominal)
    if short.any():
        out.append(
            Finding(
                "short",
                tuple(ends.names[short]),
                f"they count as failures after {int(np.median(life[short])):,} events (median),"
                f" under 1/{cfg.max_k_ratio:g} of a nominal pad's {nominal:,.0f}: too short to"
                " be lives (runs cut into pieces, a mislabelled run_id, or pads removed early"
                " without a 'failed' column: mark those 'failed' false)",
            )
        )
    out += _unmarked_censoring(log, atlas, ends.failed & ~short, ends.names, cfg)
    return out


def _unmarked_censoring(
    log: pd.DataFrame,
    atlas: Atlas,
    check: NDArray[np.bool_],
    names: NDArray[np.str_],
    cfg: PlausibilityConfig,
) -> list[Finding]:
    codes = pd.factorize(log["run_id"], sort=False)[0]
    order = np.argsort(codes, kind="stable")
    counts = np.bincount(codes, minlength=names.size)
    starts = np.r_[0, np.cumsum(counts)[:-1]]
    v_end = np.full(names.size, np.nan)
    for r in np.flatnonzero(check & (counts >= 10)):
        # The last events, no more than 2% of the run: over them the pad wears little.
        n = min(cfg.end_events, max(10, counts[r] // 50))
        rows = order[starts[r] + counts[r] - n : starts[r] + counts[r]]
        v_end[r] = end_volumes(log, atlas, rows, cfg)
    fv = atlas.failure_volume
    flagged = np.isfinite(v_end) & (v_end > fv + cfg.censor_margin)
    if not flagged.any():
        return []
    shown = ", ".join(
        f"{n} {v:.2f}" for n, v in zip(names[flagged][:5], v_end[flagged][:5], strict=True)
    )
    return [
        Finding(
            "censoring",
            tuple(names[flagged]),
            "they count as failures, but the temperatures of their last events (up to"
            f" {cfg.end_events}) say the pad ended at volume {shown} (atlas reverse"
            f" inference), far above the failure volume {fv:.2f}: pads removed before"
            " failure? mark their last row 'failed' false (fitted as lives, they make pads"
            " look short-lived)",
        )
    ]
