"""Which data would tell two tied candidates apart (issue 40 item 5; docs/results/sim2real.md).

When the attribution abstains because its two best candidates explain the held-out runs
about equally well (their paired z below ``win_z``), this says what would separate them,
with the numbers. Each is a power calculation: the data that make the expected paired z
``win_z + 0.84``, so that it exceeds ``win_z`` with 80% probability:

- **more runs of the same kind:** the paired z grows as the square root of the held-out
  events; the per-run mean differences and their spread give the runs needed, with a range;
- **an operating range:** both fitted models predict events in every speed x mass x slope
  cell of the envelope, logged or not, at the log's pad states (a cell's events preceded by
  two like them at the log's median gap, for a between-events effect). Their difference in
  noise units ``s`` gives the expected log-likelihood gain of the true model per event
  (``s^2 / 2``, variance ``s^2`` for normal readings), hence how many events in that cell,
  added to the held-out ones, bring the paired z there;
- **a channel:** the same per channel, with the share of its readings the log holds.

It is a first-order power calculation: each model keeps its fitted parameter and its pads'
K, which the new data would refit. Only held-out runs score (a share ``held/runs`` of any
new events), each capped at ``score_events_per_run`` sampled events.
``benchmarks/analysis/separability.py`` checks it on simulated logs.
"""

from __future__ import annotations

from itertools import product
from typing import Any

import numpy as np
import pandas as pd
from scipy import stats

from sim2real.diagnosis.attribute import Calibration, Scored
from sim2real.diagnosis.localise import CHANNEL_NAMES, CHANNELS, operating_edges
from sim2real.diagnosis.logdata import F64, I64, LogData
from sim2real.diagnosis.replay import Prediction

LIFE_QUANTILES = (0.1, 0.3, 0.5, 0.7, 0.9)  # pad states at which a cell is predicted
CELL_POINTS = ((1 / 6, 1 / 2, 5 / 6), (1 / 4, 3 / 4), (1 / 6, 1 / 2, 5 / 6))  # within a cell
POWER = 0.8  # the chance the recommended data brings the paired z over win_z
METHOD = (
    "power calculation (80%): the expected paired z of the held-out log-likelihood"
    " difference reaches win_z + 0.84; more runs scale it with the square root of the runs,"
    " a cell adds s^2/2 per event (variance s^2), s the two fitted models' predicted"
    " difference in noise units"
)


def target_z(win_z: float) -> float:
    """The expected paired z at which it exceeds ``win_z`` with probability :data:`POWER`."""
    return float(win_z + stats.norm.ppf(POWER))


def separation(s2: dict[str, F64]) -> F64:
    """Per event, the squared separation over the channels, ``sum_ch s_ch^2``."""
    return np.asarray(sum(np.nan_to_num(v) for v in s2.values()), dtype=np.float64)


def channel_s2(a: Prediction, b: Prediction) -> dict[str, F64]:
    """Per channel and event, the squared difference of two predictions in units of their
    mean predictive spread (sensor noise plus the slope reading's)."""
    return {
        "temp": (a.temp_mean - b.temp_mean) ** 2 / (0.5 * (a.temp_var + b.temp_var)),
        "stop": (a.stop_mean - b.stop_mean) ** 2 / (0.5 * (a.stop_var + b.stop_var)),
    }


def events_to_add(s_sum: float, v_sum: float, s2: float, z: float) -> float:
    """Scored events of mean squared separation ``s2`` that, added to held-out events whose
    log-likelihood differences sum to ``s_sum`` with variance sum ``v_sum``, bring the paired
    z ``(s_sum + m s2/2) / sqrt(v_sum + m s2)`` to ``z`` (inf if ``s2`` is 0)."""
    if s_sum >= z * np.sqrt(v_sum):
        return 0.0
    if s2 <= 0:
        return float("inf")
    mu = s2 / 2
    qa, qb, qc = mu**2, 2 * s_sum * mu - z**2 * s2, s_sum**2 - z**2 * v_sum
    disc = qb**2 - 4 * qa * qc
    root = (-qb + np.sqrt(disc)) / (2 * qa) if disc >= 0 else 0.0
    return float(max(root, -s_sum / mu if s_sum < 0 else 0.0, 0.0))


def runs_needed(z_now: float, held: int, runs: int, z_target: float, cal_fraction: float) -> float:
    """Runs in all for an expected paired z of ``z_target``, if z grows as the square root
    of the held-out runs (``held`` of ``runs`` now; inf if ``z_now`` <= 0)."""
    if z_now >= z_target:
        return float(runs)
    if z_now <= 0:
        return float("inf")
    need = held * (z_target / z_now) ** 2
    n = runs
    while n - int(np.clip(round(cal_fraction * n), 1, n - 1)) < need:
        n += 1
    return float(n)


def _run_power(ctx: Calibration, d_ll: F64, rows: I64, z_now: float) -> dict[str, Any]:
    """More runs like these: the runs needed, and a range from the per-run differences."""
    d, cfg, held = ctx.data, ctx.cfg, ctx.split.held_runs
    run = np.searchsorted(held, d.run[rows])
    per_run = np.bincount(run, weights=d_ll, minlength=held.size) / np.maximum(
        np.bincount(run, minlength=held.size), 1
    )
    z_t = target_z(cfg.win_z)
    n = runs_needed(z_now, held.size, d.n_runs, z_t, cfg.calibration_fraction)
    out: dict[str, Any] = {
        "runs_now": d.n_runs,
        "runs_needed": n,
        "more_runs": n - d.n_runs,
        "held_runs": int(held.size),
        "mean_difference_per_run": per_run.tolist(),
        "runs_needed_interval": None,
    }
    if held.size >= 3 and per_run.mean() > 0:  # the spread over runs bounds the mean
        se = per_run.std(ddof=1) / np.sqrt(held.size)
        t = float(stats.t.ppf(0.5 + cfg.level / 2, held.size - 1))
        lo_hi = [per_run.mean() + t * se, per_run.mean() - t * se]
        z_lh = [z_now * m / per_run.mean() for m in lo_hi]
        frac = cfg.calibration_fraction
        out["runs_needed_interval"] = [runs_needed(z, held.size, d.n_runs, z_t, frac) for z in z_lh]
    return out


def _cells(ctx: Calibration) -> tuple[list[dict[str, Any]], F64]:
    """The operating-range cells (labels, bounds) and the conditions predicted in each:
    (cells * points, 3) speed, mass, slope."""
    e = operating_edges(ctx.atlas)
    cells, pts = [], []
    for i, j, k in product(range(e["speed"].size - 1), range(e["mass"].size - 1), range(3)):
        lo = np.array([e["speed"][i], e["mass"][j], e["slope"][k]])
        hi = np.array([e["speed"][i + 1], e["mass"][j + 1], e["slope"][k + 1]])
        grid = np.stack(np.meshgrid(*CELL_POINTS, indexing="ij"), -1).reshape(-1, 3)
        pts.append(lo + grid * (hi - lo))
        cells.append(
            {
                "range": f"{lo[0] * 3.6:.1f}-{hi[0] * 3.6:.1f} km/h,"
                f" {lo[1] / 1000:.0f}-{hi[1] / 1000:.0f} t,"
                f" slope {np.degrees(lo[2]):.1f}-{np.degrees(hi[2]):.1f} deg",
                "lo": lo,
                "hi": hi,
            }
        )
    return cells, np.concatenate(pts)


def synthetic_log(d: LogData, pts: F64) -> tuple[LogData, I64]:
    """Events at the conditions ``pts``, each the third of three alike at the log's median
    gap (what a between-events effect carries over), and the rows of the third ones."""
    n = pts.shape[0]
    rep = np.repeat(pts, 3, axis=0)
    times = None
    if d.time_s is not None:
        gaps = d.gap_s(np.flatnonzero(d.ok))
        g = float(np.median(gaps[np.isfinite(gaps)])) if np.isfinite(gaps).any() else 60.0
        times = np.tile([0.0, g, 2 * g], n)
    nan = np.full(3 * n, np.nan)
    syn = LogData(
        run_ids=[str(i) for i in range(n)],
        run=np.repeat(np.arange(n), 3),
        event=np.tile(np.arange(3), n),
        speed_mps=rep[:, 0],
        mass_kg=rep[:, 1],
        slope_rad=rep[:, 2],
        temp_c=nan,
        stop_dist_m=nan,
        time_s=times,
        ok=np.ones(3 * n, dtype=bool),
        u=np.zeros(3 * n),
        wear_ref=np.ones(3 * n),
        starts=np.arange(0, 3 * n + 1, 3),
        frame=pd.DataFrame(),
    )
    return syn, np.arange(2, 3 * n, 3)


def _cell_s2(ctx: Calibration, a: Scored, b: Scored, pts: F64) -> dict[str, F64]:
    """Per channel, (points,) squared separation averaged over the pads' life quantiles
    (each model at its own pads' volumes on the held-out rows)."""
    syn, rows = synthetic_log(ctx.data, pts)
    preds = []
    for s in (a, b):
        assert s.held is not None
        held = s.held.rows
        vols = s.model.volume_at(held, s.k[ctx.data.run[held]])
        v = np.repeat(np.quantile(vols, LIFE_QUANTILES), rows.size)
        preds.append(s.model.on(syn).predict(np.tile(rows, len(LIFE_QUANTILES)), v))
    s2 = channel_s2(*preds)
    return {ch: x.reshape(len(LIFE_QUANTILES), -1).mean(axis=0) for ch, x in s2.items()}


def _cell_of(ctx: Calibration, rows: I64) -> I64:
    """The operating-range cell of each row (the order of :func:`_cells`)."""
    d, e = ctx.data, operating_edges(ctx.atlas)
    idx = np.zeros(rows.size, dtype=np.int64)
    for x, ed in zip((d.speed_mps, d.mass_kg, d.slope_rad), e.values(), strict=True):
        i = np.clip(np.searchsorted(ed, x[rows], side="right") - 1, 0, ed.size - 2)
        idx = idx * (ed.size - 1) + i
    return np.asarray(idx, dtype=np.int64)


def _ranges(
    ctx: Calibration, s2c: dict[str, F64], s_sum: float, v_sum: float
) -> list[dict[str, Any]]:
    """Every operating-range cell with its separation and the events it needs, fewest first."""
    cells, _ = _cells(ctx)
    d, cfg = ctx.data, ctx.cfg
    per_cell = {ch: x.reshape(len(cells), -1).mean(axis=1) for ch, x in s2c.items()}
    logged = np.bincount(_cell_of(ctx, np.flatnonzero(d.ok)), minlength=len(cells))
    held_share = ctx.split.held_runs.size / d.n_runs
    out = []
    for i, c in enumerate(cells):
        s2 = {ch: float(per_cell[ch][i]) for ch in CHANNELS}
        m = events_to_add(s_sum, v_sum, sum(s2.values()), target_z(cfg.win_z))
        out.append(
            {
                "range": c["range"],
                "speed_kmh": [c["lo"][0] * 3.6, c["hi"][0] * 3.6],
                "mass_t": [c["lo"][1] / 1000, c["hi"][1] / 1000],
                "slope_deg": [float(np.degrees(c["lo"][2])), float(np.degrees(c["hi"][2]))],
                "separation": float(np.sqrt(sum(s2.values()))),
                "separation_by_channel": {ch: float(np.sqrt(v)) for ch, v in s2.items()},
                "events_logged": int(logged[i]),
                "scored_events_to_add": m,
                "events_to_log": m / held_share,
            }
        )
    return sorted(out, key=lambda r: r["scored_events_to_add"])


def _channels(ctx: Calibration, a: Scored, b: Scored) -> list[dict[str, Any]]:
    """Per channel on the held-out events: readings logged, separation, and the events (or
    the sensor noise) it alone would need."""
    assert a.held is not None and b.held is not None
    d, rows, z_t = ctx.data, a.held.rows, target_z(ctx.cfg.win_z)
    s2 = channel_s2(a.held.pred, b.held.pred)
    out = []
    for ch in CHANNELS:
        reading = d.temp_c[rows] if ch == "temp" else d.stop_dist_m[rows]
        ok = np.isfinite(reading)
        mean_s2 = float(np.nanmean(s2[ch]))
        z_all = 0.5 * np.sqrt(rows.size * mean_s2)  # every held-out event with a reading
        out.append(
            {
                "channel": ch,
                "logged_share": float(ok.mean()),
                "separation": float(np.sqrt(mean_s2)),
                "z_if_all_logged": float(z_all),
                "events_alone": 4 * z_t**2 / mean_s2 if mean_s2 > 0 else float("inf"),
                "noise_factor": float(min(1.0, z_all / z_t)) if z_all > 0 else 0.0,
            }
        )
    return out


def separate(ctx: Calibration, a: Scored, b: Scored) -> dict[str, Any]:
    """What would tell the tied candidates ``a`` (ahead) and ``b`` apart: more runs, an
    operating range, a channel (``attribution.separation`` of ``diagnosis.json``)."""
    assert a.held is not None and b.held is not None
    d_ll = a.held.loglik - b.held.loglik
    n = d_ll.size
    s_sum, v_sum = float(d_ll.sum()), float(d_ll.var(ddof=1) * n)
    z_now = s_sum / np.sqrt(max(v_sum, 1e-300))  # the attribution's paired z
    pred_s2 = channel_s2(a.held.pred, b.held.pred)  # where the log holds the reading
    logged_s2 = separation(
        {ch: np.where(np.isfinite(a.held.channel(ch)), x, 0.0) for ch, x in pred_s2.items()}
    )
    _, pts = _cells(ctx)
    out: dict[str, Any] = {
        "candidates": [_key(a), _key(b)],
        "paired_z": z_now,
        "win_z": ctx.cfg.win_z,
        "target_z": target_z(ctx.cfg.win_z),
        "power": POWER,
        "held_events": int(n),
        "predicted_z": float(0.5 * np.sqrt(logged_s2.sum())),
        "runs": _run_power(ctx, d_ll, a.held.rows, z_now),
        "ranges": _ranges(ctx, _cell_s2(ctx, a, b, pts), s_sum, v_sum),
        "channels": _channels(ctx, a, b),
        "events_per_run": float(ctx.data.run.size / ctx.data.n_runs),
        "method": METHOD,
    }
    out["advice"] = advice(out)
    return out


def _key(s: Scored) -> str:
    return s.effect.key if s.effect is not None else s.name


def advice(sep: dict[str, Any]) -> list[str]:
    """The options, cheapest (fewest events to log) first, as sentences with the numbers."""
    opts: list[tuple[float, str]] = []
    r = sep["runs"]
    if np.isfinite(r["runs_needed"]):
        iv = r["runs_needed_interval"]
        rng = f", {iv[0]:.0f}-{iv[1]:.0f} from the runs' spread" if iv else ""
        opts.append(
            (
                r["more_runs"] * sep["events_per_run"],
                f"log {r['more_runs']:.0f} more run{'' if r['more_runs'] == 1 else 's'} like"
                f" these ({r['runs_needed']:.0f} in all"
                f"{rng}): the paired z is {sep['paired_z']:.1f}, {sep['win_z']} is needed"
                f" ({sep['power']:.0%} power)",
            )
        )
    else:
        opts.append((np.inf, "more runs like these would not separate them (paired z <= 0)"))
    best = sep["ranges"][0]
    if np.isfinite(best["events_to_log"]):
        ch = max(best["separation_by_channel"], key=best["separation_by_channel"].get)
        opts.append(
            (
                best["events_to_log"],
                f"log about {best['events_to_log']:.0f} braking events at {best['range']}"
                f" (the log has {best['events_logged']}): there the two differ by"
                f" {best['separation']:.2f} noise units per event, mostly in"
                f" {CHANNEL_NAMES[ch]}",
            )
        )
    opts.sort(key=lambda o: o[0])
    return [text for _, text in opts] + _channel_advice(sep["channels"], sep["target_z"])


def _channel_advice(channels: list[dict[str, Any]], z_target: float) -> list[str]:
    """A channel that would separate them but is missing from the log or too noisy."""
    out = []
    main = max(channels, key=lambda c: c["separation"])["channel"] if channels else None
    for c in channels:
        name = CHANNEL_NAMES[c["channel"]]
        if c["logged_share"] < 0.5 and c["z_if_all_logged"] >= z_target:
            out.append(
                f"{name} separates them ({c['separation']:.3f} noise units per event) but the"
                f" log holds {c['logged_share']:.0%} of its readings: log it"
            )
        elif c["channel"] == main and 0 < c["noise_factor"] < 1:
            out.append(
                f"{name} differs by {c['separation']:.3f} noise units per event on the events"
                f" logged: a {name} sensor {1 / c['noise_factor']:.1f}x less noisy would"
                " separate them on the events logged"
            )
    return out


def separation_lines(sep: dict[str, Any] | None) -> list[str]:
    """The terminal text: what would tell the tied candidates apart (nothing without a tie)."""
    if not sep:
        return []
    a, b = sep["candidates"]
    head = (
        f"what would tell {a} and {b} apart (paired z {sep['paired_z']:.1f} on"
        f" {sep['held_events']} held-out events, {sep['predicted_z']:.1f} predicted;"
        f" {sep['power']:.0%} power at z > {sep['win_z']}):"
    )
    return [head, *(f"  - {line}" for line in sep["advice"])]
