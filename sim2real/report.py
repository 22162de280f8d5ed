"""Reports and figures of a diagnosis and of a validation: terminal text, Markdown, PNG
(README "Sim-to-real gap" and 8)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from brake_env.output import atomic_path, table, write_json, write_text
from sim2real.attribute import NONE
from sim2real.diagnose import DiagnosisResult
from sim2real.localise import CHANNELS, Residuals

_UNITS = {"temp": "temperature", "stop": "stopping distance"}


def _fmt_gap(g: dict[str, Any]) -> str:
    lo, hi = g["structured_gap_ci"]
    return f"{g['structured_gap']:.3f} [{lo:.3f}, {hi:.3f}]"


# ---------------------------------------------------------------------- diagnosis: text
def text_report(r: DiagnosisResult) -> str:
    """The readable report (also the body of ``report.md``)."""
    s = r.summary
    a = s["attribution"]
    lines = [f"verdict: {a['verdict']}", f"  {a['reason']}", ""]
    lines.append(
        f"log: {s['log']['runs']} runs, {s['log']['events']} events"
        f" ({len(s['log']['calibration_runs'])} calibration, "
        f"{len(s['log']['held_out_runs'])} held-out runs)"
    )
    lines += ["", *_localise_lines(s["localise"]), "", *_candidate_lines(a), ""]
    lines += [*_gap_lines(s["quantify"]), *_rul_lines(s["quantify"])]
    return "\n".join(lines)


def _localise_lines(loc: dict[str, Any]) -> list[str]:
    """Where the gap lies: the ranked cells and the two-sample tests."""
    rows = [["channel", "factor", "bin", "effect", "z", "events"]]
    for c in loc["ranked"][:8]:
        effect, z = f"{c['effect_size']:+.3f}", f"{c['z']:+.1f}"
        rows.append([c["channel"], c["factor"], c["bin"], effect, z, str(c["n"])])
    ts = loc["two_sample"]
    tests = "; ".join(
        f"{ch}: KS {ts[ch]['ks_stat']:.4f} (p {ts[ch]['ks_p']:.2g}), mean z {ts[ch]['mean_z']:+.1f}"
        for ch in CHANNELS
    )
    return [
        "where the gap lies (nominal model, all runs; effect size in sensor-noise units):",
        table(rows),
        f"two-sample (real vs model readings): {tests}",
    ]


def _candidate_lines(a: dict[str, Any]) -> list[str]:
    """The candidates' held-out scores, and those skipped."""
    rows = [["candidate", "held dLL", "z vs nominal", "BIC gain", "temp gap", "stop gap"]]
    for c in a["candidates"]:
        rows.append(
            [
                c["effect"],
                f"{c['held_loglik_gain']:.1f}",
                f"{c['held_z_vs_nominal']:.1f}",
                f"{c['bic_gain']:.1f}",
                f"{c['gap_after']['temp']:.3f}",
                f"{c['gap_after']['stop']:.3f}",
            ]
        )
    lines = ["candidates (fitted on calibration runs, scored on held-out runs):", table(rows)]
    lines += [f"  skipped {name}: {why}" for name, why in a["skipped"].items()]
    return lines


def _gap_lines(q: dict[str, Any]) -> list[str]:
    """The held-out gap before and after the winner."""
    rows = [["channel", "gap before", "gap after", "shrink", "RMS before", "RMS after"]]
    for ch in CHANNELS:
        b = q["before"][ch]
        after = q.get("after", {}).get(ch)
        rows.append(
            [
                _UNITS[ch],
                _fmt_gap(b),
                _fmt_gap(after) if after else "-",
                f"{q['shrink'][ch]:.0%}" if "shrink" in q else "-",
                f"{b['rms']:.3f}",
                f"{after['rms']:.3f}" if after else "-",
            ]
        )
    head = (
        "held-out gap (structured gap and residual RMS, sensor-noise units;"
        " 90% jackknife intervals over runs):"
    )
    return [head, table(rows)]


def _rul_lines(q: dict[str, Any]) -> list[str]:
    """The twin's RUL error before and after, if it was scored."""
    rul = q.get("rul")
    if rul is None:
        return ["twin RUL: the twin package is not available"] if "rul" in q else []
    lines = []
    for k in ("before", "after"):
        v = rul.get(k)
        if v and "rmse" in v:
            ci = v["ci"]
            lines.append(f"twin RUL RMSE {k}: {v['rmse']:.0f} events [{ci[0]:.0f}, {ci[1]:.0f}]")
        elif v:
            lines.append(f"twin RUL {k}: {v.get('note', '')}")
    return lines


# ---------------------------------------------------------------------- diagnosis: figures
def _map(ax: Any, res: Residuals, r: DiagnosisResult, fx: str, fy: str, ch: str) -> None:
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
    ax.set_title(f"{_UNITS[ch]}: mean residual / noise", fontsize=9)
    plt.colorbar(im, ax=ax)


def _save(fig: Any, path: Path) -> Path:
    fig.tight_layout()
    with atomic_path(path) as tmp:  # the temporary name keeps the suffix: PNG
        fig.savefig(tmp, dpi=110)
    plt.close(fig)
    return path


def _residual_maps(r: DiagnosisResult, path: Path) -> Path:
    fig, axes = plt.subplots(2, 3, figsize=(14, 7.5))
    for row, ch in enumerate(CHANNELS):
        _map(axes[row, 0], r.nominal, r, "speed", "slope", ch)
        _map(axes[row, 1], r.nominal, r, "speed", "life", ch)
        _map(axes[row, 2], r.nominal, r, "mass", "thermal" if "thermal" in r.bins else "life", ch)
    fig.suptitle("Residuals of the nominal model over operating conditions and life")
    return _save(fig, path)


def _candidate_scores(r: DiagnosisResult, path: Path) -> Path:
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
        ax.set_title(f"{_UNITS[ch]} residual by life stage (held-out)", fontsize=9)
        ax.tick_params(axis="x", labelsize=7)
        ax.legend(fontsize=7)
    xx = np.arange(len(CHANNELS))
    axes[2].bar(
        xx - 0.2, [q["before"][c]["structured_gap"] for c in CHANNELS], 0.4, label="nominal"
    )
    if "after" in q:
        after = [q["after"][c]["structured_gap"] for c in CHANNELS]
        axes[2].bar(xx + 0.2, after, 0.4, label="with winner")
    axes[2].set_xticks(xx, [_UNITS[c] for c in CHANNELS])
    axes[2].set_ylabel("structured gap [noise units]")
    axes[2].legend(fontsize=7)
    return _save(fig, path)


def figures(r: DiagnosisResult, out: Path) -> list[Path]:
    """Residual maps, candidate scores and before/after; returns the files written."""
    out.mkdir(parents=True, exist_ok=True)
    return [
        _residual_maps(r, out / "residual_maps.png"),
        _candidate_scores(r, out / "candidate_scores.png"),
        _before_after(r, out / "before_after.png"),
    ]


def write_outputs(r: DiagnosisResult, out: Path, extra: dict[str, Any] | None = None) -> str:
    """``diagnosis.json``, ``report.md`` and figures under ``out``; returns the text report."""
    out.mkdir(parents=True, exist_ok=True)
    write_json({**r.summary, **(extra or {})}, out / "diagnosis.json")
    text = text_report(r)
    figs = figures(r, out / "figures")
    md = ["# Sim-to-real gap diagnosis", "", "```", text, "```", ""]
    md += [f"Warning: {w}\n" for w in (extra or {}).get("log_checks", {}).get("warnings", [])]
    md += [f"![{p.stem}](figures/{p.name})" for p in figs]
    write_text("\n".join(md) + "\n", out / "report.md")
    return text


# ---------------------------------------------------------------------- validation
def _short(label: str, none: str = "none") -> str:
    return none if label == NONE else label


def validation_text(r: dict[str, Any]) -> str:
    """Confusion matrix, cases and targets of a validation result, as terminal text."""
    labels = r["labels"]
    rows = [["withheld \\ answer", *[_short(lab) for lab in labels]]]
    for e in r["rows"]:
        rows.append([_short(e, "none (control)"), *[str(r["confusion"][e][a]) for a in labels]])
    conf = table(rows)
    head = ["case", "answer", "channel", "gap before", "gap after", "shrink"]
    rows = [[*head, "RUL before", "RUL after", "s"]]
    for c in r["cases"]:
        rows.append(
            [
                c["case"],
                _short(c["answer"]),
                c["channel"],
                f"{c['gap_before']:.3f}",
                "-" if c["gap_after"] is None else f"{c['gap_after']:.3f}",
                "-" if c["shrink"] is None else f"{c['shrink']:.0%}",
                f"{c['rul_before']:.0f}" if "rul_before" in c else "-",
                f"{c['rul_after']:.0f}" if "rul_after" in c else "-",
                f"{c['seconds_simulate'] + c['seconds_diagnose']:.0f}",
            ]
        )
    cases = table(rows)
    rows = [["target", "measured", "required", "n", "met"]]
    for k, t in r["targets"].items():
        v = "-" if t["value"] is None else f"{t['value']:.0%}"
        rows.append([k, v, f">= {t['target']:.0%}", str(t["n"]), "yes" if t["met"] else "NO"])
    head_text = "confusion matrix (rows: withheld effect, columns: diagnosis)"
    return f"{head_text}\n{conf}\n\n{cases}\n\n{table(rows)}"


def _confusion_figure(r: dict[str, Any], path: Path) -> Path:
    labels, row_labels = r["labels"], r["rows"]
    m = np.array([[r["confusion"][e][a] for a in labels] for e in row_labels], dtype=float)
    fig, ax = plt.subplots(figsize=(8, 7))
    ax.imshow(m / np.maximum(m.sum(axis=1, keepdims=True), 1), cmap="Blues", vmin=0, vmax=1)
    for i, j in zip(*np.nonzero(m), strict=True):
        ax.text(j, i, f"{m[i, j]:.0f}", ha="center", va="center")
    ax.set_xticks(range(len(labels)), [_short(lab) for lab in labels], rotation=45, ha="right")
    ax.set_yticks(range(len(row_labels)), [_short(lab, "none (control)") for lab in row_labels])
    ax.set_xlabel("diagnosis")
    ax.set_ylabel("withheld effect")
    ax.set_title("Attribution of withheld effects")
    return _save(fig, path)


def _shrink_figure(r: dict[str, Any], path: Path) -> Path:
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
