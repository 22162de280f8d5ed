"""The checks of a log's readings against the atlas: operating envelope, kinetic energy,
temperature response (:mod:`brake_env.data.plausibility`)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from brake_env.data.plausibility.findings import Finding, PlausibilityConfig
from brake_env.model.atlas import Atlas

F64 = NDArray[np.float64]
KELVIN = 273.15
MAX_SAMPLED = 200_000  # events the response check reads in all, whatever the fleet's size
CHUNK = 1 << 14  # events per atlas profile call: ~80 MB of corners at 80 layers
UNIT_SHARE = 0.2  # share of a run outside the envelope that flags it when a unit slip fits


def envelope(
    log: pd.DataFrame,
    atlas: Atlas,
    codes: NDArray[np.intp],
    names: NDArray[np.str_],
    cfg: PlausibilityConfig,
) -> list[Finding]:
    axes = {
        "speed_kmh": (atlas.speed_mps * 3.6, "km/h", [(3.6, "m/s (x3.6)"), (1.609344, "mph")]),
        "mass_kg": (atlas.mass_kg, "kg", [(1000.0, "t (x1000)")]),
        "slope_rad": (atlas.slope_rad, "rad", [(np.pi / 180.0, "deg (x pi/180)")]),
    }
    out = []
    for col, (grid, unit, fixes) in axes.items():
        lo, hi = float(grid[0]), float(grid[-1])
        pad = cfg.envelope_margin * (hi - lo)
        x = log[col].to_numpy(dtype=np.float64)

        def outside(v: F64, lo: float = lo, hi: float = hi, pad: float = pad) -> NDArray[np.bool_]:
            return np.isfinite(v) & ((v < lo - pad) | (v > hi + pad))

        valid = np.isfinite(x)
        flagged = _runs_where(outside(x), valid, codes, names.size, cfg.share)
        some = _runs_where(outside(x), valid, codes, names.size, UNIT_SHARE)
        for factor, _ in fixes:  # fewer outside, but a unit slip would bring them all in
            flagged |= some & ~_runs_where(outside(x * factor), valid, codes, names.size, 0.02)
        if not flagged.any():
            continue
        rows = flagged[codes] & np.isfinite(x)
        evidence = (
            f"{col}: {outside(x)[rows].mean():.0%} of their events outside the atlas's"
            f" {lo:.3g}-{hi:.3g} {unit} (median {np.median(x[rows]):.3g}); the atlas clips"
            " them, so estimates are of another vehicle"
        )
        evidence += _unit_hint(x[rows], outside, fixes)
        out.append(Finding("envelope", tuple(names[flagged]), evidence))
    return out


def _unit_hint(
    x: F64, outside: Callable[[F64], NDArray[np.bool_]], fixes: list[tuple[float, str]]
) -> str:
    """``; logged in <unit>? ...`` for the first scale factor that brings most inside."""
    for factor, name in fixes:
        if outside(x * factor).mean() < 0.1:
            inside = 1 - outside(x * factor).mean()
            return f"; logged in {name}? the converted readings are {inside:.0%} inside"
    return ""


def _runs_where(
    bad: NDArray[np.bool_],
    valid: NDArray[np.bool_],
    codes: NDArray[np.intp],
    n_runs: int,
    share: float,
) -> NDArray[np.bool_]:
    """Runs where more than ``share`` of the valid events are ``bad``."""
    n_bad = np.bincount(codes, weights=bad & valid, minlength=n_runs)
    n_ok = np.bincount(codes, weights=valid, minlength=n_runs)
    return (n_ok > 0) & (n_bad > share * n_ok)


def energy(
    log: pd.DataFrame, codes: NDArray[np.intp], names: NDArray[np.str_], cfg: PlausibilityConfig
) -> list[Finding]:
    """``energy_j`` is the kinetic energy ``m v**2 / 2`` of the event's start (schema): a
    run whose median ratio to it is off by more than 25% has a channel in other units."""
    v = log["speed_kmh"].to_numpy(dtype=np.float64) / 3.6
    ratio = log["energy_j"].to_numpy(dtype=np.float64) / (
        0.5 * log["mass_kg"].to_numpy(dtype=np.float64) * v * v
    )
    valid = np.isfinite(ratio) & (ratio > 0)
    med = pd.Series(np.where(valid, ratio, np.nan)).groupby(codes).median().to_numpy()
    med = np.full(names.size, np.nan) if med.size != names.size else med
    flagged = np.isfinite(med) & ((med < 0.8) | (med > 1.25))
    if not flagged.any():
        return []
    m = float(np.median(med[flagged]))
    hints = {
        3.6**2: "speed_kmh logged in m/s",
        1000.0: "mass_kg logged in t (or energy_j in mJ)",
        1e-3: "energy_j logged in kJ",
        1.609344**2: "speed_kmh logged in mph",
    }
    near = [h for r, h in hints.items() if abs(np.log(m / r)) < 0.15]
    return [
        Finding(
            "energy",
            tuple(names[flagged]),
            f"energy_j is {m:.3g}x the kinetic energy m v^2/2 of speed_kmh and mass_kg"
            f" (median; 1 in a consistent log)"
            + (f": {near[0]}?" if near else ": a channel in other units"),
        )
    ]


# --------------------------------------------------------------------------- response
def _sample(codes: NDArray[np.intp], n_runs: int, per_run: int) -> NDArray[np.intp]:
    """Up to ``per_run`` evenly spaced rows of each run (log order)."""
    order = np.argsort(codes, kind="stable")
    counts = np.bincount(codes, minlength=n_runs)
    starts = np.r_[0, np.cumsum(counts)[:-1]]
    take = np.minimum(counts, per_run)
    run = np.repeat(np.arange(n_runs), take)
    j = np.arange(take.sum()) - np.repeat(np.cumsum(take) - take, take)
    pos = (j * counts[run]) // np.maximum(take[run], 1)
    return order[starts[run] + pos]


def atlas_profiles(log: pd.DataFrame, atlas: Atlas, rows: NDArray[np.intp]) -> tuple[F64, F64, F64]:
    """(temperature, d temperature / d slope, ok) at every layer for ``rows``, conditions
    clipped into the envelope; ``ok``: all four channels finite."""
    s = log["speed_kmh"].to_numpy(dtype=np.float64)[rows] / 3.6
    m = log["mass_kg"].to_numpy(dtype=np.float64)[rows]
    th = log["slope_rad"].to_numpy(dtype=np.float64)[rows]
    t = log["temp_c"].to_numpy(dtype=np.float64)[rows]
    ok = np.isfinite(s) & np.isfinite(m) & np.isfinite(th) & np.isfinite(t)
    s, m, th = (
        np.where(ok, v, g[0])
        for v, g in ((s, atlas.speed_mps), (m, atlas.mass_kg), (th, atlas.slope_rad))
    )
    prof = atlas.lookup.profiles(s, m, th)
    return prof[:, 0], prof[:, 1], ok.astype(np.float64)


def response(
    log: pd.DataFrame,
    atlas: Atlas,
    codes: NDArray[np.intp],
    names: NDArray[np.str_],
    cfg: PlausibilityConfig,
) -> list[Finding]:
    # Up to sample_events per run, and no more than MAX_SAMPLED in all (a large fleet).
    per_run = max(5, min(cfg.sample_events, MAX_SAMPLED // max(names.size, 1)))
    rows = _sample(codes, names.size, per_run)
    lo, hi, valid = np.empty(rows.size), np.empty(rows.size), np.empty(rows.size, dtype=bool)
    for c0 in range(0, rows.size, CHUNK):  # bounded memory: (rows, 8 corners, layers)
        temp_at, _, ok = atlas_profiles(log, atlas, rows[c0 : c0 + CHUNK])
        lo[c0 : c0 + CHUNK], hi[c0 : c0 + CHUNK] = temp_at.min(axis=1), temp_at.max(axis=1)
        valid[c0 : c0 + CHUNK] = ok > 0
    t = log["temp_c"].to_numpy(dtype=np.float64)[rows]

    def far(v: F64) -> NDArray[np.bool_]:
        return valid & ((v < lo - cfg.temp_margin_c) | (v > hi + cfg.temp_margin_c))

    flagged = _runs_where(far(t), valid, codes[rows], names.size, cfg.share)
    if not flagged.any():
        return []
    sel = flagged[codes[rows]] & valid
    excess = (t - np.clip(t, lo, hi))[sel]
    evidence = (
        f"temp_c: {far(t)[sel].mean():.0%} of their sampled events lie more than"
        f" {cfg.temp_margin_c:g} K outside every temperature the atlas gives at their"
        f" conditions, at any wear (median {np.median(excess):+.3g} K beyond); a predictor"
        " reading them infers a pad at the end of its life or beyond"
    )
    for conv, name in (
        (lambda v: v - KELVIN, "kelvin (-273.15)"),
        (lambda v: (v - 32) / 1.8, "Fahrenheit"),
    ):
        if (far(conv(t)) & sel).sum() < 0.1 * sel.sum():
            evidence += (
                f"; logged in {name}? converted, {1 - far(conv(t))[sel].mean():.0%} are inside"
            )
            break
    else:
        evidence += "; a sensor bias, a mislabelled channel or another brake"
    return [Finding("response", tuple(names[flagged]), evidence)]
