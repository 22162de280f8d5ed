"""The twin's RUL error on held-out runs, without and with a fitted effect (issue 6, quantify).

"The twin's model includes the effect" means: for an in-event effect, a twin built on an
atlas made with the effect's physics; for a sensor or between-events effect, the nominal
twin fed temperatures with the effect's modelled change of the reading removed (for thermal
carry-over: the temperature an event would have shown had it started at the duty-cycle
level; the wear the carry-over adds is left to the twin's online K identification). Uses
``twin.DigitalTwin`` when that package provides it; returns None otherwise.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Any

import numpy as np
import pandas as pd

from brake_env.model.atlas import Atlas
from brake_env.prognostics.protocol import predict_log
from sim2real.effects import Effect
from sim2real.truth import truth_atlas


def twin_class() -> type | None:
    """``twin.DigitalTwin`` if it exists, else None."""
    try:
        mod = importlib.import_module("twin")
    except ImportError:
        return None
    return getattr(mod, "DigitalTwin", None)


Offset = "np.ndarray | None"
RulScorer = Callable[[Effect | None, pd.DataFrame, Any, pd.DataFrame, Any], "dict[str, Any] | None"]


def rul_scorer(
    atlas: Atlas,
    level: float = 0.9,
    n_boot: int = 300,
    seed: int = 0,
) -> RulScorer:
    """A ``diagnose(rul=...)`` callback: the twin's RUL RMSE per run, mean and interval.

    The callback takes (effect or None, held-out log, its offset, calibration log, its
    offset): the twin is fitted on the calibration runs and scored on the held-out runs.
    ``offset`` is, per row of a log, the effect's modelled change of the temperature
    reading (sensor and between-events effects).
    """
    cls = twin_class()

    def score(
        effect: Effect | None,
        log: pd.DataFrame,
        offset: np.ndarray | None,
        train_log: pd.DataFrame,
        train_offset: np.ndarray | None,
    ) -> dict[str, Any] | None:
        if cls is None:
            return None
        if "rul_events" not in log:
            return {"note": "the log has no rul_events column: RUL error not computable"}
        use_atlas, use_log = atlas, log
        if effect is not None and effect.kind == "in-event":
            use_atlas = truth_atlas(atlas.spec, [effect])
        elif (
            effect is not None
            and effect.kind in ("sensor", "between-events")
            and offset is not None
        ):
            use_log = log.copy()
            use_log["temp_c"] = log["temp_c"].to_numpy() - offset
            if train_offset is not None:
                train_log = train_log.copy()
                train_log["temp_c"] = train_log["temp_c"].to_numpy() - train_offset
        twin = cls(use_atlas)
        twin.fit(train_log)
        pred = predict_log(twin, use_log)
        err = pred["rul_mean"].to_numpy() - use_log["rul_events"].to_numpy()
        runs = pd.factorize(pred["run_id"])[0]
        se = np.bincount(runs, weights=err**2) / np.bincount(runs)
        rmse_runs = np.sqrt(se)
        rng = np.random.default_rng(seed)
        boot = rng.choice(rmse_runs, (n_boot, rmse_runs.size)).mean(axis=1)
        a = (1 - level) / 2
        return {
            "rmse": float(rmse_runs.mean()),
            "rmse_runs": rmse_runs.tolist(),
            "ci": [float(np.quantile(boot, a)), float(np.quantile(boot, 1 - a))],
        }

    return score
