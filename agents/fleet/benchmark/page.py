"""The leaderboard of ``docs/benchmark.md``, written from the shipped baselines by
``brakewear fleet-leaderboard``: per suite, each baseline's net cost on the test split with
its 95% bootstrap interval over episodes, its paired ratio to the bound, its paired
difference from the suite's best, the predictors' rules paired (the twin against the window
model), the compute and the command that made them.

Only the text between the page's two markers is the command's; the rest of the page is
written by hand, and a page without the markers is refused (the command replaces nothing it
did not write).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from scipy.stats import bootstrap

from agents.fleet.benchmark.baselines import read_baselines
from agents.fleet.benchmark.suite import read_suite, shipped_suites
from agents.fleet.evaluation.costs import paired_interval

BEGIN = "<!-- leaderboard: written by `brakewear fleet-leaderboard`; edits here are lost -->"
END = "<!-- /leaderboard -->"


def leaderboard() -> str:
    """The leaderboard's Markdown, every shipped suite with shipped baselines."""
    parts = []
    for name in shipped_suites():
        suite = read_suite(name)
        shipped = read_baselines(suite)
        if shipped is None:
            parts.append(f"### `{name}`\n\nNo baselines shipped yet (`brakewear fleet-baselines"
                         f" --suite {name}`).\n")  # fmt: skip
            continue
        parts.append(suite_section(name, suite.description, shipped))
    return "\n".join(parts)


def suite_section(name: str, description: str, shipped: dict[str, Any]) -> str:
    """One suite's table and notes."""
    b = shipped["baselines"]
    order = sorted(b, key=lambda k: b[k]["net"])
    best = np.asarray(b[order[0]]["episodes"]["net"])
    bound = shipped.get("bound")
    lines = [f"### `{name}`", "", description + ".", "",
             "| policy | kind | net cost (95%) | minus the best (paired) | ratio to the bound |",
             "| --- | --- | --- | --- | --- |"]  # fmt: skip
    for k in order:
        x = np.asarray(b[k]["episodes"]["net"])
        minus = "" if k == order[0] else _iv(paired_interval(x, best, "difference"))
        lines.append(f"| `{k}` | {b[k]['kind']} | {_mean_iv(x)} | {minus} | {_ratio(x, bound)} |")
    if bound is not None:
        lines.append(f"| bound | Lagrangian ({bound['iterations']} price vectors) |"
                     f" {_mean_iv(np.asarray(bound['episodes']))} | | 1 |")  # fmt: skip
    n, secs = len(shipped["seeds"]), shipped.get("seconds")
    made = f" Made in {secs / 3600:.2f} h of wall time (2 cores, shared)" if secs else ""
    lines += ["", f"{n} test episodes from seed {shipped['seeds'][0]}; net cost per"
              f" vehicle-shift in USD.{made}: `{shipped['command']}`"]  # fmt: skip
    if "twin-rule" in b and "window-rule" in b:
        twin, window = (np.asarray(b[k]["episodes"]["net"]) for k in ("twin-rule", "window-rule"))
        d = paired_interval(twin, window, "difference")
        verdict = ("the twin is worth more" if d.high < 0
                   else "the window model is worth more" if d.low > 0
                   else "no difference shown")  # fmt: skip
        lines += ["", f"Twin's rule minus the window model's: {_iv(d)} ({verdict})."]
    return "\n".join(lines) + "\n"


def write_page(path: str | Path) -> Path:
    """Replace the leaderboard between the page's markers.

    Raises:
        ValueError: The page is missing or lacks the markers (nothing is written).
    """
    p = Path(path)
    text = p.read_text(encoding="utf-8") if p.is_file() else ""
    if BEGIN not in text or END not in text or text.index(BEGIN) > text.index(END):
        raise ValueError(f"--page {p}: no leaderboard markers ({BEGIN!r} ... {END!r}); the"
                         " command writes only between them")  # fmt: skip
    head, rest = text.split(BEGIN, 1)
    tail = rest.split(END, 1)[1]
    p.write_text(f"{head}{BEGIN}\n\n{leaderboard()}\n{END}{tail}", encoding="utf-8")
    return p


def _iv(iv: Any) -> str:
    return f"{iv.point:+.3f} [{iv.low:+.3f}, {iv.high:+.3f}]"


def _mean_iv(x: Any) -> str:
    ci = bootstrap((x,), np.mean, confidence_level=0.95, n_resamples=4000,
                   rng=np.random.default_rng(0)).confidence_interval  # fmt: skip
    return f"{x.mean():.3f} [{ci.low:.3f}, {ci.high:.3f}]"


def _ratio(x: Any, bound: dict[str, Any] | None) -> str:
    if bound is None:
        return ""
    y = np.asarray(bound["episodes"])
    if y.mean() <= 0:
        return "(bound not positive)"
    r = paired_interval(x, y, "ratio")
    return f"{r.point:.3f} [{r.low:.3f}, {r.high:.3f}]"
