"""The digital twin (paper 2.4): a Bayesian grid filter over the wear coefficient K.

The paper infers the pad volume from each event's temperature through the atlas, inverts
"events needed to wear from a fresh pad to that volume" for K, and simulates forward to
failure. Given K, the expected wear path is closed-form (:mod:`brake_env.model.wear`): after
``n`` events the pad has done work ``u = K * n`` and sits in the layer where that work
ends, so the volume after ``n`` events is almost deterministic. The twin therefore keeps a
posterior over K on a log-spaced grid and updates it at every event with

    log p(T_meas | K) = -((T_meas - bias - T_atlas(v, m, theta; layer(K * n)))**2 / var
                          + log var) / 2,
    var = sigma_T**2 + (dT_atlas/dtheta * sigma_theta)**2,

where the second variance term carries the slope-sensor noise through the atlas (hot,
steep events are less informative). The paper's three steps map onto this:

- (a) reverse inference: the likelihood compares the measured temperature with every
  layer's atlas temperature at the event's measured conditions (one table per event);
- (b) identification: each grid K predicts the layer of every event, and the posterior
  weighs all of them (the paper's argmin of ``|N_sim(1 -> V_hat; K) - n|``, filtered over
  all events instead of taken from one);
- (c) prognosis: the events from the current state to failure at K are
  ``life(K) - n`` (closed-form sum over layers), averaged over the posterior; interval
  bounds are posterior quantiles, widened by the spread of the future operating mix.

A pad that keeps braking beyond ``life(K)`` rules that K out (a one-sided Gaussian term
with the operating-mix spread of the life). Per event the cost is a gather over the
layers and a few passes over the K grid, vectorised over the events of a batch.
"""

from __future__ import annotations

import math
from statistics import NormalDist
from typing import ClassVar

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from brake_env.model.atlas import Atlas
from brake_env.model.wear import WearModel
from brake_env.prognostics.protocol import EventBatch, Predictor, RULEstimate
from twin.calibration import fit_calibration
from twin.config import TwinCalibration, TwinConfig

F64 = NDArray[np.float64]


class DigitalTwin(Predictor):
    """Digital twin RUL predictor: online K identification through the atlas.

    Args:
        atlas: The atlas the twin reasons with (normally the one the data came from).
        config: Grid and prior settings.
        calibration: Prior and noise model; set by :meth:`fit` when not given.

    Attributes:
        wear: Closed-form wear path of the atlas.
        calibration: The prior over K and the temperature noise model, or None before fit.
    """

    name: ClassVar[str] = "twin"
    interval_level: ClassVar[float | None] = 0.9

    def __init__(
        self,
        atlas: Atlas,
        config: TwinConfig | None = None,
        *,
        calibration: TwinCalibration | None = None,
    ) -> None:
        super().__init__()
        self.atlas = atlas
        self.config = config or TwinConfig()
        self.wear = WearModel.from_atlas(atlas)
        self.calibration: TwinCalibration | None = None
        self._z = NormalDist().inv_cdf(0.5 + 0.5 * float(self.interval_level or 0.9))
        if calibration is not None:
            self.set_calibration(calibration)

    # ------------------------------------------------------------------ calibration
    def set_calibration(self, calibration: TwinCalibration) -> None:
        """Use ``calibration`` (prior over K and noise model); resets the posterior."""
        cfg = self.config
        self.calibration = calibration
        n = cfg.n_grid
        self._log_k0 = calibration.k_log_mean - math.log(cfg.grid_factor)
        self._dlog = 2.0 * math.log(cfg.grid_factor) / (n - 1)
        log_k = self._log_k0 + self._dlog * np.arange(n)
        self.k_grid = np.exp(log_k)
        self._life = self.wear.life(self.k_grid)
        self._life_std = self.wear.life_std(self.k_grid)
        z = (log_k - calibration.k_log_mean) / calibration.k_log_scale
        nu = calibration.prior_dof
        core = -0.5 * z**2 if math.isinf(nu) else -0.5 * (nu + 1.0) * np.log1p(z**2 / nu)
        p = np.exp(core - core.max())
        broad = np.exp(-0.5 * ((log_k - calibration.k_log_mean) / cfg.outlier_log_std) ** 2)
        p = (1.0 - cfg.outlier_weight) * p / p.sum() + cfg.outlier_weight * broad / broad.sum()
        self._log_prior = np.log(p)
        # Grid indices at which each layer's end is reached, per event: see _chunk.
        self._log_edges = np.log(self.wear.work_edges[:-1])
        self._reset()

    def _fit(self, train_log: pd.DataFrame) -> None:
        self.set_calibration(fit_calibration(self.atlas, train_log, self.config, self.wear))

    # ------------------------------------------------------------------ filtering
    def _reset(self) -> None:
        if self.calibration is not None:
            self._loglik = np.zeros(self.config.n_grid)

    @property
    def k_posterior(self) -> tuple[F64, F64]:
        """(K grid, normalised posterior weights) after the events seen so far (no survival
        term)."""
        if self.calibration is None:
            raise RuntimeError("twin: call fit() or give a calibration first")
        post = self._loglik + self._log_prior
        w = np.exp(post - post.max())
        return self.k_grid.copy(), w / w.sum()

    def _update(self, events: EventBatch) -> RULEstimate:
        if self.calibration is None:
            raise RuntimeError("twin: call fit() or give a calibration before update()")
        step = self.config.chunk_events
        parts = [self._chunk(events[i : i + step]) for i in range(0, len(events), step)]
        cols = [np.concatenate(c) for c in zip(*parts, strict=True)]
        return RULEstimate(*cols)

    def _chunk(self, ev: EventBatch) -> tuple[F64, F64, F64, F64, F64]:
        ll = self._layer_loglik(ev)
        post, n_after, tail, over = self._grid_posterior(ev, ll)
        return self._prognosis(post, n_after, tail, over)

    def _layer_loglik(self, ev: EventBatch) -> F64:
        """(a) Log-likelihood (events, layers) of each event's temperature at every layer."""
        cal = self.calibration
        assert cal is not None
        s, m, th, temp = ev.speed_kmh / 3.6, ev.mass_kg, ev.slope_rad, ev.temp_c
        ok = np.isfinite(s) & np.isfinite(m) & np.isfinite(th) & np.isfinite(temp)
        if not ok.all():  # a dropped-out channel: the event carries no evidence
            s, m, th, temp = (np.where(ok, x, 0.0) for x in (s, m, th, temp))
        t_atlas, dt_dslope = self.atlas.lookup.profile(s, m, th)
        var = cal.temp_sigma_c**2 + (dt_dslope * cal.slope_sigma_rad) ** 2
        r = (temp - cal.temp_bias_c)[:, None] - t_atlas
        ll = -0.5 * (r * r / var + np.log(var))
        ll -= ll.max(axis=1, keepdims=True)  # a constant per event: cancels in the posterior
        ll[~ok] = 0.0
        return ll

    def _grid_posterior(self, ev: EventBatch, ll: F64) -> tuple[F64, F64, int, F64]:
        """Unnormalised log posterior over the K grid after each event (the survival term
        included), the events done after each, and the survival overshoot of the grid
        points from ``tail`` on (the K whose life may already have ended)."""
        n, n_k = len(ev), self.config.n_grid
        # (b) layer of each event for each grid K: layer j+1 once K * k >= work_edges[j],
        # i.e. from grid index ceil((log work_j - log k - log K0) / dlog) on. The grid
        # log-likelihood is piecewise constant in K: scatter the jumps, then a cumsum.
        k_before = ev.event.astype(np.float64)
        with np.errstate(divide="ignore"):
            x = (self._log_edges[None, :] - np.log(k_before)[:, None] - self._log_k0) / self._dlog
        first = np.clip(np.ceil(x), 0, n_k).astype(np.intp)  # k = 0: x = inf -> n_k (never)
        rows = np.arange(n, dtype=np.intp)[:, None] * (n_k + 1)
        jumps: F64 = np.bincount(
            (rows + first).ravel(),
            weights=(ll[:, 1:] - ll[:, :-1]).ravel(),
            minlength=n * (n_k + 1),
        ).astype(np.float64, copy=False)
        grid_ll: F64 = np.cumsum(jumps.reshape(n, n_k + 1)[:, :n_k], axis=1)
        grid_ll += ll[:, :1]
        # Accumulate in event order from the carried sum: the same additions whatever the
        # batching, so batches of 1 and of a whole run give the same numbers.
        grid_ll[0] += self._loglik
        acc: F64 = np.cumsum(grid_ll, axis=0)
        self._loglik = acc[-1].copy()
        post = acc
        post += self._log_prior

        # Survival: the pad has done n_after events, so K whose life ends before is unlikely.
        n_after = k_before + 1.0
        last = float(n_after[-1])
        tail = int(np.searchsorted(-self._life, -(last + 8.0 * self._life_std.max())))
        over = np.maximum(n_after[:, None] - self._life[None, tail:], 0.0)
        if tail < n_k:
            post[:, tail:] -= 0.5 * (over / self._life_std[tail:]) ** 2
        return post, n_after, tail, over

    def _prognosis(
        self, post: F64, n_after: F64, tail: int, over: F64
    ) -> tuple[F64, F64, F64, F64, F64]:
        """(c) RUL(K) = life(K) - n_after averaged over the posterior; interval, volume, K."""
        n_k = self.config.n_grid
        post -= post.max(axis=1, keepdims=True)
        w = np.exp(post, out=post)
        z = w.sum(axis=1)
        k_mean = (w @ self.k_grid) / z
        rul = (w @ self._life) / z - n_after
        if tail < n_k:  # K whose life already ended contribute RUL 0, not a negative one
            rul += (w[:, tail:] * over).sum(axis=1) / z
        cdf = np.cumsum(w, axis=1)
        q = (1.0 - float(self.interval_level or 0.9)) / 2.0
        life_lo, life_med, life_hi = (
            self.wear.life(np.exp(self._log_quantile(cdf, w, z, p))) for p in (q, 0.5, 1.0 - q)
        )
        if self.config.point_estimate == "median":
            rul = np.maximum(life_med - n_after, 0.0)
        # Beyond K, the operating mix spreads the life: in the path so far (the volume is
        # known only through K) and in the future; ~ life_std(K) over a whole life.
        spread = self._z * self.wear.life_std(k_mean)
        lower = np.maximum(life_hi - n_after - spread, 0.0)
        upper = np.maximum(life_lo - n_after, 0.0) + spread
        volume = self.wear.volume_at_work(k_mean * n_after)
        return rul, lower, upper, volume, k_mean

    def _log_quantile(self, cdf: F64, w: F64, z: F64, p: float) -> F64:
        """log K at posterior probability ``p`` per event, linear inside the grid cell."""
        n_k = cdf.shape[1]
        target = p * z
        i = np.minimum((cdf < target[:, None]).sum(axis=1), n_k - 1)
        rows = np.arange(len(i))
        w_i = w[rows, i]
        frac = np.clip((target - (cdf[rows, i] - w_i)) / np.maximum(w_i, 1e-300), 0.0, 1.0)
        return self._log_k0 + self._dlog * (i - 0.5 + frac)


def make_twin(atlas: Atlas, seed: int = 0) -> DigitalTwin:
    """Registry factory (``brakewear.predictors``); the twin draws no random numbers."""
    return DigitalTwin(atlas)
