"""Sim-to-real gap diagnosis: localise, attribute, quantify (docs/results/sim2real.md).

Works on any event log in the README's event-log schema (ground-truth columns are never used,
except the optional ``rul_events`` to score the twin's RUL in "quantify"). The steps are
:mod:`sim2real.diagnosis.localise`, :mod:`sim2real.diagnosis.attribute` and
:mod:`sim2real.diagnosis.quantify`; this module splits the runs, runs the steps in order and
assembles the summary that goes to ``diagnosis.json``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from brake_env.model.atlas import Atlas
from sim2real.diagnosis.attribute import (
    Calibration,
    Nominal,
    Progress,
    RunSplit,
    Scored,
    Verdict,
    cal_loglik_runs,
    candidate_table,
    decide,
    score_candidates,
)
from sim2real.diagnosis.config import DiagnosisConfig
from sim2real.diagnosis.localise import (
    Binning,
    Cells,
    Residuals,
    factor_bins,
    gap_summary,
    localise,
    residuals,
    two_sample,
)
from sim2real.diagnosis.logdata import I64, LogData, prepare_log, sample_rows
from sim2real.diagnosis.padfit import fit_k
from sim2real.diagnosis.preconditions import check_log
from sim2real.diagnosis.quantify import RulScorer, quantify, rul_error
from sim2real.diagnosis.refine import ParameterFit, refine_winner
from sim2real.diagnosis.replay import ReplayModel
from sim2real.diagnosis.separate import separate
from sim2real.effects.interface import Effect
from sim2real.effects.library import LIBRARY


@dataclass(frozen=True, eq=False)
class DiagnosisResult:
    """What ``diagnose`` found; ``summary`` is what goes to ``diagnosis.json``."""

    summary: dict[str, Any]
    data: LogData
    nominal: Residuals
    held_before: Residuals
    held_after: Residuals | None
    bins: dict[str, Binning]
    held_runs: I64
    winner: Effect | None

    @property
    def verdict(self) -> str:
        return str(self.summary["attribution"]["verdict"])


def diagnose(
    log: pd.DataFrame,
    atlas: Atlas,
    candidates: Sequence[type[Effect]] | None = None,
    config: DiagnosisConfig | None = None,
    seed: int = 0,
    *,
    progress: Progress = None,
    rul: RulScorer | None = None,
) -> DiagnosisResult:
    """Localise, attribute and quantify the gap between a log and the nominal model.

    Args:
        log: A validated event log (``brake_env.data.schema.read_event_log``), two runs or more.
        atlas: The nominal model's atlas.
        candidates: Effect classes to try (default: the library).
        config: Settings.
        seed: Seeds the run split, the event subsamples, the simulated readings and (an
            independent stream) the bootstrap of the winner's parameter.
        progress: Called with a short text per fitted model.
        rul: Optional callback for the twin's RUL error without and with the winning
            effect (:data:`~.quantify.RulScorer`, e.g. :func:`~.rul.rul_scorer`).
    """
    cfg = config or DiagnosisConfig()
    check_log(log, cfg, with_rul=rul is not None)  # fail in seconds, not after the replay
    seeds = np.random.SeedSequence(seed)
    rng = np.random.default_rng(seeds)  # the same stream as default_rng(seed)
    d = prepare_log(log, atlas)
    split = _split_runs(d, cfg, rng)
    bins = factor_bins(d, atlas)
    cells = Cells.of(bins)
    # 1. localise (all runs, the nominal model)
    nominal_rm = ReplayModel(atlas, d, None, cfg.noise)
    k0 = fit_k(nominal_rm, split.fit_rows)
    res0 = residuals(nominal_rm, _localise_rows(d, cfg, rng), k0, cfg.slope_nodes)
    local = localise(res0, bins)
    local["gap"] = gap_summary(res0, d, cells, np.arange(d.n_runs), cfg.level)
    local["two_sample"] = two_sample(res0, d, cfg.noise, rng)
    if progress:
        progress("nominal")
    # 2. attribute
    cal0 = cal_loglik_runs(nominal_rm, split, k0, cfg.slope_nodes)
    held0 = residuals(nominal_rm, split.held_rows, k0, cfg.slope_nodes)
    nominal = Nominal(nominal_rm, k0, cal0, held0)
    ctx = Calibration(atlas, d, cfg, split, nominal)
    cands = list(LIBRARY if candidates is None else candidates)
    boot_rng = np.random.default_rng(seeds.spawn(1)[0])
    att = _attribute(cands, ctx, cells, boot_rng, progress)
    # 3. quantify
    best = att.scored[0] if att.verdict.winner is not None else None
    q = quantify(d, cells, split, att.gap0, nominal, best, cfg=cfg, rng=rng)
    if rul is not None:
        q["rul"] = rul_error(rul, d, split, nominal, best)
    summary = {**_describe(d, split, cfg), "localise": local, "attribution": att.summary(nominal)}
    summary["quantify"] = q
    after = None if best is None else best.held
    return DiagnosisResult(
        summary, d, res0, nominal.held, after, bins, split.held_runs, att.verdict.winner
    )


@dataclass(frozen=True, eq=False)
class _Attribution:
    """The attribution step's outcome: candidate rows and fits (best first), the verdict,
    the candidates skipped, the held-out gap of the nominal model, the winner's parameter
    (None without a winner) and, when two candidates tie, what would separate them."""

    rows: list[dict[str, Any]]
    scored: list[Scored]
    verdict: Verdict
    skipped: dict[str, str]
    gap0: dict[str, dict[str, Any]]
    parameter: ParameterFit | None
    separation: dict[str, Any] | None = None

    def summary(self, nominal: Nominal) -> dict[str, Any]:
        v = self.verdict
        return {
            "verdict": v.answer,
            "reason": v.reason,
            "winner": v.winner.key if v.winner else None,
            "parameter": self.parameter.summary() if self.parameter else None,
            "separation": self.separation,
            "candidates": self.rows,
            "skipped": self.skipped,
            "nominal_held_loglik_per_event": float(nominal.held.loglik.mean()),
        }


def _attribute(
    cands: list[type[Effect]],
    ctx: Calibration,
    cells: Cells,
    boot_rng: np.random.Generator,
    progress: Progress,
) -> _Attribution:
    """Fit and score every candidate, decide; then refine the winner's parameter and decide
    again with the refined winner (its held-out scores are those of the refined value)."""
    d, split, cfg, nominal = ctx.data, ctx.split, ctx.cfg, ctx.nominal
    gap0 = gap_summary(nominal.held, d, cells, split.held_runs, cfg.level)
    scored, skipped = score_candidates(cands, ctx, progress=progress)
    rows, scored = candidate_table(scored, nominal, d, cells, split, cfg.level)
    verdict = decide(rows, scored, gap0, cfg)
    if verdict.winner is None:
        return _Attribution(rows, scored, verdict, skipped, gap0, None, _tie(ctx, rows, scored))
    refined, fit = refine_winner(scored[0], ctx, boot_rng, progress=progress)
    rows, scored = candidate_table([refined, *scored[1:]], nominal, d, cells, split, cfg.level)
    verdict = decide(rows, scored, gap0, cfg)
    named = verdict.winner is not None and scored[0] is refined  # (the refinement kept it)
    sep = None if named else _tie(ctx, rows, scored)
    return _Attribution(rows, scored, verdict, skipped, gap0, fit if named else None, sep)


def _tie(
    ctx: Calibration, rows: list[dict[str, Any]], scored: list[Scored]
) -> dict[str, Any] | None:
    """What would separate the two best candidates, when the verdict abstains because they
    tie (:func:`~.attribute.decide` sets their paired z only when it gets that far)."""
    z = rows[0].get("held_z_vs_runner_up") if rows else None
    if z is None or z >= ctx.cfg.win_z:
        return None
    return separate(ctx, scored[0], scored[1])


def _split_runs(d: LogData, cfg: DiagnosisConfig, rng: np.random.Generator) -> RunSplit:
    """Calibration and held-out runs, and the rows that fit K and score the models."""
    if d.n_runs < 2:
        raise ValueError(
            f"the log has {d.n_runs} run; the diagnosis splits runs into calibration and"
            " held-out runs and needs at least 2"
        )
    perm = rng.permutation(d.n_runs)
    n_cal = int(np.clip(round(cfg.calibration_fraction * d.n_runs), 1, d.n_runs - 1))
    cal_runs, held_runs = np.sort(perm[:n_cal]), np.sort(perm[n_cal:])
    fit_rows = sample_rows(d, cfg.fit_events_per_run, rng)
    cal_sample = sample_rows(d, cfg.calibration_events_per_run, rng)
    held_sample = sample_rows(d, cfg.score_events_per_run, rng)
    return RunSplit(
        cal_runs=cal_runs,
        held_runs=held_runs,
        fit_rows=fit_rows,
        cal_rows=np.concatenate([cal_sample[r] for r in cal_runs]),
        held_rows=np.concatenate([held_sample[r] for r in held_runs]),
    )


def _localise_rows(d: LogData, cfg: DiagnosisConfig, rng: np.random.Generator) -> I64:
    """The replayable rows, subsampled to ``cfg.max_localise_events``."""
    ok = np.flatnonzero(d.ok)
    if ok.size <= cfg.max_localise_events:
        return ok
    return np.sort(rng.choice(ok, cfg.max_localise_events, replace=False))


def _describe(d: LogData, split: RunSplit, cfg: DiagnosisConfig) -> dict[str, Any]:
    """The log and the noise model, as the summary reports them."""
    return {
        "log": {
            "runs": d.n_runs,
            "events": int(d.run.size),
            "replayable": int(d.ok.sum()),
            "has_time": d.time_s is not None,
            "calibration_runs": [d.run_ids[r] for r in split.cal_runs],
            "held_out_runs": [d.run_ids[r] for r in split.held_runs],
        },
        "noise": {
            "temp_c": cfg.noise.temp_c,
            "stop_dist_m": cfg.noise.stop_dist_m,
            "slope_rad": cfg.noise.slope_rad,
        },
    }
