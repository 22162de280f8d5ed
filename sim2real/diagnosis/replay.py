"""Replay of logged braking events through the nominal model, optionally with one effect.

The log gives each event's operating conditions; the pad state is not logged, so it is
estimated from the log itself (docs/results/sim2real.md, localise):

- each event's relative wear severity gives an *operational time* u
  (:func:`sim2real.diagnosis.logdata.operational_time`);
- the model's mean wear per event in each layer over the log's own mix of conditions gives
  the wear clock (:class:`brake_env.model.wear.WearModel`, paper 2.4): the work ``K * u``
  needed to wear a fresh pad down to each volume;
- the volume at event k is the clock's volume at work ``K u_k``, with the pad's K fitted
  per run by maximum likelihood of the readings (:mod:`sim2real.diagnosis.padfit`);
- a model whose effect changes the wear law re-weights the severities with it, so a wear
  law in speed shows where the operating mix changes along a run (alternating routes).

A model with an effect answers through the nominal atlas plus the effect's change on a
coarse grid (:mod:`sim2real.effects.grid`). A between-events effect moves each event's start
temperature (two lags of the recurrence, linear in the start temperature); a sensor effect
transforms the predicted temperature. The noisy slope reading is integrated out over its
posterior (a truncated normal on the envelope), and stop-distance readings are floored at 0
like the logger does.
"""

from __future__ import annotations

import copy
import dataclasses
from dataclasses import dataclass

import numpy as np
from scipy.special import ndtr, ndtri

from brake_env.model.atlas import Atlas
from brake_env.model.lookup import RegularGridInterp
from brake_env.model.physics import critical_volume, end_of_life, simulate_events
from brake_env.model.simulator import SensorNoise
from brake_env.model.wear import WearModel
from sim2real.diagnosis.logdata import F64, I64, LogData, operational_time, severity_layer
from sim2real.effects.grid import GRID_FIELDS, T0_STEP, apply_change, change_grid
from sim2real.effects.interface import Effect, InEventPhysics, SensorContext

_WEAR = GRID_FIELDS.index("wear_per_k_m3")


@dataclass(frozen=True, eq=False)
class Prediction:
    """Predicted readings of a set of rows (slope integrated out).

    Attributes:
        temp_mean, temp_var: Mean and variance of the temperature reading [deg C, K^2].
        stop_mean, stop_var: Of the true stopping distance (before the floor) [m, m^2].
        stop_reading: Expected floored reading [m].
    """

    temp_mean: F64
    temp_var: F64
    stop_mean: F64
    stop_var: F64
    stop_reading: F64


class ReplayModel:
    """The nominal model, optionally with one effect, replaying the events of one log.

    Args:
        atlas: The nominal atlas.
        data: The prepared log.
        effect: An effect (any kind) added to the nominal model, or None.
        noise: Sensor noise of the nominal model (standard deviations).
        grid: Coarse grid nodes (speed, mass, slope, volume) for an in-event effect's change.
        condition_sample: Rows whose conditions stand for the log's operating mix in the
            wear clock (default: 600 rows evenly spread over the log).

    Attributes:
        v_end: The model's end of life [-] (an in-event effect's own, else the atlas's).
        u: Operational time of each row under this model.
        clock: The wear clock of the log's operating mix, fresh pad to ``v_end``.
    """

    def __init__(
        self,
        atlas: Atlas,
        data: LogData,
        effect: Effect | None = None,
        noise: SensorNoise | None = None,
        grid: tuple[int, int, int, int] = (6, 3, 6, 10),
        condition_sample: I64 | None = None,
    ) -> None:
        self.atlas, self.data, self.effect = atlas, data, effect
        self.noise = noise or SensorNoise()
        self.model = atlas.spec.model
        self.base_t0 = self.model.brake.start_temp_c
        kind = effect.kind if effect is not None and not effect.is_neutral else None
        self.kind = kind
        if kind == "between-events" and data.time_s is None:
            raise ValueError(f"effect {effect!r} needs event times (time_s) in the log")
        self.v_end = atlas.failure_volume
        self._delta: RegularGridInterp | None = None
        self._dt0: RegularGridInterp | None = None
        if kind == "in-event" and effect is not None:
            mod = InEventPhysics([effect], self.model)
            # The effect's own end of life (it may be below the nominal atlas's last layer).
            v_crit = critical_volume(self.model, tol=1e-5, modifier=mod, batch=48)
            self.v_end = end_of_life(v_crit, self.model)
            self._delta = change_grid(
                atlas,
                self.v_end,
                grid,
                lambda sp, m, th, v: simulate_events(sp, m, th, v, self.model, modifier=mod),
            )
        if kind == "between-events":
            brake = dataclasses.replace(self.model.brake, start_temp_c=self.base_t0 + T0_STEP)
            hot = dataclasses.replace(self.model, brake=brake)
            self._dt0 = change_grid(
                atlas, self.v_end, grid, lambda sp, m, th, v: simulate_events(sp, m, th, v, hot)
            )
        self.u, ref_mean = self._operational_time()
        self.clock = self._wear_clock(*self._layer_wear(condition_sample, ref_mean))

    def on(self, data: LogData) -> ReplayModel:
        """This model (effect, change grids, wear clock) answering for another log's events:
        their conditions and, between events, their predecessors and gaps. Only
        :meth:`respond` and :meth:`predict` apply (the operational time stays this log's)."""
        out = copy.copy(self)
        out.data = data
        return out

    # ------------------------------------------------------------------ the pad state
    def _operational_time(self) -> tuple[F64, float]:
        """The log's operational time under this model, and its unit (the log's mean wear at
        the reference volume): an in-event effect that changes wear re-weights each event's
        severity (a wear law in speed, say, makes fast events count for more than the
        nominal model says)."""
        d = self.data
        if self._delta is None:
            return d.u, float(np.nanmean(d.wear_ref))
        ok = np.flatnonzero(d.ok)
        v_ref = float(self.atlas.volumes[severity_layer(self.atlas)])
        pts = np.stack(
            [d.speed_mps[ok], d.mass_kg[ok], d.slope_rad[ok], np.full(ok.size, v_ref)], -1
        )
        w = d.wear_ref.copy()
        w[ok] *= 1.0 + self._delta(pts, [_WEAR])[:, 0]
        return operational_time(w, d.event, d.starts), float(np.nanmean(w))

    def _layer_wear(self, sample: I64 | None, ref_mean: float) -> tuple[F64, F64, F64]:
        """(top, bottom, mean wear per event per unit K) of each layer under this model over
        the log's mix of conditions; layers extend below the atlas's last one down to
        ``v_end`` (``ref_mean``: the unit of the operational time)."""
        d, a = self.data, self.atlas
        if sample is None:  # the log's mix of conditions, a fixed subsample of it
            ok = np.flatnonzero(d.ok)
            sample = ok[np.linspace(0, ok.size - 1, min(ok.size, 600)).astype(np.int64)]
        tops, bottoms, layer = a.volumes, a.lower_edges, np.arange(a.n_layers)
        if self.v_end < a.failure_volume:  # extend below the atlas with its last layer
            ext = np.linspace(a.failure_volume, self.v_end, 9)
            tops, bottoms = np.append(tops, ext[:-1]), np.append(bottoms, ext[1:])
            layer = np.append(layer, np.full(8, a.n_layers - 1))
        s, m, th = (x[sample][None, :] for x in (d.speed_mps, d.mass_kg, d.slope_rad))
        fields = ("wear_per_k_m3",)
        w = a.query(s, m, th, layer=layer[:, None], clip=True, fields=fields)["wear_per_k_m3"]
        pts = np.stack(np.broadcast_arrays(s, m, th, tops[:, None]), -1)  # (layers, rows, 4)
        if self._delta is not None:
            w = w * (1.0 + self._delta(pts, [_WEAR])[..., 0])
        # Control variate: the sample's mean wear at the reference layer against the whole
        # log's (the unit of ``u``); wear at other layers is highly correlated with it, so
        # the ratio removes most of the sample's error from every layer's mean.
        w = w * (ref_mean / np.mean(w[severity_layer(a)]))
        if self._dt0 is not None:
            shift = self._t0_shift_mean(sample)[None, :] / T0_STEP
            w = w * (1.0 + shift * self._dt0(pts, [_WEAR])[..., 0])
        return tops, bottoms, np.maximum(w.mean(axis=1), 1e-30)

    def _wear_clock(self, tops: F64, bottoms: F64, wear: F64) -> WearModel:
        """The clock of the layers down to ``v_end``; a layer the end lies in is cut there
        (its rate continues to the end)."""
        edges = np.append(tops, bottoms[-1])
        n_whole = int(np.count_nonzero(edges >= self.v_end - 1e-12)) - 1  # layers kept whole
        top, bottom, w = tops[:n_whole], bottoms[:n_whole], wear[:n_whole]
        if edges[n_whole] > self.v_end:
            top, bottom = np.append(top, edges[n_whole]), np.append(bottom, self.v_end)
            w = np.append(w, wear[min(n_whole, wear.size - 1)])
        return WearModel.from_layer_wear(top, bottom, w, self.model.brake.pad_volume_m3)

    def _t0_shift_mean(self, rows: I64) -> F64:
        """Start-temperature rise of the sampled events at mid-life (for the wear clock)."""
        v = np.full(rows.size, 0.6 if self.v_end < 0.6 else 0.5 * (1 + self.v_end))
        return self._start_temp(rows, v) - self.base_t0

    def volume_at(self, rows: I64, k: F64) -> F64:
        """Volume of each row's pad at its operational time, for wear coefficients ``k``
        (broadcast against the rows)."""
        return self.clock.volume_at_work(k * self.u[rows])

    # ------------------------------------------------------------------ response
    def _fields(self, s: F64, m: F64, th: F64, v: F64, names: tuple[str, ...]) -> dict[str, F64]:
        a = self.atlas
        vq = np.clip(v, a.failure_volume, 1.0)
        out = a.query(s, m, th, volume_frac=vq, fields=names, clip=True)
        if self._delta is not None:
            v_in = np.broadcast_to(np.asarray(v, dtype=np.float64), s.shape)
            dv = self._delta(np.stack([s, m, th, v_in], -1), [GRID_FIELDS.index(n) for n in names])
            for j, n in enumerate(names):
                out[n] = apply_change(out[n], dv[..., j], n, self.base_t0)
        return out

    def _hot_start(self, s: F64, m: F64, th: F64, v: F64, t0: F64, f: dict[str, F64]) -> None:
        """Change the fields ``f`` in place for events that start at ``t0`` (between-events)."""
        assert self._dt0 is not None
        pts = np.stack([s, m, th, np.clip(v, self.atlas.failure_volume, 1.0)], -1)
        dd = self._dt0(pts, [GRID_FIELDS.index(n) for n in f])
        for j, n in enumerate(f):
            f[n] = apply_change(f[n], dd[..., j] * (t0 - self.base_t0) / T0_STEP, n, self.base_t0)

    def _start_temp(self, rows: I64, v: F64) -> F64:
        """Start temperature of each row under a between-events effect (two lags)."""
        d, e = self.data, self.effect
        assert e is not None
        p1, p2 = d.prev(rows, 1), d.prev(rows, 2)

        def peak(p: I64, t0: F64) -> F64:
            q = np.maximum(p, 0)
            s, m, th = d.speed_mps[q], d.mass_kg[q], d.slope_rad[q]
            s, m, th = (np.where(np.isfinite(x), x, np.nanmean(x)) for x in (s, m, th))
            f = self._fields(s, m, th, v, ("temp_peak_c",))
            self._hot_start(s, m, th, v, t0, f)
            return f["temp_peak_c"]

        t0_prev = np.full(rows.size, self.base_t0)
        has2 = p2 >= 0
        if has2.any():
            pk2 = peak(p2, np.full(rows.size, self.base_t0))
            t0_prev = np.where(
                has2, e.start_temp(pk2, d.gap_s(np.maximum(p1, 0)), self.base_t0), self.base_t0
            )
        pk1 = peak(p1, t0_prev)
        t0 = e.start_temp(pk1, d.gap_s(rows), self.base_t0)
        return np.where(p1 >= 0, t0, self.base_t0)

    def respond(self, rows: I64, v: F64, slope: F64 | None = None) -> dict[str, F64]:
        """True temperature (as the sensor logs it) and stopping distance of ``rows`` at
        volumes ``v`` (broadcast; ``slope`` overrides the logged slope)."""
        d = self.data
        shape = np.broadcast_shapes(
            rows.shape, np.shape(v), np.shape(slope) if slope is not None else ()
        )
        rows_b = np.broadcast_to(rows, shape)
        v_b = np.broadcast_to(v, shape).astype(np.float64)
        s, m = d.speed_mps[rows_b], d.mass_kg[rows_b]
        th = d.slope_rad[rows_b] if slope is None else np.broadcast_to(slope, shape)
        names: tuple[str, ...] = ("temp_mean_c", "stop_dist_m")
        if self.kind in ("sensor", "between-events"):
            names = (*names, "temp_peak_c", "stop_time_s")
        f = self._fields(s, m, th, v_b, names)
        t_start = np.full(shape, self.base_t0)
        if self.kind == "between-events":
            t_start = self._start_temp(rows_b.ravel(), v_b.ravel()).reshape(shape)
            self._hot_start(s, m, th, v_b, t_start, f)
        if self.kind == "sensor" and self.effect is not None:
            ctx = SensorContext(t_start, f["temp_peak_c"], f["stop_time_s"])
            f["temp_mean_c"] = np.asarray(self.effect.measure_temp(f["temp_mean_c"], ctx))
        return f

    # ------------------------------------------------------------------ readings
    def slope_nodes(self, rows: I64, n_slope: int) -> F64:
        """(n_slope, rows) equal-weight nodes of the true slope given the noisy reading (a
        normal truncated to the envelope, flat prior)."""
        th_m = self.data.slope_rad[rows]
        sd = self.noise.slope_rad
        lo, hi = self.atlas.slope_rad[0], self.atlas.slope_rad[-1]
        if sd <= 0 or n_slope <= 1:
            return np.clip(th_m, lo, hi)[None, :]
        a = ndtr((lo - th_m) / sd)
        b = ndtr((hi - th_m) / sd)
        q = (np.arange(n_slope) + 0.5) / n_slope
        p = np.clip(a[None, :] + q[:, None] * (b - a)[None, :], 1e-12, 1 - 1e-12)
        return np.clip(th_m[None, :] + sd * ndtri(p), lo, hi)

    def predict(self, rows: I64, v: F64, n_slope: int = 5) -> Prediction:
        """Predicted readings with the slope reading's noise integrated out."""
        sd = self.noise
        nodes = self.slope_nodes(rows, n_slope)
        f = self.respond(rows[None, :], v[None, :], nodes)
        t, dist = f["temp_mean_c"], f["stop_dist_m"]
        s2 = sd.stop_dist_m**2 + dist.var(axis=0)
        sdv = np.sqrt(np.maximum(s2, 1e-12))
        dm = dist.mean(axis=0)
        z = dm / sdv
        reading = dm * ndtr(z) + sdv * np.exp(-0.5 * z**2) / np.sqrt(2 * np.pi)
        return Prediction(t.mean(axis=0), sd.temp_c**2 + t.var(axis=0), dm, s2, reading)

    def loglik(self, rows: I64, pred: Prediction) -> F64:
        """Per-row log-likelihood of the temperature and stop-distance readings (NaN-safe)."""
        d = self.data
        y_t, y_d = d.temp_c[rows], d.stop_dist_m[rows]
        ll_t = -0.5 * (
            (y_t - pred.temp_mean) ** 2 / pred.temp_var + np.log(2 * np.pi * pred.temp_var)
        )
        sdv = np.sqrt(pred.stop_var)
        zero = y_d <= 0.0
        ll_d = np.where(
            zero,
            np.log(np.maximum(ndtr(-pred.stop_mean / sdv), 1e-300)),
            -0.5
            * ((y_d - pred.stop_mean) ** 2 / pred.stop_var + np.log(2 * np.pi * pred.stop_var)),
        )
        return np.nan_to_num(ll_t, nan=0.0) + np.nan_to_num(ll_d, nan=0.0)
