"""Plausibility checks of event logs and fitted parameters, before the long work
(docs/schema.md, "What is checked").

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

import math
import warnings

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from brake_env.data.plausibility.findings import (
    Finding,
    ImplausibleDataError,
    PlausibilityConfig,
    PlausibilityWarning,
)
from brake_env.data.plausibility.lives import end_volumes
from brake_env.data.plausibility.lives import lives as check_lives
from brake_env.data.plausibility.readings import energy, envelope, response
from brake_env.model.atlas import Atlas
from brake_env.model.regime import WearRegime

__all__ = [
    "Finding",
    "ImplausibleDataError",
    "PlausibilityConfig",
    "PlausibilityWarning",
    "check_log",
    "check_wear_coeff",
    "end_volumes",
    "report",
    "warn_fitted",
    "warn_implausible",
]


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
    out = envelope(log, atlas, codes, names, cfg)
    out += energy(log, codes, names, cfg)
    out += response(log, atlas, codes, names, cfg)
    if lives:
        out += check_lives(log, atlas, cfg)
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
            f"{what} K = {k:.3g}, "
            + (f"{k / nominal:.3g}x" if math.isfinite(k) else "not a finite multiple of")
            + f" the nominal {nominal:.3g} (physical"
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
