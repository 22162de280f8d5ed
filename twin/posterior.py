"""The twin's grid posterior over K: per-event evidence and the summary at a read-out.

:class:`TwinGrid` holds what a calibration fixes (the log-spaced K grid, the prior, the
life and its spread at every grid K, the layer edges of the wear clock) and the three
steps of the filter that :class:`twin.DigitalTwin` and :class:`twin.fleet.TwinFleet` share:

- :meth:`TwinGrid.layer_loglik`: each event's temperature log-likelihood at the atlas
  layers some grid K can be in (paper 2.4 (a), reverse inference), shape (events, layers);
- :meth:`TwinGrid.first_index`: from which grid index on each layer is the one an event
  falls in (each grid K predicts the layer of every event; paper 2.4 (b)), so an event's
  log-likelihood over the grid is piecewise constant with one jump per layer edge;
- :meth:`TwinGrid.summarise`: RUL, interval, volume and K from the unnormalised log
  posterior of a row, over all of the grid or a window of it (paper 2.4 (c), prognosis).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from brake_env.model.atlas import Atlas
from brake_env.model.wear import WearModel
from twin.config import TwinCalibration, TwinConfig

F64 = NDArray[np.float64]
Summary = tuple[F64, F64, F64, F64, F64]


@dataclass(frozen=True, eq=False)
class TwinGrid:
    """The K grid of a calibrated twin and the filter's arithmetic on it.

    Attributes:
        atlas, wear, config, calibration: What the grid was built from.
        interval_level: Nominal coverage of the RUL interval [-].
        k_grid: Grid over the wear coefficient K, log-spaced [-].
        log_k0, dlog: log K of the first grid point and the log step [-].
        log_prior: Log prior weight of each grid point (normalised) [-].
        life, life_std: Expected life at each grid K and its spread over the operating
            mix [events].
        log_edges: log of the work at which each layer ends but the last [K * events].
        z_interval: Standard normal quantile of the interval's upper tail [-].
    """

    atlas: Atlas
    wear: WearModel
    config: TwinConfig
    calibration: TwinCalibration
    interval_level: float
    k_grid: F64
    log_k0: float
    dlog: float
    log_prior: F64
    life: F64
    life_std: F64
    log_edges: F64
    z_interval: float

    @classmethod
    def build(
        cls,
        atlas: Atlas,
        wear: WearModel,
        config: TwinConfig,
        calibration: TwinCalibration,
        interval_level: float,
        z_interval: float,
    ) -> TwinGrid:
        """The grid around the calibration's prior median and the prior on it: the fitted
        Student-t on log K mixed with a broad log-normal (``config.outlier_weight``)."""
        n = config.n_grid
        log_k0 = calibration.k_log_mean - math.log(config.grid_factor)
        dlog = 2.0 * math.log(config.grid_factor) / (n - 1)
        log_k = log_k0 + dlog * np.arange(n)
        k_grid = np.exp(log_k)
        z = (log_k - calibration.k_log_mean) / calibration.k_log_scale
        nu = calibration.prior_dof
        core = -0.5 * z**2 if math.isinf(nu) else -0.5 * (nu + 1.0) * np.log1p(z**2 / nu)
        p = np.exp(core - core.max())
        broad = np.exp(-0.5 * ((log_k - calibration.k_log_mean) / config.outlier_log_std) ** 2)
        w = config.outlier_weight
        p = (1.0 - w) * p / p.sum() + w * broad / broad.sum()
        return cls(
            atlas=atlas,
            wear=wear,
            config=config,
            calibration=calibration,
            interval_level=interval_level,
            k_grid=k_grid,
            log_k0=log_k0,
            dlog=dlog,
            log_prior=np.log(p),
            life=wear.life(k_grid),
            life_std=wear.life_std(k_grid),
            log_edges=np.log(wear.work_edges[:-1]),
            z_interval=z_interval,
        )

    @property
    def n_grid(self) -> int:
        return int(self.k_grid.size)

    # ------------------------------------------------------------------ evidence
    def layers_reached(self, event: NDArray[np.int64]) -> slice:
        """The layers some grid K is in after any of ``event`` events: only their
        log-likelihoods enter the grid's (one jump per layer edge inside the grid)."""
        if event.size <= 16:  # finding the range costs more than it saves
            return slice(0, self.log_edges.size + 1)
        first = self.first_index(np.array([event.min(), event.max()]))
        return slice(int((first[0] == 0).sum()), int((first[1] < self.n_grid).sum()) + 1)

    def layer_loglik(self, s_kmh: F64, m: F64, th: F64, temp: F64, layers: slice) -> F64:
        """Log-likelihood (events, layers) of each event's temperature at the ``layers``,
        less its maximum over them (a constant per event, so every value is <= 0).

        ``log p = -((T - bias - T_atlas)**2 / var + log var) / 2`` with ``var = sigma_T**2
        + (dT_atlas/dslope * sigma_slope)**2``: the slope-sensor noise seen through the
        atlas. An event with a dropped-out channel carries no evidence (a row of zeros).
        """
        cal = self.calibration
        s = s_kmh / 3.6
        ok = np.isfinite(s) & np.isfinite(m) & np.isfinite(th) & np.isfinite(temp)
        if not ok.all():
            s, m, th, temp = (np.where(ok, x, 0.0) for x in (s, m, th, temp))
        prof = self.atlas.lookup.profiles(s, m, th, layers=layers)
        var = prof[:, 1] * cal.slope_sigma_rad
        var *= var
        var += cal.temp_sigma_c**2
        r = np.subtract((temp - cal.temp_bias_c)[:, None], prof[:, 0])
        r *= r
        r /= var
        r += np.log(var, out=var)
        r *= -0.5
        r -= r.max(axis=1, keepdims=True)
        r[~ok] = 0.0
        return r

    def first_index(self, event: NDArray[np.int64], edges: slice = slice(None)) -> NDArray[np.intp]:
        """(events, edges): the grid index from which on an event, done after ``event``
        events, lies beyond the end of each layer (of the ``edges`` slice of the layer
        ends): ``K * event >= work_edge``, i.e. ``ceil((log work_edge - log event - log K0)
        / dlog)``, clipped to ``[0, n_grid]`` (``n_grid``: no grid K gets there; event 0 is
        in the first layer)."""
        with np.errstate(divide="ignore"):
            log_n = np.log(event.astype(np.float64))
        x = np.subtract(self.log_edges[None, edges], log_n[:, None])
        x -= self.log_k0
        x /= self.dlog
        np.ceil(x, out=x)
        np.clip(x, 0, self.n_grid, out=x)
        return x.astype(np.intp)

    def survival(self, n_after: F64, lo: int = 0, hi: int | None = None) -> F64:
        """(rows, grid points in ``[lo, hi)``): how far each K's life falls short of the
        events done, in events (0 where the life is not over)."""
        return np.maximum(n_after[:, None] - self.life[None, lo:hi], 0.0)

    # ------------------------------------------------------------------ read-out
    def summarise(self, post: F64, lo: int, n_after: F64) -> Summary:
        """(c) RUL(K) = life(K) - n_after averaged over the posterior; interval, volume, K.

        Args:
            post: Unnormalised log posterior without the survival term, (rows, window) for
                the grid points ``[lo, lo + window)`` (overwritten).
            lo: First grid index of the window (points outside it weigh nothing).
            n_after: Events done after each row [-].

        Returns:
            (RUL mean, lower, upper [events], volume fraction [-], K mean [-]) per row.
        """
        hi = lo + post.shape[1]
        life, std = self.life[lo:hi], self.life_std[lo:hi]
        # A pad that kept braking beyond life(K) rules that K out, with the operating-mix
        # spread of the life; only K whose life is already over (life decreases with K).
        tail = int(np.searchsorted(-life, -float(n_after.max()), side="right"))
        over = self.survival(n_after, tail + lo, hi)
        post[:, tail:] -= 0.5 * (over / std[tail:]) ** 2
        post -= post.max(axis=1, keepdims=True)
        w = np.exp(post, out=post)
        z = w.sum(axis=1)
        k_mean = (w @ self.k_grid[lo:hi]) / z
        rul = (w @ life) / z - n_after
        rul += (w[:, tail:] * over).sum(axis=1) / z  # K whose life ended: RUL 0, not < 0
        np.maximum(rul, 0.0, out=rul)  # once every K's life is over the sum rounds to ~-1e-11
        q = (1.0 - self.interval_level) / 2.0
        life_lo, life_med, life_hi = self.wear.life(
            np.exp(self._log_quantiles(w, z, np.array([q, 0.5, 1.0 - q]), lo))
        ).T
        if self.config.point_estimate == "median":
            rul = np.maximum(life_med - n_after, 0.0)
        # Beyond K, the operating mix spreads the life: in the path so far (the volume is
        # known only through K) and in the future; ~ life_std(K) over a whole life.
        spread = self.z_interval * self.wear.life_std(k_mean)
        lower = np.maximum(life_hi - n_after - spread, 0.0)
        upper = np.maximum(life_lo - n_after, 0.0) + spread
        # The mean weighs the life table at the grid points, the interval interpolates K's
        # quantiles inside the cells: on a posterior peaked between a few points (physics the
        # pads do not follow) the mean can fall outside; the interval is widened to hold it.
        np.minimum(lower, rul, out=lower)
        np.maximum(upper, rul, out=upper)
        volume = self.wear.volume_at_work(k_mean * n_after)
        return rul, lower, upper, volume, k_mean

    def _log_quantiles(self, w: F64, z: F64, p: F64, lo: int) -> F64:
        """(rows, len(p)): log K at posterior probabilities ``p`` per row, linear inside
        the grid cell."""
        cdf = np.cumsum(w, axis=1)
        target = z[:, None] * p
        i = np.minimum((cdf[:, None, :] < target[:, :, None]).sum(axis=2), cdf.shape[1] - 1)
        rows = np.arange(len(i))[:, None]
        w_i, cdf_i = w[rows, i], cdf[rows, i]
        frac = np.clip((target - (cdf_i - w_i)) / np.maximum(w_i, 1e-300), 0.0, 1.0)
        return self.log_k0 + self.dlog * ((i + lo) - 0.5 + frac)
