"""The fleet study in money: every figure in the fleet file's currency, per vehicle-shift and
per year, and what each predictor is worth a year against the fixed interval and the oracle.

Per year = per vehicle-shift x vehicles x the fleet file's ``shifts_per_year`` (730 by
default: 2 x 12 h shifts a day). A predictor's figure is its best heuristic's (chosen on the
tuning episodes) on the study's objective (the headline or the net cost). Its value against
a baseline is the baseline's figure minus its own, per year (positive: it saves that much
against the baseline), with the paired interval over the evaluation episodes
(:func:`~agents.fleet.evaluation.costs.paired_interval`): against the fixed interval
(:mod:`agents.fleet.study.interval`, replacement by age alone, tuned with the same families
and budget) what condition monitoring with that predictor earns; against the oracle's (the
true RUL) what perfect prognostics would still add (a negative figure: the oracle is
cheaper).
"""

from __future__ import annotations

from typing import Any

from agents.fleet.evaluation.costs import EpisodeCost, figures, paired_interval
from agents.fleet.settings import FIXED_INTERVAL, FleetStudyConfig
from brake_env.prognostics.registry import ORACLE

BASELINES = (FIXED_INTERVAL, ORACLE)
_OBJECTIVE = {"cost": "the headline cost", "net": "the net cost"}


def per_year_factor(config: FleetStudyConfig) -> float:
    """Vehicle-shifts a year: vehicles x the fleet file's shifts a year."""
    return float(config.fleet.n_vehicles * config.fleet_file.shifts_per_year)


def add_money(
    config: FleetStudyConfig, rows: list[dict[str, Any]],
    eps: dict[tuple[str, str], list[EpisodeCost]], best: dict[str, str],
) -> dict[str, Any]:  # fmt: skip
    """Each row's cost and net cost a year (added to ``rows``) and ``costs.json``'s
    ``money``: the currency, the factor, and per predictor its best heuristic's figure per
    vehicle-shift and per year and its value against each baseline in the study."""
    f = per_year_factor(config)
    for r in rows:
        r["cost_per_year"] = r["cost"] * f
        r["net_cost_per_year"] = r["net_cost"] * f
    fleet = config.fleet_file

    def year(p: str) -> Any:
        return figures(eps[(p, best[p])], config.objective) * f

    predictors = {}
    for p in config.predictors:
        x = year(p)
        d: dict[str, Any] = {"heuristic": best[p], "per_vehicle_shift": float(x.mean() / f),
                             "per_year": float(x.mean())}  # fmt: skip
        for b in BASELINES:
            if b in config.predictors and b != p:
                iv = paired_interval(year(b), x, "difference")
                d[f"value_vs_{b}"] = {"point": iv.point, "low": iv.low, "high": iv.high}
        predictors[p] = d
    return {
        "currency": fleet.currency, "shifts_per_year": fleet.shifts_per_year,
        "vehicles": config.fleet.n_vehicles, "per_year_factor": f,
        "objective": config.objective, "predictors": predictors,
        "baselines": [b for b in BASELINES if b in config.predictors],
    }  # fmt: skip


def money_lines(summary: dict[str, Any], table: Any, markdown: bool = False) -> list[str]:
    """The money table: per predictor its best heuristic's cost per vehicle-shift and a
    year, and its value a year against each baseline (``table`` the project's
    :func:`~brake_env.output.table`)."""
    m = summary.get("money")
    if not m:
        return []
    cur, objective = m["currency"], m["objective"]
    values = m["baselines"]
    head = ["predictor", "best heuristic", f"{cur} / vehicle-shift", f"{cur} / year",
            *(f"value vs {b} ({cur} / year)" for b in values)]  # fmt: skip
    rows = [head]
    for p, d in m["predictors"].items():
        got = [_money(d.get(f"value_vs_{b}")) for b in values]
        rows.append([p, d["heuristic"], f"{d['per_vehicle_shift']:,.2f}",
                     f"{d['per_year']:,.0f}", *got])  # fmt: skip
    return [
        f"\nIn money ({_OBJECTIVE[objective]}; {cur}): a year = per vehicle-shift x"
        f" {m['vehicles']} vehicles x {m['shifts_per_year']} shifts. Value vs a baseline:"
        " its cost minus the predictor's (positive: the predictor saves that much), paired"
        " over the evaluation episodes, 95%.",
        table(rows, markdown),
    ]


def _money(d: dict[str, float] | None) -> str:
    if not d:
        return ""
    return f"{d['point']:,.0f} [{d['low']:,.0f}, {d['high']:,.0f}]"
