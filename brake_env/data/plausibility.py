"""Plausibility checks of event logs and fitted parameters, before the long work (README
"Event-log schema", "What is checked").

The schema reader refuses what cannot be a braking event (a NaN event index, a negative
mass). A log can pass it and still be implausible: temperatures in kelvin, speeds in m/s,
pads removed before failure but written without ``failed`` marks, a thousand runs of three
events. A predictor fitted or run on such a log answers with confidence and is wrong. These
checks compare the log with what the model can produce and say so, naming the pads and
the evidence:

- ``envelope``: most of a run's operating conditions (speed, mass, slope) lie outside the
  atlas's envelope; the atlas clips them, so every estimate is of another vehicle. A unit
  slip is named when a conversion (m/s -> km/h, t -> kg, deg -> rad) would fix it.
- ``energy``: a run's ``energy_j`` is not the kinetic energy ``m v**2 / 2`` of its speed
  and mass (median off by more than 25%): one of the three in other units, named when the
  ratio is a known conversion (x12.96: speed in m/s).
- ``response``: most of a run's temperatures lie far outside every temperature the atlas
  gives at the event's conditions, whatever the pad's wear (kelvin, Fahrenheit, a broken or
  mislabelled sensor). A unit slip is named when a conversion would fix it.
- ``censoring``: a run that counts as a failure (no ``failed`` column, or ``failed`` on its
  last row) while its last temperatures say the pad ended far above the failure volume
  (reverse inference through the atlas, as the twin does): a pad removed before failure,
  written without its ``failed`` marks. Fitted as a life, it makes pads look short-lived.
- ``short``: a run that counts as a failure after fewer events than any pad lasts (a life
  that implies a wear coefficient ``max_k_ratio`` times the nominal one or more).
- ``fitted``: a fitted wear coefficient far outside the physical range
  (:func:`check_wear_coeff`).

Each finding is a :class:`PlausibilityWarning` (:func:`report`); with ``strict`` they
become one :class:`ImplausibleDataError` (a ``ValueError``) listing them all.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from brake_env.data.runs import describe_runs, run_ends
from brake_env.model.atlas import Atlas
from brake_env.model.regime import WearRegime
from brake_env.model.wear import WearModel

F64 = NDArray[np.float64]
KELVIN = 273.15
UNIT_SHARE = 0.2  # share of a run outside the envelope that flags it when a unit slip fits


class PlausibilityWarning(UserWarning):
    """A log or a fitted parameter the model cannot have produced (see the module doc)."""


class ImplausibleDataError(ValueError):
    """Plausibility findings made errors (``strict``)."""


@dataclass(frozen=True)
class PlausibilityConfig:
    """Thresholds of the checks.

    Attributes:
        share: Share of a run's events outside a range that flags the run [-].
        envelope_margin: Slack around the atlas envelope, as a share of its span [-].
        temp_margin_c: How far outside the atlas's temperature range (over all layers at
            the event's conditions) a reading is "far" [K]; ~8 sensor sigmas.
        end_events: Last events of a run used to infer the volume it ended at [-].
        temp_sigma_c: Temperature noise of that inference [K] (paper: 5 K).
        slope_sigma_rad: Slope-sensor noise carried through the atlas [rad] (paper: 0.01).
        censor_margin: A failed run whose inferred end volume exceeds the failure volume by
            more than this is flagged [-].
        max_k_ratio: A life implying K this many times the nominal one or more (or that
            fraction of it or less) is flagged; also the limit of :func:`check_wear_coeff`.
        sample_events: Events per run the response check reads (evenly spaced) [-].
    """

    share: float = 0.5
    envelope_margin: float = 0.1
    temp_margin_c: float = 40.0
    end_events: int = 200
    temp_sigma_c: float = 5.0
    slope_sigma_rad: float = 0.01
    censor_margin: float = 0.06
    max_k_ratio: float = 1000.0
    sample_events: int = 400

    def __post_init__(self) -> None:
        for name in ("share", "envelope_margin", "temp_margin_c", "temp_sigma_c"):
            if not getattr(self, name) > 0:
                raise ValueError(f"PlausibilityConfig.{name} must be > 0")
        if not 0 < self.share <= 1 or self.max_k_ratio <= 1:
            raise ValueError("PlausibilityConfig: share must be in (0, 1], max_k_ratio > 1")
        if self.end_events < 1 or self.sample_events < 1:
            raise ValueError("PlausibilityConfig: end_events and sample_events must be >= 1")


@dataclass(frozen=True)
class Finding:
    """One implausibility: which check, which runs, the evidence.

    Attributes:
        check: ``envelope``, ``response``, ``censoring``, ``short`` or ``fitted``.
        runs: The runs concerned (empty for a fitted parameter).
        evidence: What was seen, in numbers, and what it usually means.
    """

    check: str
    runs: tuple[str, ...]
    evidence: str

    def message(self, who: str) -> str:
        names = np.asarray(self.runs, dtype=str)
        pads = f" pads {describe_runs(names, np.ones(names.size, bool))}:" if self.runs else ""
        return f"{who}: implausible ({self.check}):{pads} {self.evidence}"


# ---------------------------------------------------------------------------- the checks
def check_log(
    log: pd.DataFrame,
    atlas: Atlas,
    *,
    lives: bool = False,
    config: PlausibilityConfig | None = None,
) -> list[Finding]:
    """Every check of a validated event log against ``atlas``.

    Args:
        log: A validated event log (:func:`~brake_env.data.schema.read_event_log`).
        atlas: The atlas the log will be read with.
        lives: The runs are training lives (``fit``, ``evaluate``): also check that those
            counting as failures look like failures (``censoring``, ``short``).
        config: Thresholds.
    """
    cfg = config or PlausibilityConfig()
    if len(log) == 0:
        return []
    codes, uniques = pd.factorize(log["run_id"], sort=False)
    names: NDArray[np.str_] = np.asarray(uniques.astype(str))
    out = _envelope(log, atlas, codes, names, cfg)
    out += _energy(log, codes, names, cfg)
    out += _response(log, atlas, codes, names, cfg)
    if lives:
        out += _lives(log, atlas, cfg)
    return out


def check_wear_coeff(
    what: str, k: float, regime: WearRegime | None = None, config: PlausibilityConfig | None = None
) -> list[Finding]:
    """A fitted wear coefficient ``k`` far from the nominal one of ``regime`` (the paper's
    2e-6 by default): more than ``max_k_ratio`` times it, or that fraction of it."""
    cfg, nominal = config or PlausibilityConfig(), (regime or WearRegime()).k_mean
    if np.isfinite(k) and k > 0 and 1 / cfg.max_k_ratio < k / nominal < cfg.max_k_ratio:
        return []
    return [
        Finding(
            "fitted",
            (),
            f"{what} K = {k:.3g}, {k / nominal:.3g}x the nominal {nominal:.3g} (physical"
            f" pads lie within {cfg.max_k_ratio:g}x of it): the training log is likely"
            " implausible (see the other warnings)",
        )
    ]


def report(findings: list[Finding], who: str, *, strict: bool = False) -> None:
    """Each finding as a :class:`PlausibilityWarning`; with ``strict``, one
    :class:`ImplausibleDataError` listing them all instead."""
    if not findings:
        return
    if strict:
        raise ImplausibleDataError(
            "\n".join(f.message(who) for f in findings) + "\n(strict: plausibility findings"
            " are errors; check the log, or run without --strict to go on with warnings)"
        )
    for f in findings:
        warnings.warn(f.message(who), PlausibilityWarning, stacklevel=2)


def warn_implausible(
    log: pd.DataFrame,
    atlas: Atlas,
    who: str,
    *,
    lives: bool = False,
    strict: bool = False,
    config: PlausibilityConfig | None = None,
) -> list[Finding]:
    """:func:`check_log` then :func:`report`: what the commands call before the long work.
    Returns the findings (warned, or raised with ``strict``)."""
    findings = check_log(log, atlas, lives=lives, config=config)
    report(findings, who, strict=strict)
    return findings


def warn_fitted(
    fitted: dict[str, float | None], who: str, *, strict: bool = False
) -> list[Finding]:
    """:func:`check_wear_coeff` of each predictor's fitted K (None: it fits none)."""
    findings = [f for name, k in fitted.items() if k is not None for f in check_wear_coeff(name, k)]
    report(findings, who, strict=strict)
    return findings


# ------------------------------------------------------------------------- conditions
def _envelope(
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


def _energy(
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


def _profiles(log: pd.DataFrame, atlas: Atlas, rows: NDArray[np.intp]) -> tuple[F64, F64, F64]:
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


def _response(
    log: pd.DataFrame,
    atlas: Atlas,
    codes: NDArray[np.intp],
    names: NDArray[np.str_],
    cfg: PlausibilityConfig,
) -> list[Finding]:
    rows = _sample(codes, names.size, cfg.sample_events)
    temp_at, _, ok = _profiles(log, atlas, rows)
    t = log["temp_c"].to_numpy(dtype=np.float64)[rows]
    lo, hi = temp_at.min(axis=1), temp_at.max(axis=1)
    valid = ok > 0

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


# ------------------------------------------------------------------------------ lives
def end_volumes(
    log: pd.DataFrame, atlas: Atlas, rows: NDArray[np.intp], cfg: PlausibilityConfig
) -> F64:
    """The pad volume most likely at ``rows`` (one group of events of one run, last ones):
    the layer whose atlas temperatures at the events' conditions fit their readings best,
    Gaussian noise ``temp_sigma_c`` plus the slope noise through the atlas (the twin's
    reverse inference, without a prior on K)."""
    temp_at, dslope, ok = _profiles(log, atlas, rows)
    t = log["temp_c"].to_numpy(dtype=np.float64)[rows]
    var = (dslope * cfg.slope_sigma_rad) ** 2 + cfg.temp_sigma_c**2
    ll = -0.5 * ((np.where(ok > 0, t, 0.0)[:, None] - temp_at) ** 2 / var + np.log(var))
    ll *= ok[:, None]
    return float(atlas.volumes[int(np.argmax(ll.sum(axis=0)))])  # type: ignore[return-value]


def _lives(log: pd.DataFrame, atlas: Atlas, cfg: PlausibilityConfig) -> list[Finding]:
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
    for r in np.flatnonzero(check & (counts >= 10)):
        rows = order[starts[r] + max(0, counts[r] - cfg.end_events) : starts[r] + counts[r]]
        v_end[r] = end_volumes(log, atlas, rows, cfg)
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
            f"they count as failures, but the temperatures of their last {cfg.end_events}"
            f" events say the pad ended at volume {shown} (atlas reverse inference), far above"
            f" the failure volume {fv:.2f}: pads removed before failure? mark their last row"
            " 'failed' false (fitted as lives, they make pads look short-lived)",
        )
    ]
