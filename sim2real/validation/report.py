"""Reports of a diagnosis and of a validation: terminal text, ``diagnosis.json`` and
Markdown with the figures of :mod:`sim2real.validation.plots` (docs/results/sim2real.md)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from brake_env.output import table, write_json, write_text
from sim2real.diagnosis.diagnose import DiagnosisResult
from sim2real.diagnosis.fix import fix_lines
from sim2real.diagnosis.localise import CHANNEL_NAMES, CHANNELS
from sim2real.diagnosis.separate import separation_lines
from sim2real.validation.plots import FIGURES, figures
from sim2real.validation.validate import short_label


def _fmt_gap(g: dict[str, Any]) -> str:
    lo, hi = g["structured_gap_ci"]
    return f"{g['structured_gap']:.3f} [{lo:.3f}, {hi:.3f}]"


# ---------------------------------------------------------------------- diagnosis: text
def text_report(r: DiagnosisResult) -> str:
    """The readable report (also the body of ``report.md``)."""
    s = r.summary
    a = s["attribution"]
    lines = [f"verdict: {a['verdict']}", f"  {a['reason']}", *_parameter_lines(a), ""]
    sep = separation_lines(a.get("separation"))
    lines += [*sep, *([""] if sep else [])]
    lines.append(
        f"log: {s['log']['runs']} runs, {s['log']['events']} events"
        f" ({len(s['log']['calibration_runs'])} calibration, "
        f"{len(s['log']['held_out_runs'])} held-out runs)"
    )
    lines += ["", *_localise_lines(s["localise"]), "", *_candidate_lines(a), ""]
    lines += [*_gap_lines(s["quantify"]), *_rul_lines(s["quantify"])]
    fix = fix_lines(s.get("fix"))
    return "\n".join([*lines, *([""] if fix else []), *fix])


def _parameter_lines(a: dict[str, Any]) -> list[str]:
    """The winner's fitted parameter with its interval (none without a winner)."""
    p = a.get("parameter")
    if not p:
        return []
    lo, hi = p["interval"]
    unit = "" if p["unit"] == "-" else f" {p['unit']}"
    return [
        f"  fitted {p['name']} = {p['value']:.4g}{unit},"
        f" {p['level']:.0%} interval [{lo:.4g}, {hi:.4g}]"
        f" ({p['method']}: {p['calibration_runs']} runs, {p['resamples']} resamples;"
        f" {len(p['values_tried'])} values tried,"
        f" {p['refine_evaluations']} by the refinement; the grid gave {p['grid_value']:.4g})"
    ]


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
                CHANNEL_NAMES[ch],
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


def write_outputs(
    r: DiagnosisResult, out: Path, extra: dict[str, Any] | None = None, draw: bool = True
) -> str:
    """``diagnosis.json``, ``report.md`` and figures under ``out``; returns the text report.
    ``draw=False`` keeps the figures already drawn there (a rewrite with ``fix`` added)."""
    out.mkdir(parents=True, exist_ok=True)
    write_json({**r.summary, **(extra or {})}, out / "diagnosis.json")
    text = text_report(r)
    figs = figures(r, out / "figures") if draw else [out / "figures" / n for n in FIGURES]
    figs = [p for p in figs if p.is_file()]
    md = ["# Sim-to-real gap diagnosis", "", "```", text, "```", ""]
    md += [f"Warning: {w}\n" for w in (extra or {}).get("log_checks", {}).get("warnings", [])]
    fix = r.summary.get("fix")
    if fix and fix["status"] == "done":
        head, tab = fix_lines(fix, markdown=True)
        md += ["## What the fix is worth on your log", "", head[0].upper() + head[1:], "", tab, ""]
    md += [f"![{p.stem}](figures/{p.name})" for p in figs]
    write_text("\n".join(md) + "\n", out / "report.md")
    return text


# ---------------------------------------------------------------------- validation
def validation_text(r: dict[str, Any]) -> str:
    """Confusion matrix, cases and targets of a validation result, as terminal text."""
    labels = r["labels"]
    rows = [["withheld \\ answer", *[short_label(lab) for lab in labels]]]
    for e in r["rows"]:
        rows.append(
            [short_label(e, "none (control)"), *[str(r["confusion"][e][a]) for a in labels]]
        )
    conf = table(rows)
    head = ["case", "answer", "channel", "gap before", "gap after", "shrink"]
    rows = [[*head, "RUL before", "RUL after", "s"]]
    for c in r["cases"]:
        rows.append(
            [
                c["case"],
                short_label(c["answer"]),
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
