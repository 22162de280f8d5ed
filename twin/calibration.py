"""What the twin learns from training runs: the prior over K and the temperature noise
model (paper 2.4, identification)."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from brake_env.model.atlas import Atlas
from brake_env.model.wear import WearModel
from twin.config import TwinCalibration, TwinConfig

F64 = NDArray[np.float64]
FIT_COLUMNS = ("run_id", "event", "speed_kmh", "mass_kg", "slope_rad", "temp_c")


def fit_calibration(
    atlas: Atlas,
    train_log: pd.DataFrame,
    config: TwinConfig | None = None,
    wear: WearModel | None = None,
) -> TwinCalibration:
    """Learn the prior over K and the temperature noise model from run-to-failure runs.

    Each training run ends at failure, so its life ``N_i`` (events) is known and its K is
    ``life_work / N_i``. The prior on log K is the Student-t predictive of a new pad given
    the training pads (mean, spread, ``n - 1`` degrees of freedom). Along each run's
    expected wear path the residuals of measured temperature against the atlas give the
    bias and, by least squares of the squared residuals on the squared slope derivative,
    the temperature and slope-sensor noise.

    Args:
        atlas: The twin's atlas.
        train_log: Event log of at least two run-to-failure runs (columns ``run_id``,
            ``event``, ``speed_kmh``, ``mass_kg``, ``slope_rad``, ``temp_c``; others ignored).
        config: Floors and the number of events used for the noise fit.
        wear: The atlas's wear model, when already built.
    """
    config = config or TwinConfig()
    wear = wear or WearModel.from_atlas(atlas)
    codes, event, life = _training_lives(train_log)
    log_k = np.log(wear.life_work / life)
    n = life.size
    scale = max(float(np.std(log_k, ddof=1)), config.min_prior_log_std) * math.sqrt(1 + 1 / n)

    # Noise model along each run's expected path, on evenly strided events.
    stride = max(1, math.ceil(len(train_log) / config.fit_max_events))
    sel = np.arange(0, len(train_log), stride)
    k_run = np.exp(log_k)[codes[sel]]
    cols = {
        c: train_log[c].to_numpy(dtype=np.float64)[sel]
        for c in ("speed_kmh", "mass_kg", "slope_rad", "temp_c")
    }
    ok = np.logical_and.reduce([np.isfinite(v) for v in cols.values()])
    if ok.sum() < 10:
        raise ValueError("twin.fit: fewer than 10 training events with all channels finite")
    layer = wear.layer_at_work(k_run[ok] * event[sel][ok])
    t_atlas, dt = atlas.lookup.profile(
        cols["speed_kmh"][ok] / 3.6, cols["mass_kg"][ok], cols["slope_rad"][ok], layer=layer
    )
    r = cols["temp_c"][ok] - t_atlas
    bias = float(r.mean())
    r2, g2 = (r - bias) ** 2, dt**2
    a, b = _nonneg_line(g2, r2)
    return TwinCalibration(
        k_log_mean=float(log_k.mean()),
        k_log_scale=scale,
        prior_dof=float(n - 1),
        temp_bias_c=bias,
        temp_sigma_c=max(math.sqrt(max(a, 0.0)), config.min_temp_sigma_c),
        slope_sigma_rad=math.sqrt(b),
        n_runs=n,
    )


def _training_lives(
    train_log: pd.DataFrame,
) -> tuple[NDArray[np.intp], NDArray[np.int64], NDArray[np.int64]]:
    """Run code of each row, event of each row and life of each run of a training log of
    run-to-failure runs, after checking it."""
    missing = [c for c in FIT_COLUMNS if c not in train_log.columns]
    if missing:
        raise ValueError(f"twin.fit: the training log lacks column(s) {missing}")
    if len(train_log) == 0:
        raise ValueError("twin.fit: the training log is empty")
    codes, names = pd.factorize(train_log["run_id"], sort=False)
    if len(names) < 2:
        raise ValueError(
            f"twin.fit: needs at least 2 run-to-failure runs to learn a prior over K, got"
            f" {len(names)}"
        )
    event = train_log["event"].to_numpy()
    if not np.issubdtype(event.dtype, np.integer) or event.min() < 0:
        raise ValueError("twin.fit: column 'event' must hold integers >= 0")
    life = np.zeros(len(names), dtype=np.int64)
    np.maximum.at(life, codes, event.astype(np.int64))
    life += 1  # each run ends at its failure event: life = last event index + 1
    if life.min() < 2:
        bad = names[int(np.argmin(life))]
        raise ValueError(f"twin.fit: run {bad!r} has fewer than 2 events")
    return codes, event, life


def _nonneg_line(x: F64, y: F64) -> tuple[float, float]:
    """Least-squares ``y ~ a + b x`` with ``b >= 0`` (a variance cannot be negative)."""
    xm, ym = float(x.mean()), float(y.mean())
    sxx = float(((x - xm) ** 2).sum())
    b = float(((x - xm) * (y - ym)).sum()) / sxx if sxx > 0 else 0.0
    if b <= 0:
        return ym, 0.0
    return ym - b * xm, b
