"""Prognostics evaluation harness: fit predictors, run them over test logs, score them.

The comparison of paper 2.5 and Table 4 for any set of predictors (a mapping name ->
predictor, so this module imports neither the twin nor the baselines): each predictor is
fitted on the training log and fed the events of every test run, each run a new pad (as
:func:`brake_env.prognostics.protocol.predict_log` does: all runs of a split through the
predictor's fleet at once when it has one, with an estimate at every event), and scored
against the ground truth with :mod:`brake_env.prognostics.metrics`. The result is a
JSON-able dict (per model, per split, per run, plus means and standard deviations over
runs), a table like the paper's Table 4, and thinned traces of every run for the figures
(:mod:`brake_env.prognostics.plots`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from brake_env.prognostics import metrics as m
from brake_env.prognostics.fleet import predict_runs
from brake_env.prognostics.protocol import EventBatch, RULEstimate, RULPredictor, iter_runs
from brake_env.prognostics.tables import rmse_table, summary_table

F64 = NDArray[np.float64]
TEST_SPLITS = ("id", "ood")
_OPTIONAL = ("rul_lower", "rul_upper", "volume_frac", "wear_coeff")


@dataclass(frozen=True)
class EvaluationConfig:
    """What the harness computes.

    Attributes:
        tolerances: RUL error tolerances of the convergence event, as fractions of the
            run's life [-] (paper Figure 13).
        alpha: Half-width of the alpha-lambda band, a fraction of the true RUL, and of the
            prognostic-horizon band, a fraction of the life [-].
        lam: Point of the life at which relative accuracy and alpha-lambda are read [-].
        phm_scale_life: Unit of the PHM08 error d as a fraction of the run's life (0.01: d
            in percent of life; see :func:`metrics.phm08_score`) [-].
        k_fractions: Points of the life at which the K-estimate error is reported [-].
        k_tolerance: Relative K error whose convergence event is reported [-].
        batch_events: Events of a run per ``update`` call (runs interleaved in a fleet); 0
            for as many as fit a call.
        trace_points: Events per run kept for the figures (evenly spaced, first and last
            included).
    """

    tolerances: tuple[float, ...] = m.TOLERANCES
    alpha: float = 0.2
    lam: float = 0.5
    phm_scale_life: float = 0.01
    k_fractions: tuple[float, ...] = (0.1, 0.25, 0.5, 0.75, 0.9)
    k_tolerance: float = 0.1
    batch_events: int = 0
    trace_points: int = 2000

    def __post_init__(self) -> None:
        object.__setattr__(self, "tolerances", tuple(float(t) for t in self.tolerances))
        object.__setattr__(self, "k_fractions", tuple(float(f) for f in self.k_fractions))
        if not self.tolerances or not all(0 < t < 1 for t in self.tolerances):
            raise ValueError(
                f"EvaluationConfig.tolerances must be in (0, 1), got {self.tolerances}"
            )
        if not all(0 <= f <= 1 for f in self.k_fractions):
            raise ValueError(
                f"EvaluationConfig.k_fractions must be in [0, 1], got {self.k_fractions}"
            )
        for name, lo, hi in (("alpha", 0.0, 1.0), ("lam", 0.0, 1.0), ("k_tolerance", 0.0, 10.0)):
            v = getattr(self, name)
            if not lo < v <= hi:
                raise ValueError(f"EvaluationConfig.{name} must be in ({lo}, {hi}], got {v}")
        if not 0 < self.phm_scale_life <= 1:
            raise ValueError(
                f"EvaluationConfig.phm_scale_life must be in (0, 1], got {self.phm_scale_life}"
            )
        if not isinstance(self.batch_events, int) or self.batch_events < 0:
            raise ValueError(
                f"EvaluationConfig.batch_events must be an int >= 0, got {self.batch_events!r}"
            )
        if not isinstance(self.trace_points, int) or self.trace_points < 2:
            raise ValueError(
                f"EvaluationConfig.trace_points must be an int >= 2, got {self.trace_points!r}"
            )


@dataclass
class Evaluation:
    """What :func:`evaluate` found.

    Attributes:
        metrics: JSON-able results: ``config``, ``splits`` (runs, lives and true K of each
            test run) and ``models`` -> name -> {``fit_seconds``, ``interval_level``,
            ``splits`` -> split -> {``runs`` -> run_id -> metrics, ``mean``, ``std``,
            ``predict_seconds``, ``events``}}.
        traces: Model -> split -> run_id -> thinned per-event frame (``event``, truth
            ``rul_true``, ``volume_true``, ``k_true`` and the estimate's columns).
        samples: Split -> the run shown in the single-run figures: the first ID run and the
            OOD run of the fastest wear (the paper's choice).
    """

    metrics: dict[str, Any]
    traces: dict[str, dict[str, dict[str, pd.DataFrame]]] = field(default_factory=dict)
    samples: dict[str, str] = field(default_factory=dict)

    @property
    def models(self) -> list[str]:
        return list(self.metrics["models"])

    @property
    def splits(self) -> list[str]:
        return list(self.metrics["splits"])

    def mean(self, model: str, split: str, key: str) -> Any:
        """Mean over the runs of a split of one metric (e.g. ``"rul_rmse"``)."""
        return self.metrics["models"][model]["splits"][split]["mean"][key]

    def table(self, markdown: bool = False) -> str:
        """Per-run RUL RMSE [events] and their mean: rows models, one block per split."""
        return rmse_table(self.metrics, markdown)

    def summary_table(self, markdown: bool = False) -> str:
        """Means over runs of the other metrics, one row per model and split."""
        return summary_table(self.metrics, markdown)


# ---------------------------------------------------------------------- the harness
def evaluate(
    predictors: Mapping[str, RULPredictor],
    logs: Mapping[str, pd.DataFrame],
    config: EvaluationConfig | None = None,
    *,
    fit: bool = True,
    progress: Callable[[str, int], object] | None = None,
) -> Evaluation:
    """Fit every predictor on ``logs["train"]`` and score it on the test splits.

    Args:
        predictors: Name -> predictor (the name labels the results; unfitted if ``fit``).
        logs: Validated event logs: ``train`` (when ``fit``) and any of ``id``, ``ood``;
            the test logs must carry the ground truth ``rul_events`` and start every run at
            a fresh pad (event 0).
        config: What to compute.
        fit: Fit the predictors first; False to score predictors fitted beforehand.
        progress: Called with (model name, events) after each ``update`` of the
            predictor, and with (``"fit <name>"``, 0) before each fit.

    Returns:
        The metrics, traces and sample runs.

    Raises:
        ValueError: No predictors, no test split, a missing training log, or a test log
            without ground truth.
    """
    cfg = config or EvaluationConfig()
    runs = _check_inputs(predictors, logs, fit)
    out: dict[str, Any] = {
        "config": _jsonable(asdict(cfg)),
        "splits": {s: _split_info(r) for s, r in runs.items()},
        "models": {},
    }
    traces: dict[str, dict[str, dict[str, pd.DataFrame]]] = {}
    for name, pred in predictors.items():
        fit_s = 0.0
        if fit:
            if progress:
                progress(f"fit {name}", 0)
            t0 = time.perf_counter()
            pred.fit(logs["train"])
            fit_s = time.perf_counter() - t0
        model: dict[str, Any] = {
            "predictor": getattr(pred, "name", name),
            "fit_seconds": fit_s,
            "interval_level": getattr(pred, "interval_level", None),
            "splits": {},
        }
        traces[name] = {}
        for split, split_runs in runs.items():
            report = _score_split(name, pred, split_runs, cfg, progress)
            model["splits"][split], traces[name][split] = report
        out["models"][name] = model
    samples = {s: _sample_run(s, r) for s, r in runs.items()}
    return Evaluation(_jsonable(out), traces, samples)


def _check_inputs(
    predictors: Mapping[str, RULPredictor], logs: Mapping[str, pd.DataFrame], fit: bool
) -> dict[str, list[tuple[str, EventBatch]]]:
    """The test runs of every test split present, after checking the inputs."""
    if not predictors:
        raise ValueError("evaluate: no predictors given")
    splits = [s for s in TEST_SPLITS if s in logs]
    if not splits:
        raise ValueError(f"evaluate: no test log; give one of {list(TEST_SPLITS)}")
    if fit and "train" not in logs:
        raise ValueError("evaluate: the predictors need a 'train' log to be fitted on")
    return {s: _test_runs(s, logs[s]) for s in splits}


def _score_split(
    name: str,
    pred: RULPredictor,
    runs: list[tuple[str, EventBatch]],
    cfg: EvaluationConfig,
    progress: Callable[[str, int], object] | None,
) -> tuple[dict[str, Any], dict[str, pd.DataFrame]]:
    """Metrics of one fitted predictor over the runs of a split, and its thinned traces."""
    t0 = time.perf_counter()
    tick = None if progress is None else (lambda n: progress(name, n))
    ests = predict_runs(pred, [ev for _, ev in runs], cfg.batch_events, tick)
    per_run: dict[str, Any] = {}
    traces: dict[str, pd.DataFrame] = {}
    for (run_id, events), est in zip(runs, ests, strict=True):
        per_run[run_id] = run_metrics(est, events, cfg)
        traces[run_id] = _trace(est, events, cfg.trace_points)
    report = {
        "predict_seconds": time.perf_counter() - t0,
        "events": int(sum(len(e) for _, e in runs)),
        "mean": _aggregate(list(per_run.values()), np.mean),
        "std": _aggregate(list(per_run.values()), np.std),
        "runs": per_run,
    }
    return report, traces


def run_metrics(est: RULEstimate, events: EventBatch, cfg: EvaluationConfig) -> dict[str, Any]:
    """Every metric of one run (see :mod:`brake_env.prognostics.metrics`); optional parts
    when available."""
    assert events.rul_events is not None
    true = events.rul_events.astype(np.float64)
    rul = est.rul_mean
    life = m.life_events(true)
    conv = {
        f"{t:g}": _event_of(events, m.convergence_event(rul, true, t, life)) for t in cfg.tolerances
    }
    res: dict[str, Any] = {
        "life_events": life,
        "rul_rmse": m.rmse(rul, true),
        "rul_rmse_frac": m.rmse(rul, true) / life,
        "convergence_event": conv,
        "convergence_frac": {k: v / life for k, v in conv.items()},
        "relative_accuracy": m.relative_accuracy(rul, true, cfg.lam),
        "alpha_lambda": m.alpha_lambda(rul, true, cfg.alpha, cfg.lam),
        "prognostic_horizon_frac": m.prognostic_horizon(rul, true, cfg.alpha, life) / life,
        "cumulative_relative_accuracy": m.cumulative_relative_accuracy(rul, true),
        "monotonicity": m.monotonicity(rul),
        "phm08": m.phm08_score(rul, true, cfg.phm_scale_life * life),
    }
    if est.volume_frac is not None and events.volume_frac is not None:
        res["volume_rmse"] = m.rmse(est.volume_frac, events.volume_frac)
    if est.wear_coeff is not None and events.wear_coeff is not None:
        err = m.relative_error(est.wear_coeff, events.wear_coeff)
        k_conv = _event_of(events, m.converged_within(err, cfg.k_tolerance))
        res["k_rel_error"] = {
            "mean": float(np.mean(err)),
            "final": float(err[-1]),
            "at_life_frac": dict(
                zip(
                    (f"{f:g}" for f in cfg.k_fractions),
                    m.at_life_fractions(err, cfg.k_fractions),
                    strict=True,
                )
            ),
            f"convergence_frac_{cfg.k_tolerance:g}": k_conv / life,
        }
    if est.rul_lower is not None and est.rul_upper is not None:
        res["interval_coverage"] = m.interval_coverage(est.rul_lower, est.rul_upper, true)
        res["interval_width_frac"] = m.interval_width(est.rul_lower, est.rul_upper, life)
    return res


# ---------------------------------------------------------------------- internals
def _test_runs(split: str, log: pd.DataFrame) -> list[tuple[str, EventBatch]]:
    if "rul_events" not in log:
        raise ValueError(f"the {split} log has no ground truth (rul_events): nothing to score")
    runs = list(iter_runs(log))
    if not runs:
        raise ValueError(f"the {split} log has no runs")
    for run_id, ev in runs:
        if int(ev.event[0]) != 0:
            raise ValueError(
                f"{split} run {run_id!r} starts at event {int(ev.event[0])}: test runs must"
                " start at pad installation (event 0)"
            )
    return runs


def _event_of(events: EventBatch, row: int) -> int:
    """The event index of a run's row ``row`` (``len``: the end of the run): the same number
    on a full log from event 0, and on a log with gaps the event, not the row (protocol
    module docstring, "Gaps")."""
    return int(events.event[row]) if row < len(events) else int(events.event[-1]) + 1


def _split_info(runs: list[tuple[str, EventBatch]]) -> dict[str, Any]:
    return {
        "runs": [r for r, _ in runs],
        "life_events": [m.life_events(e.rul_events) for _, e in runs],  # type: ignore[arg-type]
        "wear_coeff": [None if e.wear_coeff is None else float(e.wear_coeff[0]) for _, e in runs],
    }


def _sample_run(split: str, runs: list[tuple[str, EventBatch]]) -> str:
    """The first ID run; for OOD the fastest-wearing run (shortest life), as in the paper."""
    if split != "ood":
        return runs[0][0]
    lives = [m.life_events(e.rul_events) for _, e in runs]  # type: ignore[arg-type]
    return runs[int(np.argmin(lives))][0]


def _trace(est: RULEstimate, events: EventBatch, points: int) -> pd.DataFrame:
    n = len(events)
    idx = np.unique(np.linspace(0, n - 1, min(points, n)).round().astype(np.int64))
    cols: dict[str, Any] = {"event": events.event[idx]}
    assert events.rul_events is not None
    cols["rul_true"] = events.rul_events[idx].astype(np.float64)
    if events.volume_frac is not None:
        cols["volume_true"] = events.volume_frac[idx]
    if events.wear_coeff is not None:
        cols["k_true"] = events.wear_coeff[idx]
    cols["rul_mean"] = est.rul_mean[idx]
    for k in _OPTIONAL:
        v = getattr(est, k)
        if v is not None:
            cols[k] = v[idx]
    return pd.DataFrame(cols)


def _aggregate(rows: list[dict[str, Any]], fn: Callable[[F64], Any]) -> dict[str, Any]:
    """``fn`` over runs of every numeric leaf present in all runs (NaN ignored)."""
    out: dict[str, Any] = {}
    for key in rows[0]:
        vals = [r.get(key) for r in rows]
        if any(v is None for v in vals):
            continue
        if isinstance(vals[0], dict):
            out[key] = _aggregate([v for v in vals if v is not None], fn)
        else:
            x = np.asarray(vals, dtype=np.float64)
            x = x[np.isfinite(x)]
            out[key] = float(fn(x)) if x.size else None
    return out


def _jsonable(x: Any) -> Any:
    """Plain Python types; NaN and inf become None (JSON has neither)."""
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_jsonable(v) for v in x]
    if isinstance(x, bool | np.bool_):
        return bool(x)
    if isinstance(x, int | np.integer):
        return int(x)
    if isinstance(x, float | np.floating):
        return float(x) if math.isfinite(x) else None
    return x
