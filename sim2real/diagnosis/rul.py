"""The twin's RUL error on held-out runs, without and with a fitted effect (quantify).

"The twin's model includes the effect" means: for an in-event effect, a twin built on an
atlas made with the effect's physics; for a sensor or between-events effect, the nominal
twin fed temperatures with the effect's modelled change of the reading removed (for thermal
carry-over: the temperature an event would have shown had it started at the duty-cycle
level; the wear the carry-over adds is left to the twin's online K identification). The
twin is the ``twin`` predictor of ``brake_env.prognostics.registry`` (paper 2.4); without
it the scorer returns None.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from brake_env.model.atlas import Atlas
from brake_env.prognostics.protocol import predict_log
from brake_env.prognostics.registry import make_predictor, predictor_names
from sim2real.diagnosis.quantify import LogPart, RulScorer
from sim2real.effects.interface import Effect
from sim2real.effects.truth import truth_atlas


def twin_available() -> bool:
    """Whether the ``twin`` predictor is installed (a plug-in of the predictor registry)."""
    return "twin" in predictor_names()


def rul_scorer(
    atlas: Atlas,
    level: float = 0.9,
    n_boot: int = 300,
    seed: int = 0,
) -> RulScorer:
    """A ``diagnose(rul=...)`` callback: the twin's RUL RMSE per run, mean and interval.

    The callback takes (effect or None, held-out part, calibration part): the twin is
    fitted on the calibration runs and scored on the held-out runs. Its answer is
    ``{"rmse": mean over runs, "rmse_runs": per run, "ci": bootstrap interval over runs}``
    [events], a ``{"note": ...}`` when the log has no ``rul_events``, or None without the
    twin.
    """
    has_twin = twin_available()

    def score(effect: Effect | None, held: LogPart, cal: LogPart) -> dict[str, Any] | None:
        if not has_twin:
            return None
        if "rul_events" not in held.log:
            return {"note": "the log has no rul_events column: RUL error not computable"}
        use_atlas = atlas
        if effect is not None and effect.kind == "in-event":
            use_atlas = truth_atlas(atlas.spec, [effect])
        twin = make_predictor("twin", use_atlas, seed)
        twin.fit(_corrected(cal))
        log = _corrected(held)
        pred = predict_log(twin, log)
        err = pred["rul_mean"].to_numpy() - log["rul_events"].to_numpy()
        return rmse_by_run(err, pred["run_id"], level, n_boot, seed)

    return score


def _corrected(part: LogPart) -> pd.DataFrame:
    """The part's log with the effect's modelled change of the temperature removed."""
    if part.temp_offset is None:
        return part.log
    log = part.log.copy()
    log["temp_c"] = part.log["temp_c"].to_numpy() - part.temp_offset
    return log


def rmse_by_run(
    err: np.ndarray, run_id: pd.Series, level: float, n_boot: int, seed: int
) -> dict[str, Any]:
    """RMSE of each run's errors, their mean and a bootstrap interval of the mean (over
    runs)."""
    runs = pd.factorize(run_id)[0]
    rmse_runs = np.sqrt(np.bincount(runs, weights=err**2) / np.bincount(runs))
    rng = np.random.default_rng(seed)
    boot = rng.choice(rmse_runs, (n_boot, rmse_runs.size)).mean(axis=1)
    a = (1 - level) / 2
    return {
        "rmse": float(rmse_runs.mean()),
        "rmse_runs": rmse_runs.tolist(),
        "ci": [float(np.quantile(boot, a)), float(np.quantile(boot, 1 - a))],
    }
