"""Sim-to-real gap diagnosis: localise, attribute, quantify (DESIGN 7, issue 6).

Works on any event log in the schema of DESIGN 4 (ground-truth columns are never used,
except the optional ``rul_events`` to score the twin's RUL in "quantify").

1. localise: every event is replayed through the nominal model at the pad state estimated
   from the log (``sim2real.replay``); residuals per channel, in units of sensor noise, by
   operating region (speed, mass, slope), life stage (share of the run's events) and thermal
   history (time since the previous event); global two-sample tests; a ranked list of cells.
2. attribute: runs are split into calibration and held-out runs (never events). Each
   candidate's fitted parameter is chosen on calibration runs (grid plus a parabola); its
   held-out log-likelihood gain over the nominal model, a paired z against the nominal model
   and the runner-up, and the BIC decide. A candidate is named only if it clearly wins *and*
   closes the structured gap on held-out runs; otherwise the answer is "none of the
   candidates" with what remains.
3. quantify: held-out gap before and after adding the winner, (jackknife over runs).

The structured gap of a channel is the root-mean-square of the mean residual over cells of
(speed x mass x slope x life x thermal history), noise subtracted, in sensor-noise units: 0
for a model that is right everywhere, whatever the sensor noise.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray
from scipy import stats

from brake_env.model.atlas import Atlas
from brake_env.model.simulator import SensorNoise
from sim2real.effects import LIBRARY, Effect
from sim2real.replay import F64, I64, LogData, Prediction, ReplayModel, prepare_log

CHANNELS = ("temp", "stop")
NONE = "none of the candidates"


@dataclass(frozen=True)
class DiagnosisConfig:
    """Settings of the diagnosis.

    Attributes:
        noise: Sensor noise of the nominal model (residuals are in these units).
        calibration_fraction: Share of runs used to fit candidate parameters [-].
        fit_events_per_run: Events per run used to fit a pad's K [-].
        calibration_events_per_run: Events per calibration run scoring a parameter value [-].
        score_events_per_run: Events per held-out run scoring a model (and the gap) [-].
        max_localise_events: Cap on events replayed for the localisation maps [-].
        grid_points: Parameter values tried per candidate (plus the neutral one) [-].
        slope_nodes: Quadrature nodes over the slope reading's noise [-].
        gap_tolerance: Structured gap [noise units] below which a channel has no gap.
        win_z: Paired z a winner needs against the nominal model and the runner-up [-].
        close_fraction: Share of the structured gap the winner must remove [-].
        level: Interval level [-].
    """

    noise: SensorNoise = field(default_factory=SensorNoise)
    calibration_fraction: float = 0.5
    fit_events_per_run: int = 2000
    calibration_events_per_run: int = 3000
    score_events_per_run: int = 25_000
    max_localise_events: int = 300_000
    grid_points: int = 5
    slope_nodes: int = 5
    gap_tolerance: float = 0.08
    win_z: float = 3.0
    close_fraction: float = 0.5
    level: float = 0.9

    def __post_init__(self) -> None:
        if not 0.1 <= self.calibration_fraction <= 0.9:
            raise ValueError("DiagnosisConfig.calibration_fraction must be in [0.1, 0.9]")
        for name in ("fit_events_per_run", "score_events_per_run", "grid_points", "slope_nodes"):
            if int(getattr(self, name)) < 1:
                raise ValueError(f"DiagnosisConfig.{name} must be >= 1")
        if self.noise.temp_c <= 0 or self.noise.stop_dist_m <= 0:
            raise ValueError("DiagnosisConfig.noise: temperature and distance noise must be > 0")


# ---------------------------------------------------------------------- binning
def _bins(d: LogData, atlas: Atlas) -> dict[str, tuple[I64, list[str]]]:
    """Factor -> (bin index per row, bin labels)."""
    n_run = np.diff(d.starts)[d.run]
    pos = (np.arange(d.run.size) - d.starts[d.run]) / np.maximum(n_run, 1)

    def cut(x: F64, edges: F64, fmt: str) -> tuple[I64, list[str]]:
        idx = np.clip(
            np.searchsorted(edges, np.nan_to_num(x, nan=edges[0]), side="right") - 1,
            0,
            edges.size - 2,
        )
        labels = [fmt.format(edges[i], edges[i + 1]) for i in range(edges.size - 1)]
        return idx.astype(np.int64), labels

    out = {
        "speed": cut(
            d.speed_mps * 3.6,
            np.linspace(atlas.speed_mps[0], atlas.speed_mps[-1], 5) * 3.6,
            "{:.1f}-{:.1f} km/h",
        ),
        "mass": cut(
            d.mass_kg / 1000,
            np.linspace(atlas.mass_kg[0], atlas.mass_kg[-1], 3) / 1000,
            "{:.0f}-{:.0f} t",
        ),
        "slope": cut(
            np.degrees(d.slope_rad),
            np.degrees(np.linspace(atlas.slope_rad[0], atlas.slope_rad[-1], 4)),
            "{:.1f}-{:.1f} deg",
        ),
        "life": cut(pos, np.linspace(0, 1, 5), "{:.0%}-{:.0%} of run"),
    }
    if d.time_s is not None:
        gap = d.gap_s(np.arange(d.run.size))
        finite = gap[np.isfinite(gap)]
        q = np.quantile(finite, [1 / 3, 2 / 3]) if finite.size else np.array([1.0, 2.0])
        out["thermal"] = cut(
            np.where(np.isfinite(gap), gap, np.inf),
            np.array([0.0, *q, np.inf]),
            "gap {:.0f}-{:.0f} s",
        )
    return out


def _cells(bins: dict[str, tuple[I64, list[str]]]) -> tuple[I64, int]:
    cell = np.zeros_like(next(iter(bins.values()))[0])
    n = 1
    for idx, labels in bins.values():
        cell = cell * len(labels) + idx
        n *= len(labels)
    return cell, n


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
    d = rm.data
    v = rm.volume(rm.u[rows], k[d.run[rows]])
    p = rm.predict(rows, v, nodes)
    t = (d.temp_c[rows] - p.temp_mean) / rm.noise.temp_c
    s = (d.stop_dist_m[rows] - p.stop_reading) / rm.noise.stop_dist_m
    return Residuals(rows, t, s, rm.loglik(rows, p), p)


def _run_cell_stats(
    res: Residuals, run: I64, cell: I64, n_runs: int, n_cells: int, ch: str
) -> NDArray[np.float64]:
    """(runs, cells, 3): count, sum and sum of squares of one channel's residuals."""
    x = res.channel(ch)
    ok = np.isfinite(x)
    idx = run[ok] * n_cells + cell[ok]
    out = np.zeros((3, n_runs * n_cells))
    for i, w in enumerate((np.ones(ok.sum()), x[ok], x[ok] ** 2)):
        out[i] = np.bincount(idx, weights=w, minlength=n_runs * n_cells)
    return out.reshape(3, n_runs, n_cells).transpose(1, 2, 0)


def _gap_from_stats(st: NDArray[np.float64]) -> F64:
    """Structured gap from cell stats (..., cells, 3), noise-corrected, in noise units."""
    n, s1, s2 = st[..., 0], st[..., 1], st[..., 2]
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(n > 1, s1 / np.maximum(n, 1), 0.0)
        var = np.where(n > 1, (s2 - n * mean**2) / np.maximum(n - 1, 1), 0.0)
        excess = n * mean**2 - var  # n (m^2 - s^2/n): unbiased for n mu^2
    tot = np.maximum(n.sum(axis=-1), 1)
    return np.sqrt(np.maximum(np.where(n > 1, excess, 0.0).sum(axis=-1) / tot, 0.0))


def gap_summary(
    res: Residuals,
    d: LogData,
    cell: I64,
    n_cells: int,
    runs: I64,
    level: float,
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
        st = _run_cell_stats(res, run, cell[res.rows], d.n_runs, n_cells, ch)[runs]
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


def _two_sample(
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


def localise(
    res: Residuals, d: LogData, bins: dict[str, tuple[I64, list[str]]], top: int = 12
) -> dict[str, Any]:
    """Marginal residual tables per factor and channel, and the ranked list of cells."""
    tables: dict[str, Any] = {}
    ranked = []
    for fac, (idx, labels) in bins.items():
        b = idx[res.rows]
        rows = []
        for i, lab in enumerate(labels):
            row: dict[str, Any] = {"bin": lab}
            for ch in CHANNELS:
                x = res.channel(ch)[(b == i)]
                x = x[np.isfinite(x)]
                n = int(x.size)
                m = float(x.mean()) if n else float("nan")
                se = float(x.std(ddof=1) / np.sqrt(n)) if n > 1 else float("nan")
                row[ch] = {"n": n, "mean": m, "se": se, "z": m / se if n > 1 and se > 0 else 0.0}
                if n > 1:
                    ranked.append(
                        {
                            "channel": ch,
                            "factor": fac,
                            "bin": lab,
                            "effect_size": m,
                            "z": row[ch]["z"],
                            "n": n,
                        }
                    )
            rows.append(row)
        tables[fac] = rows
    ranked.sort(key=lambda r: (abs(r["z"]) < 3.0, -abs(r["effect_size"])))
    return {"tables": tables, "ranked": ranked[:top]}


# ---------------------------------------------------------------------- attribution
@dataclass
class _Scored:
    name: str
    effect: Effect | None
    model: ReplayModel
    k: F64
    cal_ll: float
    grid: list[dict[str, float]] = field(default_factory=list)
    held: Residuals | None = None


def _sample_rows(d: LogData, n_per_run: int, rng: np.random.Generator) -> list[I64]:
    out = []
    for r in range(d.n_runs):
        ok = np.flatnonzero(d.ok[d.starts[r] : d.starts[r + 1]]) + d.starts[r]
        n = min(n_per_run, ok.size)
        out.append(np.sort(rng.choice(ok, n, replace=False)) if n else ok)
    return out


def parameter_grid(neutral: float, lo: float, hi: float, n: int) -> list[float]:
    """Neutral value plus ``n`` values per side, halving the distance towards neutral."""
    frac = 0.5 ** np.arange(n)[::-1]
    vals = {neutral}
    for end in (lo, hi):
        if end != neutral:
            vals.update((neutral + (end - neutral) * frac).tolist())
    return sorted(vals)


def _fit_candidate(
    cls: type[Effect],
    atlas: Atlas,
    d: LogData,
    cfg: DiagnosisConfig,
    fit_rows: list[I64],
    cal_runs: I64,
    cal_rows: I64,
    progress: Callable[[str], object] | None,
    nominal: tuple[ReplayModel, F64, float] | None = None,
) -> _Scored:
    """Grid (and a parabola) over the candidate's first fitted parameter, on calibration runs."""
    params = cls.fitted_params()
    if not params:
        raise ValueError(f"candidate {cls.name!r} has no fitted parameter")
    p = params[0]
    values = parameter_grid(p.neutral, p.lo, p.hi, cfg.grid_points)
    best: _Scored | None = None
    grid = []

    def score(v: float) -> _Scored:
        if v == p.neutral and nominal is not None:
            return _Scored(cls.name, cls(), nominal[0], nominal[1], nominal[2])
        eff = cls(**{p.name: v})
        rm = ReplayModel(atlas, d, eff, cfg.noise)
        k = rm.fit_k(fit_rows, cal_runs)
        ll = float(np.sum(residuals(rm, cal_rows, k, cfg.slope_nodes).loglik))
        return _Scored(cls.name, eff, rm, k, ll)

    scored = []
    for v in values:
        s = score(v)
        scored.append((v, s))
        grid.append({"value": v, "cal_loglik": s.cal_ll})
        if progress:
            progress(f"{cls.name}:{p.name}={v:.3g}")
    lls = np.array([s.cal_ll for _, s in scored])
    i = int(np.argmax(lls))
    best = scored[i][1]
    if 0 < i < len(scored) - 1:  # parabola through the best value and its neighbours
        x = np.array([scored[j][0] for j in (i - 1, i, i + 1)])
        y = lls[i - 1 : i + 2]
        c = np.polyfit(x, y, 2)
        if c[0] < 0:
            v_ref = float(np.clip(-c[1] / (2 * c[0]), x[0], x[2]))
            if p.lo <= v_ref <= p.hi and v_ref not in x:
                s = score(v_ref)
                grid.append({"value": v_ref, "cal_loglik": s.cal_ll})
                if s.cal_ll > best.cal_ll:
                    best = s
    best.grid = sorted(grid, key=lambda g: g["value"])
    return best


@dataclass(frozen=True, eq=False)
class DiagnosisResult:
    """What ``diagnose`` found; ``summary`` is what goes to ``diagnosis.json``."""

    summary: dict[str, Any]
    data: LogData
    nominal: Residuals
    held_before: Residuals
    held_after: Residuals | None
    bins: dict[str, tuple[I64, list[str]]]
    held_runs: I64
    winner: Effect | None

    @property
    def verdict(self) -> str:
        return str(self.summary["attribution"]["verdict"])


def diagnose(
    log: pd.DataFrame,
    atlas: Atlas,
    candidates: Sequence[type[Effect]] | None = None,
    config: DiagnosisConfig | None = None,
    seed: int = 0,
    progress: Callable[[str], object] | None = None,
    rul: Callable[..., dict[str, Any] | None] | None = None,
) -> DiagnosisResult:
    """Localise, attribute and quantify the gap between a log and the nominal model.

    Args:
        log: A validated event log (``brake_env.data.schema.read_event_log``), two runs or more.
        atlas: The nominal model's atlas.
        candidates: Effect classes to try (default: the library).
        config: Settings.
        seed: Seeds the run split, the event subsamples and the simulated readings.
        progress: Called with a short text per fitted model.
        rul: Optional callback for the twin's RUL error without and with the winning
            effect: ``(effect or None, held-out log, offset, calibration log, offset) ->
            {"rmse": ..., ...}`` (``sim2real.rul.rul_scorer``).
    """
    cfg = config or DiagnosisConfig()
    cands = list(LIBRARY if candidates is None else candidates)
    rng = np.random.default_rng(seed)
    d = prepare_log(log, atlas)
    if d.n_runs < 2:
        raise ValueError(
            f"the log has {d.n_runs} run; the diagnosis splits runs into calibration and"
            " held-out runs and needs at least 2"
        )
    perm = rng.permutation(d.n_runs)
    n_cal = int(np.clip(round(cfg.calibration_fraction * d.n_runs), 1, d.n_runs - 1))
    cal_runs, held_runs = np.sort(perm[:n_cal]), np.sort(perm[n_cal:])
    fit_rows = _sample_rows(d, cfg.fit_events_per_run, rng)
    cal_sample = _sample_rows(d, cfg.calibration_events_per_run, rng)
    held_sample = _sample_rows(d, cfg.score_events_per_run, rng)
    cal_rows = np.concatenate([cal_sample[r] for r in cal_runs])
    held_rows = np.concatenate([held_sample[r] for r in held_runs])
    bins = _bins(d, atlas)
    cell, n_cells = _cells(bins)

    # 1. localise (all runs, the nominal model)
    nominal = ReplayModel(atlas, d, None, cfg.noise)
    k0 = nominal.fit_k(fit_rows)
    ok = np.flatnonzero(d.ok)
    loc_rows = (
        ok
        if ok.size <= cfg.max_localise_events
        else np.sort(rng.choice(ok, cfg.max_localise_events, replace=False))
    )
    res0 = residuals(nominal, loc_rows, k0, cfg.slope_nodes)
    all_runs = np.arange(d.n_runs)
    local = localise(res0, d, bins)
    local["gap"] = gap_summary(res0, d, cell, n_cells, all_runs, cfg.level)
    local["two_sample"] = _two_sample(res0, d, cfg.noise, rng)
    if progress:
        progress("nominal")

    # 2. attribute
    nom_cal = float(np.sum(residuals(nominal, cal_rows, k0, cfg.slope_nodes).loglik))
    held0 = residuals(nominal, held_rows, k0, cfg.slope_nodes)
    gap0 = gap_summary(held0, d, cell, n_cells, held_runs, cfg.level)
    scored: list[_Scored] = []
    skipped = {}
    for cls in cands:
        if cls.kind == "between-events" and d.time_s is None:
            skipped[cls.name] = "needs event times (time_s), which the log does not have"
            continue
        s = _fit_candidate(
            cls, atlas, d, cfg, fit_rows, cal_runs, cal_rows, progress, (nominal, k0, nom_cal)
        )
        k_held = s.model.fit_k(fit_rows, held_runs)  # the pad states of the held-out runs
        s.k = np.where(np.isnan(s.k), k_held, s.k)
        s.held = residuals(s.model, held_rows, s.k, cfg.slope_nodes)
        scored.append(s)
    n_cal_ev = cal_rows.size
    rows_out = []
    for s in scored:
        assert s.held is not None
        diff = s.held.loglik - held0.loglik
        z = float(diff.mean() / (diff.std(ddof=1) / np.sqrt(diff.size) + 1e-300))
        g = gap_summary(s.held, d, cell, n_cells, held_runs, cfg.level)
        n_par = len(type(s.effect).fitted_params()) if s.effect else 0
        rows_out.append(
            {
                "name": s.name,
                "kind": type(s.effect).kind if s.effect else "",
                "effect": s.effect.key if s.effect else "",
                "params": dict(s.effect.values) if s.effect else {},
                "cal_loglik_gain": s.cal_ll - nom_cal,
                "bic_gain": 2 * (s.cal_ll - nom_cal) - n_par * np.log(n_cal_ev),
                "held_loglik_gain": float(diff.sum()),
                "held_loglik_gain_per_event": float(diff.mean()),
                "held_z_vs_nominal": z,
                "gap_after": {ch: g[ch]["structured_gap"] for ch in CHANNELS},
                "grid": s.grid,
            }
        )
    order = np.argsort([-r["held_loglik_gain"] for r in rows_out])
    rows_out = [rows_out[i] for i in order]
    scored = [scored[i] for i in order]
    verdict, reason, winner = _decide(rows_out, scored, held0, gap0, cfg)

    # 3. quantify
    held_after = None
    quantify: dict[str, Any] = {"before": gap0}
    if winner is not None:
        w = scored[0]
        held_after = w.held
        assert held_after is not None
        quantify["after"] = gap_summary(held_after, d, cell, n_cells, held_runs, cfg.level)
        quantify["shrink"] = {
            ch: 1.0
            - quantify["after"][ch]["structured_gap"] / max(gap0[ch]["structured_gap"], 1e-12)
            for ch in CHANNELS
        }
        quantify["two_sample_before"] = _two_sample(held0, d, cfg.noise, rng)
        quantify["two_sample_after"] = _two_sample(held_after, d, cfg.noise, rng)
    quantify["channel"] = max(CHANNELS, key=lambda c: gap0[c]["structured_gap"])
    if rul is not None:

        def part(runs: I64) -> tuple[I64, pd.DataFrame]:
            rows = np.concatenate([np.arange(d.starts[r], d.starts[r + 1]) for r in runs])
            return rows, d.frame.iloc[rows].reset_index(drop=True)

        rows_h, held_log = part(held_runs)
        rows_c, cal_log = part(cal_runs)
        quantify["rul"] = {"before": rul(None, held_log, None, cal_log, None)}
        if winner is not None:
            w0 = scored[0]  # its K covers calibration and held-out runs
            quantify["rul"]["after"] = rul(
                winner,
                held_log,
                _offset(w0, nominal, rows_h),
                cal_log,
                _offset(w0, nominal, rows_c),
            )

    summary = {
        "log": {
            "runs": d.n_runs,
            "events": int(d.run.size),
            "replayable": int(d.ok.sum()),
            "has_time": d.time_s is not None,
            "calibration_runs": [d.run_ids[r] for r in cal_runs],
            "held_out_runs": [d.run_ids[r] for r in held_runs],
        },
        "noise": {
            "temp_c": cfg.noise.temp_c,
            "stop_dist_m": cfg.noise.stop_dist_m,
            "slope_rad": cfg.noise.slope_rad,
        },
        "localise": local,
        "attribution": {
            "verdict": verdict,
            "reason": reason,
            "winner": winner.key if winner else None,
            "candidates": rows_out,
            "skipped": skipped,
            "nominal_held_loglik_per_event": float(held0.loglik.mean()),
        },
        "quantify": quantify,
    }
    return DiagnosisResult(summary, d, res0, held0, held_after, bins, held_runs, winner)


def _offset(s: _Scored, nominal: ReplayModel, rows: I64) -> F64 | None:
    """Per row, the winner's modelled change of the temperature reading (sensor and
    between-events effects); None for in-event effects."""
    rm, d = s.model, s.model.data
    ok = d.ok[rows]
    out = np.zeros(rows.size)
    r = rows[ok]
    v = rm.volume(rm.u[r], s.k[d.run[r]])
    if rm.kind in ("sensor", "between-events"):
        out[ok] = rm.respond(r, v)["temp_mean_c"] - nominal.respond(r, v)["temp_mean_c"]
    else:
        return None
    return out


def _decide(
    rows: list[dict[str, Any]],
    scored: list[_Scored],
    held0: Residuals,
    gap0: dict[str, dict[str, float]],
    cfg: DiagnosisConfig,
) -> tuple[str, str, Effect | None]:
    """Name the best candidate only if it clearly wins and closes the gap."""
    worst = max(gap0[c]["structured_gap"] for c in CHANNELS)
    if not rows:
        return NONE, "no candidate could be tried on this log", None
    best = rows[0]
    if worst < cfg.gap_tolerance:
        return (
            NONE,
            (
                f"no gap: the structured gap {worst:.3f} noise units is below the"
                f" tolerance {cfg.gap_tolerance} (best candidate {best['name']},"
                f" z {best['held_z_vs_nominal']:.1f})"
            ),
            None,
        )
    if best["held_z_vs_nominal"] < cfg.win_z:
        return (
            NONE,
            (
                f"a gap of {worst:.3f} noise units remains and no candidate improves the"
                f" held-out fit significantly (best {best['name']}, z"
                f" {best['held_z_vs_nominal']:.1f})"
            ),
            None,
        )
    if len(rows) > 1:
        a, b = scored[0].held, scored[1].held
        assert a is not None and b is not None
        diff = a.loglik - b.loglik
        z2 = float(diff.mean() / (diff.std(ddof=1) / np.sqrt(diff.size) + 1e-300))
        best["held_z_vs_runner_up"] = z2
        if z2 < cfg.win_z:
            return (
                NONE,
                (
                    f"{best['name']} and {rows[1]['name']} explain the gap about equally"
                    f" well (paired z {z2:.1f} < {cfg.win_z})"
                ),
                None,
            )
    remains = {c: best["gap_after"][c] for c in CHANNELS}
    unclosed = [
        c
        for c in CHANNELS
        if remains[c] > max(cfg.gap_tolerance, (1 - cfg.close_fraction) * gap0[c]["structured_gap"])
    ]
    if unclosed:
        return (
            NONE,
            (
                "best candidate "
                + best["name"]
                + " does not close the gap: "
                + ", ".join(
                    f"{c} {gap0[c]['structured_gap']:.3f} -> {remains[c]:.3f}" for c in unclosed
                )
                + " noise units remain"
            ),
            None,
        )
    return (
        best["name"],
        (
            f"{best['effect']} wins on held-out runs (z {best['held_z_vs_nominal']:.1f}"
            f" vs nominal) and closes the gap"
        ),
        scored[0].effect,
    )
