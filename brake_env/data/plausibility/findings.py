"""What a plausibility check finds, how it is reported, and the checks' thresholds."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from brake_env.data.runs import describe_runs


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
        end_events: Last events of a run used to infer the volume it ended at, at most;
            no more than 2% of the run (at least 10) [-].
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
