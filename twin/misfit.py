"""The twin checks its own physics: does a pad's wear rate read the same from the early and
the late shares of its events? (docs/results/sim2real.md, "The twin's misfit test")

The twin reads a pad's wear coefficient K from its temperatures through the atlas: each grid
K puts every event in a layer, and the temperatures say which K puts them in the right ones.
If the atlas's physics is the pad's physics, the K read from each quarter of the pad's
events alone is one K, to within the quarters' likelihood widths. An effect the physics
lacks (heat to the disc, another wear law, friction that fades with pressure, heat carried
over between events) bends the temperature's course over the life away from the atlas's,
so the quarters need K that drift, the same way on every pad: this drift is what makes the
twin's RUL wrong by whole pad lives.

The test needs no truth and runs on any log: per pad, the weighted least-squares slope of
log K over its ``WINDOWS`` windows (each K from the temperature likelihood of that window's
events alone, flat over the twin's log-K grid: the prior would pull them together) and its
``z``; over the pads the median ``z`` and ``factor = exp(median drift)`` from the first
window to the last. The median is standardised by its spread on the atlas's own physics,
``t = median z * sqrt(n) / (1.2533 * PAD_Z_SD)`` (1.2533: the median's standard error
over the mean's for normal z), so a log of few pads needs a larger drift than a log of many.
The twin warns when ``|t|`` exceeds ``T_THRESHOLD`` on at least ``MIN_PADS`` pads.
``PAD_Z_SD`` and the threshold were chosen on the seeds of a first run of
benchmarks/analysis/twin_misfit.py (nominal logs for false alarms, the effect library for
misses) and checked on other seeds (docs/results/sim2real.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from brake_env.prognostics.fleet import concat_events
from brake_env.prognostics.protocol import EventBatch, iter_runs
from twin.fleet import TwinFleet
from twin.posterior import TwinGrid

F64 = NDArray[np.float64]
PAD_Z_SD = 1.5  # spread of one pad's z on nominal logs (1.45 measured over 240 pads) [-]
T_THRESHOLD = 3.0  # |t| above which the twin warns [-]
MIN_PADS = 3  # pads needed for a verdict [-]
WINDOWS = 4  # shares of a pad's events whose K are compared [-]
MIN_EVENTS = 400  # events a pad needs to enter the test (100 per window) [-]


@dataclass(frozen=True)
class Misfit:
    """The twin's misfit test on a log.

    Attributes:
        z: Median over the pads of the drift's z, or NaN when fewer than ``MIN_PADS``
            pads have ``MIN_EVENTS`` events [-].
        factor: exp of the median drift of log K from the first to the last window [-].
        pads: Pads in the test [-].
        per_pad: Pad id -> its z.
        threshold: The ``|t|`` beyond which the twin warns [-].
    """

    z: float
    factor: float
    pads: int
    per_pad: dict[str, float]
    threshold: float = T_THRESHOLD

    @property
    def checked(self) -> bool:
        return self.pads >= MIN_PADS and math.isfinite(self.z)

    @property
    def t(self) -> float:
        """The median z standardised by its spread on the atlas's own physics [-]."""
        return self.z * math.sqrt(self.pads) / (1.2533 * PAD_Z_SD)

    @property
    def warns(self) -> bool:
        """True when the pads' windows need different wear rates beyond the threshold."""
        return self.checked and abs(self.t) > self.threshold

    def message(self) -> str:
        """One line for the terminal: the size of the misfit and what to do."""
        if not self.checked:
            return (
                f"twin misfit: not checked ({self.pads} pad(s) with {MIN_EVENTS} events or more;"
                f" the test needs {MIN_PADS})"
            )
        size = (
            f"the last quarter of each pad's events reads a wear rate {self.factor:.2f}x the"
            f" first quarter's (median z {self.z:+.1f} over {self.pads} pads, t {self.t:+.1f})"
        )
        if not self.warns:
            return f"twin misfit: none found: {size}, within |t| {self.threshold:g}"
        return (
            f"the twin's physics does not fit this log: {size}, beyond |t| {self.threshold:g};"
            " its RUL can be wrong by whole pad lives. Run `brakewear diagnose --real LOG` to"
            " name the effect, then `brakewear fit --diagnosis DIR`, or use --predictor window"
        )

    def to_dict(self) -> dict[str, Any]:
        return {
            "z": self.z if self.checked else None,
            "t": self.t if self.checked else None,
            "factor": self.factor if self.checked else None,
            "pads": self.pads,
            "threshold": self.threshold,
            "warns": self.warns,
            "per_pad": self.per_pad,
            "message": self.message(),
        }


def misfit(grid: TwinGrid, log: pd.DataFrame) -> Misfit:
    """The drift test of the calibrated twin ``grid`` on every pad of ``log``
    with at least ``MIN_EVENTS`` events (the others are left out)."""
    runs = [(r, ev) for r, ev in iter_runs(log) if len(ev) >= MIN_EVENTS]
    if not runs:
        return Misfit(math.nan, math.nan, 0, {})
    diff, z = drift(grid, [ev for _, ev in runs])
    per_pad = {str(r): float(x) for (r, _), x in zip(runs, z, strict=True)}
    if len(runs) < MIN_PADS:
        return Misfit(math.nan, math.nan, len(runs), per_pad)
    return Misfit(float(np.median(z)), math.exp(float(np.median(diff))), len(runs), per_pad)


def drift(grid: TwinGrid, runs: list[EventBatch], windows: int = WINDOWS) -> tuple[F64, F64]:
    """Per pad, (drift of log K from its first to its last window of events, its z): K
    read from the temperature likelihood of each of ``windows`` equal shares of the pad's
    events alone (mean and variance over the grid's log K, the variance floored at the grid
    cell's), and the weighted least-squares line of log K over the windows."""
    fleet = TwinFleet(grid, len(runs))
    log_k = np.log(grid.k_grid)
    edges = [np.linspace(0, len(ev), windows + 1).astype(np.intp) for ev in runs]
    before = np.zeros((len(runs), grid.n_grid))
    mean, var = np.empty((2, len(runs), windows))
    for j in range(windows):
        parts = [ev[int(e[j]) : int(e[j + 1])] for ev, e in zip(runs, edges, strict=True)]
        pads = np.repeat(np.arange(len(runs), dtype=np.intp), [len(p) for p in parts])
        fleet.update(pads, concat_events(parts))
        after = np.array([fleet.loglik(i) for i in range(len(runs))])
        for i, ll in enumerate(after - before):
            mean[i, j], var[i, j] = _moments(ll, log_k)
        before = after
    w = 1.0 / (var + grid.dlog**2 / 12.0)
    x = np.arange(windows, dtype=np.float64)
    xc = x - (w @ x / w.sum(axis=1))[:, None]
    sxx = (w * xc**2).sum(axis=1)
    slope = (w * xc * mean).sum(axis=1) / sxx
    return slope * (windows - 1), slope * np.sqrt(sxx)


def _moments(ll: F64, log_k: F64) -> tuple[float, float]:
    w = np.exp(ll - ll.max())
    w /= w.sum()
    m = float(w @ log_k)
    return m, float(w @ (log_k - m) ** 2)
