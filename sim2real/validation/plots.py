"""Figures of a diagnosis (residual maps, candidate scores, before/after) and of a
validation (confusion matrix, gap and RUL shrink), as PNG (docs/results/sim2real.md)."""

from __future__ import annotations

import functools
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from brake_env.output import atomic_path
from sim2real.diagnosis.diagnose import DiagnosisResult
from sim2real.diagnosis.localise import CHANNEL_NAMES, CHANNELS, Residuals
from sim2real.validation.validate import short_label

if TYPE_CHECKING:
    from types import ModuleType


@functools.cache
def _pyplot() -> ModuleType:
    """pyplot on the Agg backend, imported when the first figure is drawn (matplotlib: only
    when plotting, so that parsing the command line stays fast)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _map(ax: Any, res: Residuals, r: DiagnosisResult, fx: str, fy: str, ch: str) -> None:
    plt = _pyplot()
    ix, lx = r.bins[fx]
    iy, ly = r.bins[fy]
    x = res.channel(ch)
    ok = np.isfinite(x)
    cell = iy[res.rows][ok] * len(lx) + ix[res.rows][ok]
    n = np.bincount(cell, minlength=len(lx) * len(ly))
    sm = np.bincount(cell, weights=x[ok], minlength=len(lx) * len(ly))
    m = (sm / np.maximum(n, 1)).reshape(len(ly), len(lx))
    lim = max(float(np.abs(m).max()), 0.05)
    im = ax.imshow(m, cmap="RdBu_r", vmin=-lim, vmax=lim, origin="lower", aspect="auto")
    ax.set_xticks(range(len(lx)), lx, rotation=30, fontsize=7, ha="right")
    ax.set_yticks(range(len(ly)), ly, fontsize=7)
    ax.set_title(f"{CHANNEL_NAMES[ch]}: mean residual / noise", fontsize=9)
    plt.colorbar(im, ax=ax)


def _save(fig: Any, path: Path) -> Path:
    plt = _pyplot()
    fig.tight_layout()
    with atomic_path(path) as tmp:  # the temporary name keeps the suffix: PNG
        fig.savefig(tmp, dpi=110)
    plt.close(fig)
    return path


def _residual_maps(r: DiagnosisResult, path: Path) -> Path:
    plt = _pyplot()
    fig, axes = plt.subplots(2, 3, figsize=(14, 7.5))
    for row, ch in enumerate(CHANNELS):
        _map(axes[row, 0], r.nominal, r, "speed", "slope", ch)
        _map(axes[row, 1], r.nominal, r, "speed", "life", ch)
        _map(axes[row, 2], r.nominal, r, "mass", "thermal" if "thermal" in r.bins else "life", ch)
    fig.suptitle("Residuals of the nominal model over operating conditions and life")
    return _save(fig, path)


def _candidate_scores(r: DiagnosisResult, path: Path) -> Path:
    plt = _pyplot()
    cands = r.summary["attribution"]["candidates"]
    fig, axes = plt.subplots(1, 2, figsize=(12, 4))
    names = [c["name"] for c in cands]
    axes[0].barh(names, [c["held_loglik_gain"] for c in cands], color="tab:blue")
    axes[0].set_xscale("symlog")
    axes[0].set_xlabel("held-out log-likelihood gain over the nominal model")
    axes[0].invert_yaxis()
    for c in cands:
        g = c["grid"]
        if g:
            base = max(x["cal_loglik"] for x in g)
            axes[1].plot(range(len(g)), [x["cal_loglik"] - base for x in g], "o-", label=c["name"])
    axes[1].set_yscale("symlog")
    axes[1].set_xlabel("parameter grid index (neutral to the range ends)")
    axes[1].set_ylabel("calibration log-likelihood - best")
    axes[1].legend(fontsize=7)
    fig.suptitle(f"Candidate scores; verdict: {r.verdict}")
    return _save(fig, path)


def _before_after(r: DiagnosisResult, path: Path) -> Path:
    plt = _pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(14, 4))
    q = r.summary["quantify"]
    idx, labels = r.bins["life"]
    for ax, ch in zip(axes[:2], CHANNELS, strict=True):
        for res, lab in ((r.held_before, "nominal"), (r.held_after, "with winner")):
            if res is None:
                continue
            x, b = res.channel(ch), idx[res.rows]
            m = [np.nanmean(x[b == j]) if np.any(b == j) else np.nan for j in range(len(labels))]
            ax.plot(labels, m, "o-", label=lab)
        ax.axhline(0, color="k", lw=0.5)
        ax.set_title(f"{CHANNEL_NAMES[ch]} residual by life stage (held-out)", fontsize=9)
        ax.tick_params(axis="x", labelsize=7)
        ax.legend(fontsize=7)
    xx = np.arange(len(CHANNELS))
    axes[2].bar(
        xx - 0.2, [q["before"][c]["structured_gap"] for c in CHANNELS], 0.4, label="nominal"
    )
    if "after" in q:
        after = [q["after"][c]["structured_gap"] for c in CHANNELS]
        axes[2].bar(xx + 0.2, after, 0.4, label="with winner")
    axes[2].set_xticks(xx, [CHANNEL_NAMES[c] for c in CHANNELS])
    axes[2].set_ylabel("structured gap [noise units]")
    axes[2].legend(fontsize=7)
    return _save(fig, path)


FIGURES = ("residual_maps.png", "candidate_scores.png", "before_after.png")


def figures(r: DiagnosisResult, out: Path) -> list[Path]:
    """Residual maps, candidate scores and before/after (:data:`FIGURES`); returns the files
    written."""
    out.mkdir(parents=True, exist_ok=True)
    maps, scores, before_after = (out / name for name in FIGURES)
    return [
        _residual_maps(r, maps),
        _candidate_scores(r, scores),
        _before_after(r, before_after),
    ]


# ---------------------------------------------------------------------- validation
def _confusion_figure(r: dict[str, Any], path: Path) -> Path:
    plt = _pyplot()
    labels, row_labels = r["labels"], r["rows"]
    m = np.array([[r["confusion"][e][a] for a in labels] for e in row_labels], dtype=float)
    fig, ax = plt.subplots(figsize=(8, 7))
    ax.imshow(m / np.maximum(m.sum(axis=1, keepdims=True), 1), cmap="Blues", vmin=0, vmax=1)
    for i, j in zip(*np.nonzero(m), strict=True):
        ax.text(j, i, f"{m[i, j]:.0f}", ha="center", va="center")
    ax.set_xticks(range(len(labels)), [short_label(lab) for lab in labels], rotation=45, ha="right")
    ax.set_yticks(
        range(len(row_labels)), [short_label(lab, "none (control)") for lab in row_labels]
    )
    ax.set_xlabel("diagnosis")
    ax.set_ylabel("withheld effect")
    ax.set_title("Attribution of withheld effects")
    return _save(fig, path)


def _shrink_figure(r: dict[str, Any], path: Path) -> Path:
    plt = _pyplot()
    hits = [c for c in r["cases"] if c["shrink"] is not None]
    fig, axes = plt.subplots(1, 2, figsize=(13, 4.5))
    y = np.arange(len(hits))
    axes[0].barh(y - 0.2, [c["gap_before"] for c in hits], 0.4, label="nominal")
    axes[0].barh(y + 0.2, [c["gap_after"] for c in hits], 0.4, label="with fitted effect")
    axes[0].set_yticks(y, [c["case"] for c in hits], fontsize=7)
    axes[0].set_xscale("log")
    axes[0].set_xlabel("held-out structured gap in the affected channel [noise units]")
    axes[0].legend(fontsize=8)
    rul = [c for c in hits if "rul_before" in c]
    y2 = np.arange(len(rul))
    axes[1].barh(y2 - 0.2, [c["rul_before"] for c in rul], 0.4, label="nominal twin")
    axes[1].barh(y2 + 0.2, [c["rul_after"] for c in rul], 0.4, label="twin with the effect")
    axes[1].set_yticks(y2, [c["case"] for c in rul], fontsize=7)
    axes[1].set_xscale("log")
    axes[1].set_xlabel("twin RUL RMSE on held-out runs [events]")
    axes[1].legend(fontsize=8)
    return _save(fig, path)


def validation_figures(r: dict[str, Any], out: Path) -> list[Path]:
    """The confusion matrix and the gap and RUL shrink per case; returns the files written."""
    return [
        _confusion_figure(r, out / "confusion.png"),
        _shrink_figure(r, out / "shrink.png"),
    ]
