"""What the twin learns from training runs: the prior over K and the temperature noise
model (paper 2.4, identification), from run-to-failure and censored runs alike.

Real fleets rarely run pads to failure (docs/results/prognostics.md): most runs end at a planned
replacement, sometimes with the remaining volume measured in the workshop. Such a run's
length is a lower bound on its life, never a life. The prior over log K is therefore fitted
by maximum likelihood over three kinds of evidence:

- a run that ended at failure after ``N`` events: its K is ``life_work / N``, and it
  contributes the density of that log K;
- a run removed after ``n`` events: the survival probability ``P(life(K) > n)``, i.e. K
  below ``life_work / n``, integrated over the prior;
- a measured volume ``v`` after event ``e`` of a removed run: ``v`` is the volume the wear
  clock gives after ``e + 1`` events at K, with multiplicative measurement noise and the
  spread of the operating mix, integrated over the prior with the survival term.

With run-to-failure runs only the fit is the closed form of the sample mean and standard
deviation of log K.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import NDArray
from scipy import optimize, special

from brake_env.data.runs import RunEnds, run_ends
from brake_env.data.schema import MEASURED_VOLUME
from brake_env.model.atlas import Atlas
from brake_env.model.wear import WearModel
from twin.config import TwinCalibration, TwinConfig

F64 = NDArray[np.float64]
FIT_COLUMNS = ("run_id", "event", "speed_kmh", "mass_kg", "slope_rad", "temp_c")
VOLUME_NOISE = 0.02  # relative noise of a workshop volume measurement [-]
GRID_STEP = 0.004  # log-K step of the integration grid over censored runs [-]


@dataclass(frozen=True, eq=False)
class TrainingRuns:
    """The evidence of a training log, per run.

    Attributes:
        names: Run ids, in order of first appearance.
        codes: Run index of each row of the log.
        seen: Events from installation to the run's last logged event [-].
        failed: Whether the run ended at failure (else it was removed: censored).
        meas_run, meas_events, meas_volume: Measured volumes of censored runs: run index,
            events done when measured (event + 1) [-] and volume fraction [-].
    """

    names: NDArray[np.str_]
    codes: NDArray[np.intp]
    seen: NDArray[np.int64]
    failed: NDArray[np.bool_]
    meas_run: NDArray[np.intp]
    meas_events: F64
    meas_volume: F64

    @property
    def informative(self) -> NDArray[np.bool_]:
        """Runs whose K is pinned down: ended at failure or carry a measured volume."""
        out = self.failed.copy()
        out[self.meas_run] = True
        return out


def fit_calibration(
    atlas: Atlas,
    train_log: pd.DataFrame,
    config: TwinConfig | None = None,
    wear: WearModel | None = None,
) -> TwinCalibration:
    """Learn the prior over K and the temperature noise model from training runs.

    The prior on log K is the Student-t predictive of a new pad given the maximum-likelihood
    mean and spread over the runs (spread corrected to the unbiased one, ``n - 1`` degrees
    of freedom, ``n`` the runs that end at failure or carry a measured volume). Along the
    expected wear path of each of those ``n`` runs (K of a measured run: its posterior mean
    under that prior) the residuals of measured temperature against the atlas give the
    bias and, by least squares of the squared residuals on the squared slope derivative,
    the temperature and slope-sensor noise.

    Args:
        atlas: The twin's atlas.
        train_log: Event log of the training runs (columns ``run_id``, ``event``,
            ``speed_kmh``, ``mass_kg``, ``slope_rad``, ``temp_c``; optional ``failed``: a
            run whose last row is not marked failed was removed before failure; optional
            ``measured_volume_frac``: measured volume after that event, NaN where not
            measured). Without ``failed`` every run is taken to end at failure.
        config: Floors and the number of events used for the noise fit.
        wear: The atlas's wear model, when already built.

    Raises:
        ValueError: Missing columns, fewer than two runs that end at failure or carry a
            measured volume (the runs that only survived are named), or bad measurements.
    """
    config = config or TwinConfig()
    wear = wear or WearModel.from_atlas(atlas)
    runs = training_runs(train_log, wear)
    mu, s, n_info = fit_prior(runs, wear)
    log_k = run_log_k(runs, wear, mu, s)
    scale = max(s, config.min_prior_log_std)
    # Only runs whose K is pinned down trace a known path: a survival bound alone leaves the
    # layers of its events uncertain and would bias the temperature residuals.
    k_run = np.where(runs.informative, np.exp(log_k), np.nan)
    noise = _noise_model(atlas, train_log, wear, k_run[runs.codes], config)
    return TwinCalibration(
        k_log_mean=mu,
        k_log_scale=scale * math.sqrt(1 + 1 / n_info),
        prior_dof=float(n_info - 1),
        temp_bias_c=noise[0],
        temp_sigma_c=max(noise[1], config.min_temp_sigma_c),
        slope_sigma_rad=noise[2],
        n_runs=len(runs.names),
    )


def training_runs(train_log: pd.DataFrame, wear: WearModel) -> TrainingRuns:
    """The evidence of each run of a training log, after checking it."""
    missing = [c for c in FIT_COLUMNS if c not in train_log.columns]
    if missing:
        raise ValueError(f"twin.fit: the training log lacks column(s) {missing}")
    if len(train_log) == 0:
        raise ValueError("twin.fit: the training log is empty")
    event = train_log["event"].to_numpy()
    if not np.issubdtype(event.dtype, np.integer) or event.min() < 0:
        raise ValueError("twin.fit: column 'event' must hold integers >= 0")
    ends = run_ends(train_log, "twin.fit")
    codes, names, failed = ends.codes, ends.names, ends.failed
    seen = np.zeros(len(names), dtype=np.int64)
    np.maximum.at(seen, codes, event.astype(np.int64))
    seen += 1  # events from installation to the end of the last logged one
    short = np.flatnonzero(failed & (seen < 2))
    if short.size:
        raise ValueError(f"twin.fit: run {names[short[0]]!r} failed within its first event")
    meas_run, meas_events, meas_volume = _measurements(train_log, ends)
    return TrainingRuns(names, codes, seen, failed, meas_run, meas_events, meas_volume)


def _measurements(train_log: pd.DataFrame, ends: RunEnds) -> tuple[NDArray[np.intp], F64, F64]:
    """Measured volumes of the censored runs (those of failed runs add nothing)."""
    keep = ~ends.failed[ends.codes[ends.meas_rows]]
    rows, v = ends.meas_rows[keep], ends.meas_volume[keep]
    bad = np.flatnonzero((v <= 0.0) | (v > 1.0 + 5 * VOLUME_NOISE))
    if bad.size:
        i = int(rows[bad[0]])
        raise ValueError(
            f"twin.fit: column {MEASURED_VOLUME!r}, row {i}, run {ends.names[ends.codes[i]]!r}:"
            f" a volume fraction of {v[bad[0]]:g} is impossible for a pad still in service"
        )
    events = train_log["event"].to_numpy()[rows].astype(np.float64) + 1.0
    return ends.codes[rows], events, v


def fit_prior(runs: TrainingRuns, wear: WearModel) -> tuple[float, float, int]:
    """Maximum-likelihood mean of log K over the runs, its spread (the ML one corrected to
    the unbiased one) and the number of informative runs.

    Raises:
        ValueError: Fewer than two runs that end at failure or carry a measured volume.
    """
    n_info = int(runs.informative.sum())
    if n_info < 2:
        only = list(runs.names[~runs.informative][:5])
        raise ValueError(
            f"twin.fit: needs at least 2 runs that end at failure or carry a measured volume"
            f" ({MEASURED_VOLUME!r}), got {n_info}; runs like {only} were removed before"
            " failure and only bound their lives from below, so they cannot set the prior"
            " over K"
        )
    x_fail = np.log(wear.life_work / runs.seen[runs.failed])
    if runs.failed.all():  # closed form: the sample mean and (ML) spread of log K
        return float(x_fail.mean()), float(np.std(x_fail, ddof=1)), n_info
    grid, ll = censored_loglik(runs, wear)
    x0 = np.concatenate([x_fail, _measured_log_k(runs, wear)])
    start = np.array([x0.mean(), math.log(max(float(x0.std()), 0.05))])

    def nll(p: F64) -> float:
        return -_log_likelihood(float(p[0]), math.exp(float(p[1])), x_fail, grid, ll)

    res = optimize.minimize(nll, start, method="Nelder-Mead", options={"xatol": 1e-6})
    return float(res.x[0]), math.exp(float(res.x[1])) * math.sqrt(n_info / (n_info - 1)), n_info


def _measured_log_k(runs: TrainingRuns, wear: WearModel) -> F64:
    """The K of each measured volume by closed-form identification (the fit's start)."""
    v = np.clip(runs.meas_volume, wear.lower_edges[-1], 1.0)
    return np.log(np.maximum(wear.identify_k(v, runs.meas_events), 1e-300))


def censored_loglik(runs: TrainingRuns, wear: WearModel) -> tuple[F64, F64]:
    """A log-K grid and each censored run's log-likelihood on it, shape (runs, grid):
    survival past its last event plus its measured volumes."""
    cens = np.flatnonzero(~runs.failed)
    anchors = np.log(wear.life_work / runs.seen.astype(np.float64))
    if runs.meas_volume.size:
        anchors = np.concatenate([anchors, _measured_log_k(runs, wear)])
    lo, hi = float(anchors.min()) - 3.0, float(anchors.max()) + 1.0
    grid = np.arange(lo, hi + GRID_STEP, GRID_STEP)
    k = np.exp(grid)
    life, life_std = wear.life(k), wear.life_std(k)
    seen = runs.seen[cens].astype(np.float64)[:, None]
    ll = special.log_ndtr((life - seen) / np.maximum(life_std, 1e-9))
    if runs.meas_volume.size:
        slot = np.full(len(runs.names), -1)
        slot[cens] = np.arange(cens.size)
        np.add.at(ll, slot[runs.meas_run], _volume_loglik(runs, wear, k))
    return grid, ll


def _volume_loglik(runs: TrainingRuns, wear: WearModel, k: F64) -> F64:
    """Log-likelihood (measurements, grid) of each measured volume at every grid K: the
    clock's volume after the events done, with relative noise ``VOLUME_NOISE`` and the
    spread of the operating mix carried through the clock's slope."""
    u = k[None, :] * runs.meas_events[:, None]
    v_pred = wear.volume_at_work(u)
    layer = wear.layer_at_work(u)
    tops = np.concatenate([[0.0], wear.work_edges[:-1]])
    slope = (wear.volumes - wear.lower_edges) / (wear.work_edges - tops)  # -dv/du per layer
    var_u = k[None, :] * wear.life_var_work * np.minimum(u / wear.life_work, 1.0)
    var = (VOLUME_NOISE * v_pred) ** 2 + slope[layer] ** 2 * var_u
    r = runs.meas_volume[:, None] - v_pred
    out: F64 = -0.5 * (r * r / var + np.log(var))
    return out


def _log_likelihood(mu: float, s: float, x_fail: F64, grid: F64, ll: F64) -> float:
    """Log-likelihood of the prior (mu, s): failed runs' densities plus each censored
    run's evidence integrated over the prior on the grid."""
    z = (x_fail - mu) / s
    out = float(np.sum(-0.5 * z * z - math.log(s)))
    log_prior = -0.5 * ((grid - mu) / s) ** 2 - math.log(s) - 0.5 * math.log(2 * math.pi)
    out += float(special.logsumexp(ll + log_prior + math.log(GRID_STEP), axis=1).sum())
    return out


def run_log_k(runs: TrainingRuns, wear: WearModel, mu: float, s: float) -> F64:
    """log K of each run: exact for a failed run, the posterior mean under the fitted prior
    for a censored one."""
    out = np.log(wear.life_work / runs.seen.astype(np.float64))
    cens = np.flatnonzero(~runs.failed)
    if cens.size:
        grid, ll = censored_loglik(runs, wear)
        post = ll - 0.5 * ((grid - mu) / s) ** 2
        w = np.exp(post - post.max(axis=1, keepdims=True))
        out[cens] = (w @ grid) / w.sum(axis=1)
    return out


def _noise_model(
    atlas: Atlas, train_log: pd.DataFrame, wear: WearModel, k_row: F64, config: TwinConfig
) -> tuple[float, float, float]:
    """(temperature bias, temperature noise, slope noise) along each run's expected path,
    on evenly strided events; ``k_row`` is the K of each row's run (NaN: left out)."""
    stride = max(1, math.ceil(len(train_log) / config.fit_max_events))
    sel = np.arange(0, len(train_log), stride)
    cols = {
        c: train_log[c].to_numpy(dtype=np.float64)[sel]
        for c in ("speed_kmh", "mass_kg", "slope_rad", "temp_c")
    }
    ok = np.logical_and.reduce([np.isfinite(v) for v in (*cols.values(), k_row[sel])])
    if ok.sum() < 10:
        raise ValueError("twin.fit: fewer than 10 training events with all channels finite")
    event = train_log["event"].to_numpy()[sel][ok]
    layer = wear.layer_at_work(k_row[sel][ok] * event)
    t_atlas, dt = atlas.lookup.profile(
        cols["speed_kmh"][ok] / 3.6, cols["mass_kg"][ok], cols["slope_rad"][ok], layer=layer
    )
    r = cols["temp_c"][ok] - t_atlas
    bias = float(r.mean())
    a, b = _nonneg_line(dt**2, (r - bias) ** 2)
    return bias, math.sqrt(max(a, 0.0)), math.sqrt(b)


def _nonneg_line(x: F64, y: F64) -> tuple[float, float]:
    """Least-squares ``y ~ a + b x`` with ``b >= 0`` (a variance cannot be negative)."""
    xm, ym = float(x.mean()), float(y.mean())
    sxx = float(((x - xm) ** 2).sum())
    b = float(((x - xm) * (y - ym)).sum()) / sxx if sxx > 0 else 0.0
    if b <= 0:
        return ym, 0.0
    return ym - b * xm, b
