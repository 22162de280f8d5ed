"""Reports and figures of a diagnosis: terminal text, Markdown, PNG (issue 6, output)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from brake_env.cli.common import table, write_json
from sim2real.diagnose import CHANNELS, DiagnosisResult, Residuals

_UNITS = {"temp": "temperature", "stop": "stopping distance"}


def _fmt_gap(g: dict[str, Any]) -> str:
    lo, hi = g["structured_gap_ci"]
    return f"{g['structured_gap']:.3f} [{lo:.3f}, {hi:.3f}]"


def text_report(r: DiagnosisResult) -> str:
    """The readable report (also the body of ``report.md``)."""
    s = r.summary
    a, q, loc = s["attribution"], s["quantify"], s["localise"]
    lines = [f"verdict: {a['verdict']}", f"  {a['reason']}", ""]
    lines.append(
        f"log: {s['log']['runs']} runs, {s['log']['events']} events"
        f" ({len(s['log']['calibration_runs'])} calibration, "
        f"{len(s['log']['held_out_runs'])} held-out runs)"
    )
    lines.append("")
    lines.append("where the gap lies (nominal model, all runs; effect size in sensor-noise units):")
    rows = [["channel", "factor", "bin", "effect", "z", "events"]]
    for c in loc["ranked"][:8]:
        rows.append(
            [
                c["channel"],
                c["factor"],
                c["bin"],
                f"{c['effect_size']:+.3f}",
                f"{c['z']:+.1f}",
                str(c["n"]),
            ]
        )
    lines.append(table(rows))
    ts = loc["two_sample"]
    lines.append(
        "two-sample (real vs model readings): "
        + "; ".join(
            f"{ch}: KS {ts[ch]['ks_stat']:.4f} (p {ts[ch]['ks_p']:.2g}),"
            f" mean z {ts[ch]['mean_z']:+.1f}"
            for ch in CHANNELS
        )
    )
    lines.append("")
    lines.append("candidates (fitted on calibration runs, scored on held-out runs):")
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
    lines.append(table(rows))
    for name, why in a["skipped"].items():
        lines.append(f"  skipped {name}: {why}")
    lines.append("")
    lines.append(
        "held-out gap (structured gap and residual RMS, sensor-noise units;"
        " 90% jackknife intervals over runs):"
    )
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
    lines.append(table(rows))
    rul = q.get("rul")
    if rul:
        for k in ("before", "after"):
            v = rul.get(k)
            if v and "rmse" in v:
                lines.append(
                    f"twin RUL RMSE {k}: {v['rmse']:.0f} events"
                    f" [{v['ci'][0]:.0f}, {v['ci'][1]:.0f}]"
                )
            elif v:
                lines.append(f"twin RUL {k}: {v.get('note', '')}")
    elif rul is None and "rul" in q:
        lines.append("twin RUL: the twin package is not available")
    return "\n".join(lines)


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


def figures(r: DiagnosisResult, out: Path) -> list[Path]:
    """Residual maps, candidate scores and before/after; returns the files written."""
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    fig, axes = plt.subplots(2, 3, figsize=(14, 7.5))
    for row, ch in enumerate(CHANNELS):
        _map(axes[row, 0], r.nominal, r, "speed", "slope", ch)
        _map(axes[row, 1], r.nominal, r, "speed", "life", ch)
        _map(axes[row, 2], r.nominal, r, "mass", "thermal" if "thermal" in r.bins else "life", ch)
    fig.suptitle("Residuals of the nominal model over operating conditions and life")
    fig.tight_layout()
    paths.append(out / "residual_maps.png")
    fig.savefig(paths[-1], dpi=110)
    plt.close(fig)

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
    fig.tight_layout()
    paths.append(out / "candidate_scores.png")
    fig.savefig(paths[-1], dpi=110)
    plt.close(fig)

    fig, axes = plt.subplots(1, 3, figsize=(14, 4))
    q = r.summary["quantify"]
    for i, ch in enumerate(CHANNELS):
        idx, labels = r.bins["life"]
        for res, lab in ((r.held_before, "nominal"), (r.held_after, "with winner")):
            if res is None:
                continue
            x = res.channel(ch)
            b = idx[res.rows]
            m = [np.nanmean(x[b == j]) if np.any(b == j) else np.nan for j in range(len(labels))]
            axes[i].plot(labels, m, "o-", label=lab)
        axes[i].axhline(0, color="k", lw=0.5)
        axes[i].set_title(f"{_UNITS[ch]} residual by life stage (held-out)", fontsize=9)
        axes[i].tick_params(axis="x", labelsize=7)
        axes[i].legend(fontsize=7)
    before = [q["before"][c]["structured_gap"] for c in CHANNELS]
    after = [q["after"][c]["structured_gap"] for c in CHANNELS] if "after" in q else [0, 0]
    xx = np.arange(len(CHANNELS))
    axes[2].bar(xx - 0.2, before, 0.4, label="nominal")
    if "after" in q:
        axes[2].bar(xx + 0.2, after, 0.4, label="with winner")
    axes[2].set_xticks(xx, [_UNITS[c] for c in CHANNELS])
    axes[2].set_ylabel("structured gap [noise units]")
    axes[2].legend(fontsize=7)
    fig.tight_layout()
    paths.append(out / "before_after.png")
    fig.savefig(paths[-1], dpi=110)
    plt.close(fig)
    return paths


def write_outputs(r: DiagnosisResult, out: Path, extra: dict[str, Any] | None = None) -> str:
    """``diagnosis.json``, ``report.md`` and figures under ``out``; returns the text report."""
    out.mkdir(parents=True, exist_ok=True)
    write_json({**r.summary, **(extra or {})}, out / "diagnosis.json")
    text = text_report(r)
    figs = figures(r, out / "figures")
    md = ["# Sim-to-real gap diagnosis", "", "```", text, "```", ""]
    md += [f"![{p.stem}](figures/{p.name})" for p in figs]
    (out / "report.md").write_text("\n".join(md) + "\n")
    return text
