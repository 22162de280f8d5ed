"""Localise the gap: residuals of a replay, where they lie, and the structured gap.

Every event is replayed through a model at the pad state estimated from the log
(:mod:`sim2real.diagnosis.replay`); residuals per channel are in units of sensor noise, tabulated by
operating region (speed, mass, slope), life stage (share of the run's events) and thermal
history (time since the previous event), with global two-sample tests and a ranked list of
cells.

The structured gap of a channel is the root-mean-square of the mean residual over cells of
(speed x mass x slope x life x thermal history), noise subtracted, in sensor-noise units: 0
for a model that is right everywhere, whatever the sensor noise.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
from scipy import stats

from brake_env.model.atlas import Atlas
from brake_env.model.simulator import SensorNoise
from sim2real.diagnosis.logdata import F64, I64, LogData
from sim2real.diagnosis.replay import Prediction, ReplayModel

CHANNELS = ("temp", "stop")
CHANNEL_NAMES = {"temp": "temperature", "stop": "stopping distance"}  # in reports


class Binning(NamedTuple):
    """One factor's bins: the bin of each log row and the bins' labels."""

    row_bin: I64
    labels: list[str]


@dataclass(frozen=True, eq=False)
class Cells:
    """Cells crossing every factor's bins: the cell of each log row and the cell count."""

    index: I64
    n: int

    @classmethod
    def of(cls, bins: dict[str, Binning]) -> Cells:
        cell = np.zeros_like(next(iter(bins.values())).row_bin)
        n = 1
        for idx, labels in bins.values():
            cell = cell * len(labels) + idx
            n *= len(labels)
        return cls(cell, n)


def _cut(x: F64, edges: F64, fmt: str) -> Binning:
    idx = np.clip(
        np.searchsorted(edges, np.nan_to_num(x, nan=edges[0]), side="right") - 1,
        0,
        edges.size - 2,
    )
    labels = [fmt.format(edges[i], edges[i + 1]) for i in range(edges.size - 1)]
    return Binning(idx.astype(np.int64), labels)


def operating_edges(atlas: Atlas) -> dict[str, F64]:
    """Bin edges of the operating range [SI units]: 4 speed, 2 mass and 3 slope bins over
    the atlas's envelope."""
    return {
        "speed": np.linspace(atlas.speed_mps[0], atlas.speed_mps[-1], 5),
        "mass": np.linspace(atlas.mass_kg[0], atlas.mass_kg[-1], 3),
        "slope": np.linspace(atlas.slope_rad[0], atlas.slope_rad[-1], 4),
    }


def factor_bins(d: LogData, atlas: Atlas) -> dict[str, Binning]:
    """Bins of every factor: speed, mass, slope, life stage and (with event times) the
    time since the previous event (terciles)."""
    n_run = np.diff(d.starts)[d.run]
    pos = (np.arange(d.run.size) - d.starts[d.run]) / np.maximum(n_run, 1)
    edges = operating_edges(atlas)
    speed, mass, slope = edges["speed"] * 3.6, edges["mass"] / 1000, np.degrees(edges["slope"])
    out = {
        "speed": _cut(d.speed_mps * 3.6, speed, "{:.1f}-{:.1f} km/h"),
        "mass": _cut(d.mass_kg / 1000, mass, "{:.0f}-{:.0f} t"),
        "slope": _cut(np.degrees(d.slope_rad), slope, "{:.1f}-{:.1f} deg"),
        "life": _cut(pos, np.linspace(0, 1, 5), "{:.0%}-{:.0%} of run"),
    }
    if d.time_s is not None:
        gap = d.gap_s(np.arange(d.run.size))
        finite = gap[np.isfinite(gap)]
        q = np.quantile(finite, [1 / 3, 2 / 3]) if finite.size else np.array([1.0, 2.0])
        out["thermal"] = _cut(
            np.where(np.isfinite(gap), gap, np.inf),
            np.array([0.0, *q, np.inf]),
            "gap {:.0f}-{:.0f} s",
        )
    return out


@dataclass(frozen=True, eq=False)
class Residuals:
    """Standardised residuals of a model on a set of rows (NaN where a reading is missing)."""

    rows: I64
    temp: F64
    stop: F64
    loglik: F64
    pred: Prediction

    def channel(self, ch: str) -> F64:
        return self.temp if ch == "temp" else self.stop


def residuals(rm: ReplayModel, rows: I64, k: F64, nodes: int) -> Residuals:
    """Residuals of ``rows`` with each run's pad at wear coefficient ``k[run]``."""
    d = rm.data
    p = rm.predict(rows, rm.volume_at(rows, k[d.run[rows]]), nodes)
    t = (d.temp_c[rows] - p.temp_mean) / rm.noise.temp_c
    s = (d.stop_dist_m[rows] - p.stop_reading) / rm.noise.stop_dist_m
    return Residuals(rows, t, s, rm.loglik(rows, p), p)


def _run_cell_stats(res: Residuals, run: I64, cell: I64, n_runs: int, n_cells: int, ch: str) -> F64:
    """(runs, cells, 3): count, sum and sum of squares of one channel's residuals."""
    x = res.channel(ch)
    ok = np.isfinite(x)
    idx = run[ok] * n_cells + cell[ok]
    out = np.zeros((3, n_runs * n_cells))
    for i, w in enumerate((np.ones(ok.sum()), x[ok], x[ok] ** 2)):
        out[i] = np.bincount(idx, weights=w, minlength=n_runs * n_cells)
    return out.reshape(3, n_runs, n_cells).transpose(1, 2, 0)


def _gap_from_stats(st: F64) -> F64:
    """Structured gap from cell stats (..., cells, 3), noise-corrected, in noise units."""
    n, s1, s2 = st[..., 0], st[..., 1], st[..., 2]
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(n > 1, s1 / np.maximum(n, 1), 0.0)
        var = np.where(n > 1, (s2 - n * mean**2) / np.maximum(n - 1, 1), 0.0)
        excess = n * mean**2 - var  # n (m^2 - s^2/n): unbiased for n mu^2
    tot = np.maximum(n.sum(axis=-1), 1)
    return np.sqrt(np.maximum(np.where(n > 1, excess, 0.0).sum(axis=-1) / tot, 0.0))


def gap_summary(
    res: Residuals, d: LogData, cells: Cells, runs: I64, level: float
) -> dict[str, dict[str, Any]]:
    """Per channel: structured gap and residual RMS [noise units] (jackknife over runs).

    Intervals are normal ones from the leave-one-run-out jackknife (a bootstrap over runs
    duplicates runs, which biases the noise-corrected gap upwards).
    """
    run = d.run[res.rows]
    out = {}
    n = len(runs)
    loo = 1.0 - np.eye(n)  # leave one run out
    z = float(stats.norm.ppf(0.5 + level / 2))

    def interval(x: float, jack: F64, lo: float = 0.0) -> list[float]:
        if n < 2:
            return [float("nan"), float("nan")]
        se = float(np.sqrt((n - 1) / n * np.sum((jack - jack.mean()) ** 2)))
        return [max(lo, x - z * se), x + z * se]

    for ch in CHANNELS:
        st = _run_cell_stats(res, run, cells.index[res.rows], d.n_runs, cells.n, ch)[runs]
        g = float(_gap_from_stats(st.sum(axis=0)))
        gj = _gap_from_stats(np.einsum("br,rcs->bcs", loo, st))
        tot = st.sum(axis=(0, 1))
        rms = float(np.sqrt(tot[2] / max(tot[0], 1)))
        tj = np.einsum("br,rs->bs", loo, st.sum(axis=1))
        rmsj = np.sqrt(tj[:, 2] / np.maximum(tj[:, 0], 1))
        out[ch] = {
            "structured_gap": g,
            "structured_gap_ci": interval(g, gj),
            "rms": rms,
            "rms_ci": interval(rms, rmsj),
            "mean": float(tot[1] / max(tot[0], 1)),
        }
    return out


def two_sample(
    res: Residuals, d: LogData, noise: SensorNoise, rng: np.random.Generator
) -> dict[str, Any]:
    """Real readings against readings simulated from the model (same rows): KS and mean z."""
    p = res.pred
    sim_t = p.temp_mean + rng.normal(0, 1, p.temp_mean.size) * np.sqrt(p.temp_var)
    sim_d = np.maximum(p.stop_mean + rng.normal(0, 1, p.stop_mean.size) * np.sqrt(p.stop_var), 0)
    out: dict[str, Any] = {}
    for ch, real, sim in (
        ("temp", d.temp_c[res.rows], sim_t),
        ("stop", d.stop_dist_m[res.rows], sim_d),
    ):
        ok = np.isfinite(real)
        ks = stats.ks_2samp(real[ok], sim[ok])
        r = res.channel(ch)[ok]
        z = float(r.mean() / (r.std(ddof=1) / np.sqrt(r.size))) if r.size > 1 else 0.0
        out[ch] = {
            "ks_stat": float(ks.statistic),
            "ks_p": float(ks.pvalue),
            "mean_z": z,
            "n": int(ok.sum()),
        }
    return out


def _bin_stats(x: F64) -> dict[str, Any]:
    """Count, mean, standard error and z of the finite residuals ``x``."""
    x = x[np.isfinite(x)]
    n = int(x.size)
    m = float(x.mean()) if n else float("nan")
    se = float(x.std(ddof=1) / np.sqrt(n)) if n > 1 else float("nan")
    return {"n": n, "mean": m, "se": se, "z": m / se if n > 1 and se > 0 else 0.0}


def localise(res: Residuals, bins: dict[str, Binning], top: int = 12) -> dict[str, Any]:
    """Marginal residual tables per factor and channel, and the ranked list of cells."""
    tables: dict[str, Any] = {}
    ranked = []
    for fac, (idx, labels) in bins.items():
        b = idx[res.rows]
        rows = []
        for i, lab in enumerate(labels):
            row: dict[str, Any] = {"bin": lab}
            for ch in CHANNELS:
                row[ch] = st = _bin_stats(res.channel(ch)[(b == i)])
                if st["n"] > 1:
                    ranked.append(
                        {
                            "channel": ch,
                            "factor": fac,
                            "bin": lab,
                            "effect_size": st["mean"],
                            "z": st["z"],
                            "n": st["n"],
                        }
                    )
            rows.append(row)
        tables[fac] = rows
    ranked.sort(key=lambda r: (abs(r["z"]) < 3.0, -abs(r["effect_size"])))
    return {"tables": tables, "ranked": ranked[:top]}
