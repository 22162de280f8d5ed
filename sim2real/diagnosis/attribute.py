"""Attribute the gap: fit each candidate on calibration runs, score it on held-out runs,
name the winner or abstain (docs/results/sim2real.md).

Runs are split into calibration and held-out runs (never events). Each candidate's fitted
parameter is chosen on calibration runs (a grid plus a parabola); its held-out
log-likelihood gain over the nominal model, a paired z against the nominal model and the
runner-up, and the BIC decide. A candidate is named only if it clearly wins *and* closes
the structured gap on held-out runs; otherwise the answer is "none of the candidates" with
what remains. The winner's parameter is then refined, with an interval
(:mod:`sim2real.diagnosis.refine`), from the per-run calibration log-likelihoods kept here.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from brake_env.model.atlas import Atlas
from sim2real.diagnosis.config import DiagnosisConfig
from sim2real.diagnosis.localise import CHANNELS, Cells, Residuals, gap_summary, residuals
from sim2real.diagnosis.logdata import F64, I64, LogData
from sim2real.diagnosis.padfit import fit_k
from sim2real.diagnosis.replay import ReplayModel
from sim2real.effects.interface import Effect

NONE = "none of the candidates"
Progress = Callable[[str], object] | None


@dataclass(frozen=True, eq=False)
class RunSplit:
    """The runs and rows a diagnosis works on.

    Attributes:
        cal_runs, held_runs: Calibration and held-out run indices, sorted.
        fit_rows: Per run, the rows that fit its pad's K.
        cal_rows: Rows of the calibration runs that score a parameter value.
        held_rows: Rows of the held-out runs that score a model (and the gap).
    """

    cal_runs: I64
    held_runs: I64
    fit_rows: list[I64]
    cal_rows: I64
    held_rows: I64


@dataclass(frozen=True, eq=False)
class Nominal:
    """The nominal model fitted to the log: replay, each run's K, calibration log-likelihood
    (per calibration run, in the order of ``RunSplit.cal_runs``) and held-out residuals."""

    model: ReplayModel
    k: F64
    cal_ll_runs: F64
    held: Residuals

    @property
    def cal_ll(self) -> float:
        return float(self.cal_ll_runs.sum())


@dataclass
class Scored:
    """A candidate at its fitted value: replay model, each run's K, calibration score.

    Attributes:
        cal_ll_runs: Calibration log-likelihood per calibration run (``RunSplit.cal_runs``).
        curve: Every parameter value tried, with its ``cal_ll_runs``.
        held: Held-out residuals (:meth:`Calibration.score_held`).
    """

    name: str
    effect: Effect | None
    model: ReplayModel
    k: F64
    cal_ll_runs: F64
    curve: dict[float, F64] = field(default_factory=dict)
    held: Residuals | None = None

    @property
    def cal_ll(self) -> float:
        return float(self.cal_ll_runs.sum())

    @property
    def grid(self) -> list[dict[str, float]]:
        """The values tried and their calibration log-likelihood, by value."""
        return [{"value": v, "cal_loglik": float(ll.sum())} for v, ll in sorted(self.curve.items())]


@dataclass(frozen=True)
class Verdict:
    """The attribution: the named effect (or :data:`NONE`), why, and the winning effect."""

    answer: str
    reason: str
    winner: Effect | None


def cal_loglik_runs(rm: ReplayModel, split: RunSplit, k: F64, nodes: int) -> F64:
    """Calibration log-likelihood of a replay, summed per calibration run."""
    res = residuals(rm, split.cal_rows, k, nodes)
    per_run = np.bincount(rm.data.run[res.rows], weights=res.loglik, minlength=rm.data.n_runs)
    return np.asarray(per_run[split.cal_runs], dtype=np.float64)


@dataclass(frozen=True, eq=False)
class Calibration:
    """What scores a candidate's parameter values: the nominal atlas, the log, the settings,
    the run split and the nominal fit."""

    atlas: Atlas
    data: LogData
    cfg: DiagnosisConfig
    split: RunSplit
    nominal: Nominal

    def score(self, cls: type[Effect], v: float) -> Scored:
        """The candidate with its first fitted parameter at ``v``, each calibration run's K
        fitted, scored on the calibration runs."""
        p = cls.fitted_params()[0]
        nom = self.nominal
        if v == p.neutral:
            return Scored(cls.name, cls(), nom.model, nom.k, nom.cal_ll_runs, {v: nom.cal_ll_runs})
        eff = cls(**{p.name: v})
        rm = ReplayModel(self.atlas, self.data, eff, self.cfg.noise)
        k = fit_k(rm, self.split.fit_rows, self.split.cal_runs)
        ll = cal_loglik_runs(rm, self.split, k, self.cfg.slope_nodes)
        return Scored(cls.name, eff, rm, k, ll, {v: ll})

    def score_held(self, s: Scored) -> Scored:
        """``s`` with the held-out runs' K fitted and its held-out residuals (in place)."""
        sp = self.split
        k_held = fit_k(s.model, sp.fit_rows, sp.held_runs)  # the held-out pad states
        s.k = np.where(np.isnan(s.k), k_held, s.k)
        s.held = residuals(s.model, sp.held_rows, s.k, self.cfg.slope_nodes)
        return s


def parameter_grid(neutral: float, lo: float, hi: float, n: int) -> list[float]:
    """Neutral value plus ``n`` values per side, halving the distance towards neutral."""
    frac = 0.5 ** np.arange(n)[::-1]
    vals = {neutral}
    for end in (lo, hi):
        if end != neutral:
            vals.update((neutral + (end - neutral) * frac).tolist())
    return sorted(vals)


def fit_candidate(cls: type[Effect], ctx: Calibration, *, progress: Progress = None) -> Scored:
    """Grid (and a parabola) over the candidate's first fitted parameter, on calibration
    runs; the result's ``curve`` holds every value tried."""
    params = cls.fitted_params()
    if not params:
        raise ValueError(f"candidate {cls.name!r} has no fitted parameter")
    p = params[0]
    scored = []
    for v in parameter_grid(p.neutral, p.lo, p.hi, ctx.cfg.grid_points):
        scored.append((v, ctx.score(cls, v)))
        if progress:
            progress(f"{cls.name}:{p.name}={v:.3g}")
    curve = {v: s.cal_ll_runs for v, s in scored}
    best = _refine(scored, p.lo, p.hi, lambda v: ctx.score(cls, v), curve)
    best.curve = curve
    return best


def _refine(
    scored: list[tuple[float, Scored]],
    lo: float,
    hi: float,
    score: Callable[[float], Scored],
    curve: dict[float, F64],
) -> Scored:
    """The best grid value, or the vertex of a parabola through it and its neighbours if
    that scores better (the vertex is added to ``curve``)."""
    lls = np.array([s.cal_ll for _, s in scored])
    i = int(np.argmax(lls))
    best = scored[i][1]
    if not 0 < i < len(scored) - 1:
        return best
    x = np.array([scored[j][0] for j in (i - 1, i, i + 1)])
    c = np.polyfit(x, lls[i - 1 : i + 2], 2)
    if c[0] < 0:
        v_ref = float(np.clip(-c[1] / (2 * c[0]), x[0], x[2]))
        if lo <= v_ref <= hi and v_ref not in x:
            s = score(v_ref)
            curve[v_ref] = s.cal_ll_runs
            if s.cal_ll > best.cal_ll:
                best = s
    return best


def score_candidates(
    cands: Sequence[type[Effect]], ctx: Calibration, *, progress: Progress = None
) -> tuple[list[Scored], dict[str, str]]:
    """Every candidate fitted on the calibration runs with its held-out residuals, and the
    candidates skipped (with the reason)."""
    scored: list[Scored] = []
    skipped = {}
    for cls in cands:
        if cls.kind == "between-events" and ctx.data.time_s is None:
            skipped[cls.name] = "needs event times (time_s), which the log does not have"
            continue
        scored.append(ctx.score_held(fit_candidate(cls, ctx, progress=progress)))
    return scored, skipped


def paired_z(a: Residuals, b: Residuals) -> float:
    """Paired z of the per-event log-likelihood difference of ``a`` over ``b``."""
    diff = a.loglik - b.loglik
    return float(diff.mean() / (diff.std(ddof=1) / np.sqrt(diff.size) + 1e-300))


def candidate_table(
    scored: list[Scored],
    nominal: Nominal,
    d: LogData,
    cells: Cells,
    split: RunSplit,
    level: float,
) -> tuple[list[dict[str, Any]], list[Scored]]:
    """One row per candidate (calibration and held-out scores, gap after), best first, and
    the candidates in the same order."""
    rows = []
    for s in scored:
        assert s.held is not None
        diff = s.held.loglik - nominal.held.loglik
        g = gap_summary(s.held, d, cells, split.held_runs, level)
        n_par = len(type(s.effect).fitted_params()) if s.effect else 0
        rows.append(
            {
                "name": s.name,
                "kind": type(s.effect).kind if s.effect else "",
                "effect": s.effect.key if s.effect else "",
                "params": dict(s.effect.values) if s.effect else {},
                "cal_loglik_gain": s.cal_ll - nominal.cal_ll,
                "bic_gain": 2 * (s.cal_ll - nominal.cal_ll) - n_par * np.log(split.cal_rows.size),
                "held_loglik_gain": float(diff.sum()),
                "held_loglik_gain_per_event": float(diff.mean()),
                "held_z_vs_nominal": paired_z(s.held, nominal.held),
                "gap_after": {ch: g[ch]["structured_gap"] for ch in CHANNELS},
                "grid": s.grid,
            }
        )
    order = np.argsort([-r["held_loglik_gain"] for r in rows])
    return [rows[i] for i in order], [scored[i] for i in order]


def decide(
    rows: list[dict[str, Any]],
    scored: list[Scored],
    gap0: dict[str, dict[str, float]],
    cfg: DiagnosisConfig,
) -> Verdict:
    """Name the best candidate only if it clearly wins and closes the gap.

    ``rows`` and ``scored`` are best first (:func:`candidate_table`); the best row gets its
    paired z against the runner-up.
    """
    if not rows:
        return Verdict(NONE, "no candidate could be tried on this log", None)
    best = rows[0]
    for check in (_no_gap, _not_significant, _tied, _not_closed):
        reason = check(rows, scored, gap0, cfg)
        if reason:
            return Verdict(NONE, reason, None)
    reason = (
        f"{best['effect']} wins on held-out runs (z {best['held_z_vs_nominal']:.1f}"
        f" vs nominal) and closes the gap"
    )
    return Verdict(best["name"], reason, scored[0].effect)


Gaps = dict[str, dict[str, float]]


def _no_gap(
    rows: list[dict[str, Any]], scored: list[Scored], gap0: Gaps, cfg: DiagnosisConfig
) -> str:
    worst = max(gap0[c]["structured_gap"] for c in CHANNELS)
    if worst >= cfg.gap_tolerance:
        return ""
    best = rows[0]
    return (
        f"no gap: the structured gap {worst:.3f} noise units is below the"
        f" tolerance {cfg.gap_tolerance} (best candidate {best['name']},"
        f" z {best['held_z_vs_nominal']:.1f})"
    )


def _not_significant(
    rows: list[dict[str, Any]], scored: list[Scored], gap0: Gaps, cfg: DiagnosisConfig
) -> str:
    best = rows[0]
    if best["held_z_vs_nominal"] >= cfg.win_z:
        return ""
    worst = max(gap0[c]["structured_gap"] for c in CHANNELS)
    return (
        f"a gap of {worst:.3f} noise units remains and no candidate improves the"
        f" held-out fit significantly (best {best['name']}, z"
        f" {best['held_z_vs_nominal']:.1f})"
    )


def _tied(
    rows: list[dict[str, Any]], scored: list[Scored], gap0: Gaps, cfg: DiagnosisConfig
) -> str:
    if len(rows) < 2:
        return ""
    a, b = scored[0].held, scored[1].held
    assert a is not None and b is not None
    z2 = paired_z(a, b)
    rows[0]["held_z_vs_runner_up"] = z2
    if z2 >= cfg.win_z:
        return ""
    return (
        f"{rows[0]['name']} and {rows[1]['name']} explain the gap about equally"
        f" well (paired z {z2:.1f} < {cfg.win_z})"
    )


def _not_closed(
    rows: list[dict[str, Any]], scored: list[Scored], gap0: Gaps, cfg: DiagnosisConfig
) -> str:
    best = rows[0]
    remains = {c: best["gap_after"][c] for c in CHANNELS}
    unclosed = [
        c
        for c in CHANNELS
        if remains[c] > max(cfg.gap_tolerance, (1 - cfg.close_fraction) * gap0[c]["structured_gap"])
    ]
    if not unclosed:
        return ""
    gaps = ", ".join(f"{c} {gap0[c]['structured_gap']:.3f} -> {remains[c]:.3f}" for c in unclosed)
    return f"best candidate {best['name']} does not close the gap: {gaps} noise units remain"
