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
with the operating-mix spread of the life). Per event the cost is of the order of the atlas
layers: the event's log-likelihood over the grid is piecewise constant, so it is kept as a
difference array (:mod:`twin.fleet`); the posterior is summarised only where an estimate is
read (:mod:`twin.posterior`). ``update`` reads it at every event; :meth:`DigitalTwin.fleet`
takes many pads at once and reads it where asked.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from statistics import NormalDist
from typing import Any, ClassVar

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from brake_env._validate import check_state
from brake_env.model.atlas import Atlas
from brake_env.model.wear import WearModel
from brake_env.prognostics.protocol import EventBatch, Predictor, RULEstimate
from twin.calibration import fit_calibration
from twin.config import TwinCalibration, TwinConfig
from twin.fleet import TwinFleet
from twin.misfit import misfit
from twin.posterior import TwinGrid

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
        grid: The K grid, prior and life at every grid K (:class:`twin.posterior.TwinGrid`),
            or None before fit.
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
        self.grid: TwinGrid | None = None
        self._z = NormalDist().inv_cdf(0.5 + 0.5 * float(self.interval_level or 0.9))
        if calibration is not None:
            self.set_calibration(calibration)

    # ------------------------------------------------------------------ calibration
    def set_calibration(self, calibration: TwinCalibration) -> None:
        """Use ``calibration`` (prior over K and noise model); resets the posterior."""
        self.calibration = calibration
        level = float(self.interval_level or 0.9)
        self.grid = TwinGrid.build(self.atlas, self.wear, self.config, calibration, level, self._z)
        self._pad = TwinFleet(self.grid, 1)

    @property
    def k_grid(self) -> F64:
        """The grid over K [-]."""
        return self._require_grid().k_grid

    def _fit(self, train_log: pd.DataFrame) -> None:
        self.set_calibration(fit_calibration(self.atlas, train_log, self.config, self.wear))

    def self_check(self, log: pd.DataFrame) -> dict[str, Any]:
        """The misfit test of :mod:`twin.misfit` on ``log``: does each pad's wear rate read
        the same from the early and the late shares of its events?"""
        return misfit(self._require_grid(), log).to_dict()

    def fitted_wear_coeff(self) -> float | None:
        """The prior's median K (None before fit)."""
        return None if self.calibration is None else math.exp(self.calibration.k_log_mean)

    def get_state(self) -> tuple[dict[str, Any], dict[str, NDArray[Any]]]:
        """The configuration and the calibration as JSON-able dicts (inf as ``"inf"``); the
        grid is rebuilt from them."""
        cal = None if self.calibration is None else _jsonable(dataclasses.asdict(self.calibration))
        return {"config": _jsonable(dataclasses.asdict(self.config)), "calibration": cal}, {}

    def set_state(self, meta: Mapping[str, Any], arrays: Mapping[str, NDArray[Any]]) -> None:
        check_state("twin", meta, arrays, meta_keys=("config", "calibration"))
        self.config = TwinConfig(**_floats(meta["config"], TwinConfig))
        self.calibration, self.grid = None, None
        if meta["calibration"] is not None:
            self.set_calibration(TwinCalibration(**_floats(meta["calibration"], TwinCalibration)))
        self.reset()

    # ------------------------------------------------------------------ filtering
    def _reset(self) -> None:
        if self.grid is not None:
            self._pad.reset(0)

    @property
    def k_posterior(self) -> tuple[F64, F64]:
        """(K grid, normalised posterior weights) after the events seen so far (no survival
        term)."""
        grid = self._require_grid()
        post = self._pad.loglik(0) + grid.log_prior
        w = np.exp(post - post.max())
        return grid.k_grid.copy(), w / w.sum()

    def fleet(self, n_pads: int) -> TwinFleet:
        """``n_pads`` pads through this calibrated twin at once (:class:`twin.fleet.TwinFleet`),
        with the estimates of :meth:`update` where they are read."""
        return TwinFleet(self._require_grid(), n_pads)

    def _update(self, events: EventBatch) -> RULEstimate:
        self._require_grid()
        n = len(events)
        return self._pad.update(np.zeros(n, dtype=np.intp), events, np.ones(n, dtype=bool))

    def _require_grid(self) -> TwinGrid:
        if self.grid is None:
            raise RuntimeError("twin: call fit() or give a calibration first")
        return self.grid


def _jsonable(d: dict[str, Any]) -> dict[str, Any]:
    """Non-finite floats as strings: JSON has no inf."""
    return {k: str(v) if isinstance(v, float) and not math.isfinite(v) else v for k, v in d.items()}


def _floats(d: Any, cls: type) -> dict[str, Any]:
    """A saved dict of ``cls`` fields back to its types: unknown or missing names and
    values that are not numbers refused, by name (the dataclass checks the ranges)."""
    if not isinstance(d, Mapping):
        raise ValueError(f"twin: the saved {cls.__name__} is {type(d).__name__}, not a dict")
    names = {f.name: f.type for f in dataclasses.fields(cls)}
    check_state(f"twin {cls.__name__}", d, {}, meta_keys=names)
    out = {}
    for k, v in d.items():
        if names[k] == "float":
            try:
                v = float(v)  # inf travels as "inf"
            except (TypeError, ValueError):
                raise ValueError(f"twin: saved {cls.__name__}.{k} is {v!r}, not a number") from None
        out[k] = v
    return out


def make_twin(atlas: Atlas, seed: int = 0) -> DigitalTwin:
    """Registry factory (``brakewear.predictors``); the twin draws no random numbers."""
    return DigitalTwin(atlas)
