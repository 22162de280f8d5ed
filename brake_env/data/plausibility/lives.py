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

CHUNK = 1 << 14  # rows per atlas profile call: ~80 MB of corners at 80 layers


def end_volumes(
    log: pd.DataFrame,
    atlas: Atlas,
    rows: NDArray[np.intp],
    group: NDArray[np.intp],
    n_groups: int,
    cfg: PlausibilityConfig,
) -> F64:
    """The pad volume most likely over each group of ``rows`` (``group``: the group of each
    row, e.g. a run's last events): the layer whose atlas temperatures at the events'
    conditions fit their readings best, Gaussian noise ``temp_sigma_c`` plus the slope noise
    through the atlas (the twin's reverse inference, without a prior on K). In chunks of
    ``CHUNK`` rows, so a fleet's worth of runs fits in memory."""
    sums = np.zeros((n_groups, atlas.n_layers))
    temp = log["temp_c"].to_numpy(dtype=np.float64)
    for c0 in range(0, rows.size, CHUNK):
        r = rows[c0 : c0 + CHUNK]
        temp_at, dslope, ok = atlas_profiles(log, atlas, r)
        var = (dslope * cfg.slope_sigma_rad) ** 2 + cfg.temp_sigma_c**2
        ll = -0.5 * ((np.where(ok > 0, temp[r], 0.0)[:, None] - temp_at) ** 2 / var + np.log(var))
        ll *= ok[:, None]
        np.add.at(sums, group[c0 : c0 + CHUNK], ll)
    return np.asarray(atlas.volumes[np.argmax(sums, axis=1)], dtype=np.float64)


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
    runs = np.flatnonzero(check & (counts >= 10))
    if runs.size:
        # The last events, no more than 2% of the run: over them the pad wears little.
        take = np.minimum(cfg.end_events, np.maximum(10, counts[runs] // 50))
        group = np.repeat(np.arange(runs.size), take)
        j = np.arange(take.sum()) - np.repeat(np.cumsum(take) - take, take)
        rows = order[(starts + counts)[runs][group] - take[group] + j]
        v_end[runs] = end_volumes(log, atlas, rows, group, runs.size, cfg)
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
