"""What the fix is worth on the user's own log: ``brakewear diagnose --backtest``
(docs/results/sim2real.md, "The twin on your pads").

After a diagnosis that names an effect an atlas can hold (in-event or sensor), the
predictors are back-tested on the diagnosed log itself, with no truth columns, by
:func:`brake_env.prognostics.backtest.backtest` (``brakewear backtest``'s library): each
nominal one, and each fed-back one (``NAME+effect``) made on the atlas with the effect at
the refined parameter value (``attribution.parameter``'s point, not the grid's). A
between-events effect (thermal carry-over) is not fed back: an atlas over (layer, speed,
mass, slope) cannot hold it. Nothing runs when the diagnosis abstains, and a log the
back-test cannot score (too few pads run to failure) says so in one line; the diagnosis is
written either way.

The block (``fix`` of ``diagnosis.json``) holds ``status`` (``done``, ``abstained``, ``not
fed back``, ``not run``), a ``note``, the ``effect`` text fed back and, when done, per
predictor its RMSE over the failed pads at 15-90% of life and its interval coverage, each
the mean over pads with a bootstrap interval, the pairs (nominal, fed back), the ranking by
RMSE and the protocol.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import pandas as pd

from brake_env.model.atlas import Atlas, cached_atlas
from brake_env.output import table
from brake_env.prognostics.backtest import (
    BacktestConfig,
    BacktestResult,
    backtest,
    history_pads,
)
from brake_env.prognostics.commands.backtest import interval_cell, predictor_factories
from brake_env.prognostics.commands.fit_effects import with_effects
from sim2real.effects.interface import Effect

FED_BACK_KINDS = ("in-event", "sensor")
NOT_FED_BACK = "cannot be fed back into the twin; the window model needs no physics"
MIN_FAILED = 2  # pads run to failure: one held out, one at least to fit on, an interval


def fed_back_effect(winner: Effect, parameter: dict[str, Any] | None) -> str:
    """The winner's canonical text with its fitted parameter at the refined value."""
    values = dict(winner.values)
    if parameter:
        values[parameter["name"]] = float(parameter["value"])
    return type(winner)(**values).key


def worth_of_fix(
    log: pd.DataFrame,
    atlas: Atlas,
    winner: Effect | None,
    parameter: dict[str, Any] | None,
    *,
    predictors: Sequence[str] = ("twin", "window"),
    fed_back: Sequence[str] = ("twin",),
    seed: int = 0,
    cache_dir: str | None = None,
    config: BacktestConfig | None = None,
    progress: Callable[[str], object] | None = None,
) -> dict[str, Any]:
    """The ``fix`` block: the back-test of ``predictors`` on ``log``, nominal and, for
    ``fed_back``, on ``atlas``'s physics with the winner at its refined ``parameter``.

    Raises:
        ValueError: An unknown predictor name (checked before any work).
    """
    predictor_factories(predictors, fed_back)  # names fail in seconds
    if winner is None:
        return _skipped("abstained", None, "the diagnosis named no effect: nothing to feed back")
    if winner.kind not in FED_BACK_KINDS:
        note = f"{winner.key} acts {winner.kind.replace('-', ' ')}: it {NOT_FED_BACK}"
        return _skipped("not fed back", winner.key, note)
    effect = fed_back_effect(winner, parameter)
    try:
        _, pads, _ = history_pads(log)
    except ValueError as e:
        return _skipped("not run", effect, str(e))
    failed = sum(p.failed for p in pads)
    if failed < MIN_FAILED:
        note = (
            f"backtest: {failed} of the log's {len(pads)} pads ran to failure; the RMSE and"
            f" coverage need at least {MIN_FAILED} (their lives are known)"
        )
        return _skipped("not run", effect, note)
    fed = cached_atlas(with_effects(atlas.spec, [effect]), cache_dir)
    factories = predictor_factories(predictors, fed_back, fed)
    try:
        res = backtest(log, atlas, factories, 0, seed, config=config, progress=progress)
    except ValueError as e:
        return _skipped("not run", effect, str(e))
    return _done(effect, fed, res, predictors, fed_back)


def _done(
    effect: str,
    fed: Atlas,
    res: BacktestResult,
    predictors: Sequence[str],
    fed_back: Sequence[str],
) -> dict[str, Any]:
    """The block of a back-test run: each nominal predictor followed by its fed-back one."""
    order = [m for n in predictors for m in (n, f"{n}+effect") if m in res.summary]
    order += [n for n in res.summary if n not in order]  # a fed-back one not asked nominal
    keys = ("rmse", "coverage", "failed_pads", "censored_pads")
    pads = res.settings["pads"]
    return {
        "status": "done",
        "note": f"{effect} fed back into {', '.join(fed_back)}",
        "effect": effect,
        "atlas_hash": fed.content_hash,
        "protocol": res.settings["protocol"],
        "cut": list(res.settings["cut"]),
        "level": res.settings["level"],
        "pads": len(pads),
        "failed_pads": sum(p["outcome"] == "failed" for p in pads),
        "predictors": {n: {k: res.summary[n][k] for k in keys} for n in order},
        "pairs": [{"nominal": n, "fed_back": f"{n}+effect"} for n in fed_back],
        "ranking": res.ranking,
        "seconds": res.seconds,
    }


def _skipped(status: str, effect: str | None, note: str) -> dict[str, Any]:
    return {"status": status, "note": note, "effect": effect}


def fix_lines(fix: dict[str, Any] | None, markdown: bool = False) -> list[str]:
    """The report's lines: the table of what the fix is worth, or why there is none."""
    if fix is None:
        return []
    head = "what the fix is worth on your log"
    if fix["status"] != "done":
        return [f"{head}: no back-test ({fix['note']})"]
    level = f"{fix['level']:.0%}"
    lo, hi = (f"{c:.0%}" for c in fix["cut"])
    rows = [["predictor", f"RMSE {lo}-{hi} [events, {level}]", f"coverage [{level}]", "pads"]]
    for name, s in fix["predictors"].items():
        label = name.replace("+effect", f" + {fix['effect']}")
        cells = [interval_cell(s["rmse"], ",.0f"), interval_cell(s["coverage"], ".2f")]
        rows.append([label, *cells, str(s["failed_pads"])])
    return [
        f"{head} ({fix['protocol']} over the {fix['failed_pads']} pads run to failure"
        f" of {fix['pads']}; means over pads, bootstrap intervals):",
        table(rows, markdown),
    ]
