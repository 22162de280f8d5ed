"""Back-testing predictors on a fleet's own history, without truth columns (docs/cli.md,
"backtest"; docs/results/prognostics.md, columns ``failed`` and ``measured_volume_frac``).

A pad run to failure (last event ``failed``; every run when the log has no ``failed``
column) lived ``last event + 1`` events, so its true RUL after event ``k`` is ``life - 1 -
k`` (as ``rul_events``). A pad removed before failure (censored) did ``n = last event + 1``
events without failing: its RUL after ``k`` was at least ``n - k``.

Each pad (or each of ``folds`` groups of pads) is held out in turn; every predictor is
fitted on the other pads, failed and censored, as ``brakewear fit`` fits, and run over the
held-out ones by :func:`~brake_env.prognostics.fleet.predict_runs` (``brakewear evaluate``'s
batch path). Scores at the cut points, the events in ``cut`` of a pad's life (failed) or of
the events it did (censored): on failed pads the RUL RMSE and the share of cut points whose
interval holds the RUL (``rmse_all``: over every event, as ``brakewear evaluate`` scores);
on censored pads the premature rate, the share of cut points where the RUL upper bound (the
mean without bounds) is below ``n - k`` (a failure announced before the pad was removed: a
certain error), and the absolute error of the volume estimate after the last event against
the volume measured at removal. Per predictor: the mean over pads with a percentile
bootstrap interval, the same resampled pads for every predictor (paired). Truth columns
(``volume_frac``, ``wear_coeff``, ``rul_events``) are dropped before anything reads the log.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass
from functools import partial
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from brake_env.data.runs import run_ends
from brake_env.data.schema import TRUTH
from brake_env.model.atlas import Atlas
from brake_env.prognostics import metrics as m
from brake_env.prognostics.evaluation import EvaluationConfig
from brake_env.prognostics.fleet import predict_runs
from brake_env.prognostics.protocol import EventBatch, Predictor, RULEstimate, iter_runs
from brake_env.prognostics.registry import ORACLE, Factory, make_predictor, predictor_names

F64 = NDArray[np.float64]
CUT = (0.15, 0.9)
TRACE_POINTS = 200  # points per failed pad kept for the figure
TRACE = ["predictor", "pad", "life_frac", "error"]
FAILED_METRICS = ("rmse", "rmse_all", "coverage")
CENSORED_METRICS = ("premature", "volume_abs_error")
SCORES = (*FAILED_METRICS, "premature", "volume_est", "volume_abs_error")


@dataclass(frozen=True)
class BacktestConfig:
    """How the back-test scores.

    Attributes:
        cut: Share of each pad's life (failed) or of its events (censored) whose events
            are the cut points, ``event / life`` in ``[cut[0], cut[1]]`` [-].
        level: Level of the bootstrap intervals over pads [-].
        n_boot: Bootstrap resamples [-].
        batch_events: Events of a pad per predictor update; 0 for as many as fit a call
            (``brakewear evaluate``'s default, :class:`EvaluationConfig`).
    """

    cut: tuple[float, float] = CUT
    level: float = 0.9
    n_boot: int = 2000
    batch_events: int = EvaluationConfig.batch_events

    def __post_init__(self) -> None:
        lo, hi = (float(c) for c in self.cut)
        object.__setattr__(self, "cut", (lo, hi))
        if not 0.0 <= lo <= hi <= 1.0:
            raise ValueError(f"BacktestConfig.cut must satisfy 0 <= lo <= hi <= 1, got {self.cut}")
        if not 0.0 < self.level < 1.0:
            raise ValueError(f"BacktestConfig.level must be in (0, 1), got {self.level}")
        for name, least in (("n_boot", 100), ("batch_events", 0)):
            v = getattr(self, name)
            if not isinstance(v, int) or v < least:
                raise ValueError(f"BacktestConfig.{name} must be an int >= {least}, got {v!r}")


@dataclass(frozen=True, eq=False)
class Pad:
    """A pad of the history and what is known of its life.

    Attributes:
        run_id: Its id in the log.
        events: Its events (no truth columns).
        failed: It ran to failure (else it was removed: censored).
        done: Events from installation to its last logged one, ``last event + 1`` [-].
        measured_volume: Volume fraction measured after its last event, NaN if none [-].
    """

    run_id: str
    events: EventBatch
    failed: bool
    done: int
    measured_volume: float

    def rul_floor(self) -> F64:
        """After each event: the true RUL (failed: ``done - 1 - event``) or the least it was
        (censored: ``done - event``, the pad did not fail at its last event) [events]."""
        return (self.done - (1 if self.failed else 0) - self.events.event).astype(np.float64)

    def cut_rows(self, cut: tuple[float, float]) -> NDArray[np.bool_]:
        """Rows whose event lies in ``cut`` of the life (failed) or of the events done."""
        frac = self.events.event / self.done
        return (frac >= cut[0]) & (frac <= cut[1])


@dataclass(frozen=True, eq=False)
class BacktestResult:
    """What :func:`backtest` found.

    Attributes:
        settings: Protocol, seed, cut, level, each pad's outcome and fold, truth ignored.
        pads: One row per predictor and held-out pad (:func:`score_pad`).
        summary: Predictor -> pads used, means over pads with intervals.
        ranking: Predictors by mean RMSE over failed pads, each one's paired difference to
            the first with its interval (None without failed pads).
        errors: ``estimate - true RUL`` [events] along the failed pads' lives, thinned.
        seconds: Predictor -> seconds of its fits and of its predictions, over the folds.
    """

    settings: dict[str, Any]
    pads: pd.DataFrame
    summary: dict[str, dict[str, Any]]
    ranking: dict[str, Any] | None
    errors: pd.DataFrame
    seconds: dict[str, dict[str, float]]


# ---------------------------------------------------------------------- the history
def history_pads(log: pd.DataFrame) -> tuple[pd.DataFrame, list[Pad], list[str]]:
    """The log without truth columns, its pads, and the truth columns it held.

    Raises:
        ValueError: Fewer than 2 pads, or no failed pad and no measured volume.
    """
    truth = [c for c in TRUTH if c in log]
    log = log.drop(columns=truth)
    ends = run_ends(log, "backtest")
    if len(ends.names) < 2:
        raise ValueError(
            f"backtest: the log has {len(ends.names)} pad(s); it needs at least 2 (one to"
            " hold out, the others to fit on)"
        )
    at_end = np.full(len(ends.names), np.nan)
    at_last = np.isin(ends.meas_rows, ends.last_row)
    at_end[ends.codes[ends.meas_rows[at_last]]] = ends.meas_volume[at_last]
    pads = [
        Pad(run_id, events, bool(failed), int(last) + 1, float(v))
        for (run_id, events), failed, last, v in zip(
            iter_runs(log), ends.failed, ends.last_event, at_end, strict=True
        )
    ]
    if not ends.failed.any() and not np.isfinite(at_end).any():
        raise ValueError(
            f"backtest: nothing to score: no pad of the {len(pads)} ran to failure (no"
            " 'failed' true on a last event) and none has a volume measured at removal"
            " ('measured_volume_frac'); removed pads alone only bound their lives"
        )
    return log, pads, truth


def assign_folds(pads: Sequence[Pad], folds: int, seed: int) -> NDArray[np.intp]:
    """Fold of each pad: its own with ``folds`` 0 (leave one pad out), else ``folds``
    groups, failed and censored pads dealt in turn after a shuffle drawn from ``seed``.

    Raises:
        ValueError: ``folds`` of 1, or more folds than pads.
    """
    n = len(pads)
    if folds == 0:
        return np.arange(n, dtype=np.intp)
    if not 2 <= folds <= n:
        raise ValueError(f"backtest: folds must be 0 (leave one pad out) or 2..{n}, got {folds}")
    rng = np.random.default_rng(np.random.SeedSequence(seed).spawn(2)[0])
    failed = np.array([p.failed for p in pads])
    order = np.r_[rng.permutation(np.flatnonzero(failed)), rng.permutation(np.flatnonzero(~failed))]
    out = np.empty(n, dtype=np.intp)
    out[order] = np.arange(n) % folds
    return out


# ---------------------------------------------------------------------- the back-test
def backtest(
    log: pd.DataFrame,
    atlas: Atlas,
    predictors: Sequence[str] | Mapping[str, Factory],
    folds: int = 0,
    seed: int = 0,
    *,
    config: BacktestConfig | None = None,
    progress: Callable[[str], object] | None = None,
) -> BacktestResult:
    """Fit each predictor without each fold's pads and score it on them.

    Args:
        log: A validated event log: the history (truth columns are ignored).
        atlas: The brake atlas (the predictors' factories take it).
        predictors: Registry names, or name -> ``factory(atlas, seed)`` of an unfitted
            predictor (a fresh one per fold).
        folds: 0 holds out one pad at a time; K >= 2 holds out K groups of pads in turn.
        seed: Seeds the predictors, the folds and the bootstrap.
        config: Cut points and intervals.
        progress: Called with the predictor's name after each fold's fit and scoring.

    Raises:
        ValueError: No predictor or an unknown name, fewer than 2 pads, nothing to score,
            bad ``folds``, or a predictor that cannot be fitted on a fold (named).
    """
    cfg = config or BacktestConfig()
    factories = _factories(predictors)
    log, pads, truth = history_pads(log)
    fold = assign_folds(pads, folds, seed)
    codes = run_ends(log, "backtest").codes
    rows: list[dict[str, Any]] = []
    errors: list[pd.DataFrame] = []
    seconds = {name: {"fit": 0.0, "predict": 0.0} for name in factories}
    for f in range(int(fold.max()) + 1):
        held = np.flatnonzero(fold == f)
        train = _fit_log(log, codes, held)
        for name, factory in factories.items():
            pred = factory(atlas, seed)
            ests, fit_s, predict_s = _fit_predict(name, pred, train, [pads[i] for i in held], cfg)
            seconds[name]["fit"] += fit_s
            seconds[name]["predict"] += predict_s
            for i, est in zip(held, ests, strict=True):
                rows.append({"predictor": name, "fold": f, **score_pad(pads[i], est, cfg.cut)})
                if pads[i].failed:
                    errors.append(_error_trace(name, pads[i], est))
            if progress:
                progress(name)
    table = pd.DataFrame(rows)
    protocol = "leave one pad out" if folds == 0 else f"{folds}-fold over pads"
    settings = {"protocol": protocol, "folds": folds, "seed": seed, "truth_columns_ignored": truth}
    settings.update(_settings(pads, fold, cfg))
    summary = summarise(table, list(factories), cfg, seed)
    ranking = _ranking(table, list(factories), cfg, seed)
    frame = pd.concat(errors, ignore_index=True) if errors else pd.DataFrame(columns=TRACE)
    return BacktestResult(settings, table, summary, ranking, frame, seconds)


def _factories(predictors: Sequence[str] | Mapping[str, Factory]) -> dict[str, Factory]:
    """Name -> factory: the given ones, or the registry's for names (checked here, before
    any work)."""
    if isinstance(predictors, Mapping):
        factories = dict(predictors)
    else:
        known = predictor_names()
        bad = [n for n in predictors if n not in known or n == ORACLE]
        if bad:
            valid = [n for n in known if n != ORACLE]
            raise ValueError(
                f"backtest: unknown predictor(s) {bad}; valid are {valid} (the"
                " oracle reads truth columns, which a history does not hold)"
            )
        factories = {n: partial(make_predictor, n) for n in dict.fromkeys(predictors)}
    if not factories:
        raise ValueError("backtest: no predictors given")
    return factories


def _fit_log(log: pd.DataFrame, codes: NDArray[np.intp], held: NDArray[np.intp]) -> pd.DataFrame:
    """The log without the held-out pads, not even as an unused category of ``run_id``."""
    train = log.loc[~np.isin(codes, held)]
    if isinstance(train["run_id"].dtype, pd.CategoricalDtype):
        train = train.assign(run_id=train["run_id"].cat.remove_unused_categories())
    return train


def _fit_predict(
    name: str, pred: Predictor, train: pd.DataFrame, held: list[Pad], cfg: BacktestConfig
) -> tuple[list[RULEstimate], float, float]:
    """``pred`` fitted on ``train``, its estimates at every event of the held-out pads, and
    the seconds of the fit and of the prediction."""
    t0 = time.perf_counter()
    try:
        pred.fit(train)
    except ValueError as e:
        raise ValueError(
            f"backtest: fitting {name} without pad(s) {[p.run_id for p in held][:5]}: {e}"
        ) from e
    t1 = time.perf_counter()
    ests = predict_runs(pred, [p.events for p in held], cfg.batch_events)
    return ests, t1 - t0, time.perf_counter() - t1


# ---------------------------------------------------------------------- scores
def score_pad(pad: Pad, est: RULEstimate, cut: tuple[float, float]) -> dict[str, Any]:
    """One held-out pad's ``pad``, ``outcome``, ``events_done``, ``cut_points`` and scores
    (NaN where they do not apply): failed, ``rmse``, ``rmse_all`` [events], ``coverage``
    [-]; censored, ``premature`` [-], ``measured_volume``, ``volume_est``,
    ``volume_abs_error`` [-]."""
    sel = pad.cut_rows(cut)
    floor = pad.rul_floor()
    row: dict[str, Any] = {"pad": pad.run_id, "outcome": "failed" if pad.failed else "censored"}
    row.update(events_done=pad.done, cut_points=int(sel.sum()), measured_volume=pad.measured_volume)
    row.update(dict.fromkeys(SCORES, float("nan")))
    lower, upper = est.rul_lower, est.rul_upper
    if pad.failed:
        row["rmse_all"] = m.rmse(est.rul_mean, floor)
        if sel.any():
            row["rmse"] = m.rmse(est.rul_mean[sel], floor[sel])
        if sel.any() and lower is not None and upper is not None:
            row["coverage"] = m.interval_coverage(lower[sel], upper[sel], floor[sel])
        return row
    if sel.any():
        bound = upper if upper is not None else est.rul_mean
        row["premature"] = float(np.mean(bound[sel] < floor[sel]))
    if est.volume_frac is not None:
        row["volume_est"] = float(est.volume_frac[-1])
        row["volume_abs_error"] = abs(row["volume_est"] - pad.measured_volume)
    return row


def summarise(
    table: pd.DataFrame, names: list[str], cfg: BacktestConfig, seed: int
) -> dict[str, dict[str, Any]]:
    """Per predictor: the pads scored and each metric's mean over pads with its bootstrap
    interval (``{"mean", "lo", "hi", "pads"}``; None where no pad has the metric)."""
    out: dict[str, dict[str, Any]] = {n: {} for n in names}
    for metric in (*FAILED_METRICS, *CENSORED_METRICS):
        wide = _wide(table, metric)
        idx = _resamples(wide.shape[0], cfg.n_boot, seed)
        for name in names:
            out[name][metric] = _interval(wide[name].to_numpy(), idx, cfg.level)
    for s in out.values():
        s["failed_pads"] = s["rmse"]["pads"] if s["rmse"] else 0
        s["censored_pads"] = s["premature"]["pads"] if s["premature"] else 0
        s["measured_pads"] = s["volume_abs_error"]["pads"] if s["volume_abs_error"] else 0
    return out


def _ranking(
    table: pd.DataFrame, names: list[str], cfg: BacktestConfig, seed: int
) -> dict[str, Any] | None:
    """Predictors by mean RMSE over failed pads; each one's paired difference to the first."""
    wide = _wide(table, "rmse")
    means = {n: float(wide[n].mean()) for n in names if wide[n].notna().any()}
    if not means:
        return None
    order = sorted(means, key=lambda n: means[n])
    idx = _resamples(wide.shape[0], cfg.n_boot, seed)
    best = wide[order[0]].to_numpy()
    diff = {n: _interval(wide[n].to_numpy() - best, idx, cfg.level) for n in order[1:]}
    return {"by": "rmse", "order": order, "rmse_minus_first": diff}


def _wide(table: pd.DataFrame, metric: str) -> pd.DataFrame:
    """Pads (those where any predictor has ``metric``) x predictors."""
    wide = table.pivot(index="pad", columns="predictor", values=metric)
    return wide[wide.notna().any(axis=1)]


def _resamples(n: int, n_boot: int, seed: int) -> NDArray[np.intp]:
    """Bootstrap rows over ``n`` pads: the same for every predictor (paired)."""
    rng = np.random.default_rng(np.random.SeedSequence(seed).spawn(2)[1])
    return rng.integers(0, max(n, 1), size=(n_boot, n))


def _interval(values: F64, idx: NDArray[np.intp], level: float) -> dict[str, Any] | None:
    """Mean of ``values`` (NaN left out) and its percentile-bootstrap interval (of values
    >= 0, never below 0)."""
    ok = np.isfinite(values)
    if not ok.any():
        return None
    mean = float(np.mean(values[ok]))
    lo = hi = None
    if ok.sum() >= 2:
        x = np.where(ok, values, 0.0)[idx]
        w = ok[idx]
        boot = x.sum(axis=1)[w.any(axis=1)] / w.sum(axis=1)[w.any(axis=1)]
        lo, hi = (float(q) for q in np.quantile(boot, [(1 - level) / 2, (1 + level) / 2]))
    return {"mean": mean, "lo": lo, "hi": hi, "pads": int(ok.sum())}


def _error_trace(name: str, pad: Pad, est: RULEstimate) -> pd.DataFrame:
    """RUL error along a failed pad's life at up to ``TRACE_POINTS`` events."""
    n = len(pad.events)
    idx = np.unique(np.linspace(0, n - 1, min(TRACE_POINTS, n)).round().astype(np.intp))
    frac, error = pad.events.event[idx] / pad.done, est.rul_mean[idx] - pad.rul_floor()[idx]
    return pd.DataFrame({"predictor": name, "pad": pad.run_id, "life_frac": frac, "error": error})


def _settings(pads: list[Pad], fold: NDArray[np.intp], cfg: BacktestConfig) -> dict[str, Any]:
    outcome = ["failed" if p.failed else "censored" for p in pads]
    rows = zip(pads, outcome, fold, strict=True)
    return {
        **asdict(cfg),
        "pads": [{"pad": p.run_id, "outcome": o, "fold": int(f)} for p, o, f in rows],
    }
