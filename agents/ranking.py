"""Every policy on the held-out pads under one cost ratio: the ranking, with paired bootstrap
intervals of each ratio to the oracle and of each gap between neighbours in the ranking
(README "Maintenance cost by predictor")."""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np

from agents import outcomes as oc
from agents.bootstrap import Intervals, bootstrap_figures
from agents.pad_study import PadSet
from agents.policies.rules import PolicyId
from agents.results import Estimate, Gap, PolicyRow, RatioResult, Tuning

if TYPE_CHECKING:
    from agents.compare import CompareConfig

F64 = oc.F64
ORACLE = PolicyId("oracle")
REPLACE_ON_FAILURE = PolicyId("replace-on-failure")
FIELD = {"threshold": "rul_mean", "lower-threshold": "rul_lower"}


def tuned_outcomes(pads: PadSet, family: PolicyId, parameter: float) -> oc.Outcomes:
    """A tuned family's outcomes on ``pads`` with its parameter [events]."""
    if family.kind == "fixed-interval":
        return oc.fixed_interval_outcomes(pads, np.array([parameter]))[0]
    assert family.predictor is not None
    values = pads.estimates[family.predictor][FIELD[family.kind]]
    return oc.threshold_outcomes(pads, values, np.array([parameter]))[0]


def rank_policies(
    config: CompareConfig,
    pads: PadSet,
    tuning: Tuning,
    agents: Mapping[PolicyId, oc.Outcomes],
    ratio: float,
    seed: int = 0,
) -> RatioResult:
    """Each tuned family (with its parameter tuned for ``ratio``; none if the tuning had too
    few pads), each agent, replace-on-failure and the oracle, priced at ``ratio``, cheapest
    first, with intervals."""
    from agents.compare import weights

    costs = weights(ratio)
    runs: dict[PolicyId, tuple[oc.Outcomes, float | None]] = {ORACLE: (oc.oracle(pads), None)}
    if tuning.enough:
        for fam, p in tuning.best[ratio].items():
            runs[fam] = (tuned_outcomes(pads, fam, p), p)
    runs.update((k, (v, None)) for k, v in agents.items())
    runs[REPLACE_ON_FAILURE] = (oc.never(pads), None)
    cost = {k: float(oc.cost_per_1000(pads, out, costs)) for k, (out, _) in runs.items()}
    order = sorted(runs, key=lambda k: cost[k])  # stable: the oracle wins a tie
    outs = [runs[k][0] for k in order]
    ood = _ood_pair(order)
    iv = _intervals(pads, outs, costs, ood, config, seed)
    n = len(order)
    rows = {
        k: _row(pads, runs[k][0], runs[k][1], k, iv, i, n, config.level)
        for i, k in enumerate(order)
    }
    gaps = tuple(Gap(order[i], order[i + 1], Estimate(*iv[2 * n + i])) for i in range(n - 1))
    ranking = sorted(
        {k.predictor for k in order if k.predictor is not None},
        key=lambda p: min(cost[k] for k in order if k.predictor == p),
    )
    return RatioResult(
        failure_to_planned=ratio,
        oracle_cost_per_1000_events=cost[ORACLE],
        policies=rows,
        gaps=gaps,
        predictor_ranking=tuple(ranking),
        ood_failure_gap=Estimate(*iv[3 * n - 1]) if ood else None,
    )


def _ood_pair(order: list[PolicyId]) -> tuple[int, int] | None:
    """Where the twin's and the physics predictor's best policies are in ``order``."""
    first = {}
    for i, k in enumerate(order):
        if k.predictor in ("twin", "physics") and k.predictor not in first:
            first[k.predictor] = i
    return (first["twin"], first["physics"]) if len(first) == 2 else None


def _intervals(
    pads: PadSet,
    outs: list[oc.Outcomes],
    costs: oc.CostWeights,
    ood: tuple[int, int] | None,
    config: CompareConfig,
    seed: int,
) -> Intervals:
    """Figures, in order: each policy's cost per 1000 events, its ratio to the oracle (the
    first policy), each gap between neighbours, and the OOD failure gap (if ``ood``)."""
    n = len(outs)
    is_ood = (pads.draws.label != "id") * 1.0
    rows = [x for out in outs for x in (out.cost(costs), out.events * 1.0)]
    if ood:
        rows += [outs[i].failed * is_ood for i in ood] + [is_ood]

    def statistic(m: F64) -> F64:
        c = 1000.0 * m[..., 0 : 2 * n : 2] / m[..., 1 : 2 * n : 2]
        r = c / c[..., :1]
        parts = [c, r, r[..., 1:] - r[..., :-1]]
        if ood:
            gap = 100.0 * (m[..., 2 * n] - m[..., 2 * n + 1]) / m[..., 2 * n + 2]
            parts.append(gap[..., None])
        return np.concatenate(parts, axis=-1)

    return bootstrap_figures(
        pads,
        np.stack(rows),
        statistic,
        level=config.level,
        n_resamples=config.n_resamples,
        seed=seed,
    )


def _row(
    pads: PadSet,
    out: oc.Outcomes,
    parameter: float | None,
    key: PolicyId,
    iv: Intervals,
    i: int,
    n: int,
    level: float,
) -> PolicyRow:
    never = parameter is not None and (parameter == 0 or np.isinf(parameter))
    note = "never replaces: tuning fell back to replace-on-failure" if never else ""
    return PolicyRow(
        parameter=parameter,
        cost_per_1000_events=Estimate(*iv[i]),
        ratio_to_oracle=Estimate(*iv[n + i]) if i else Estimate.exact(1.0),
        failures_per_100_pads=failure_rates(pads, out, level),
        mean_unused_life_frac=oc.unused_life(pads, out),
        note=note if key.tuned else "",
        life_left=pads.life - out.events,
    )


def failure_rates(pads: PadSet, out: oc.Outcomes, level: float) -> dict[str, Estimate]:
    """Failures per 100 pads: over the regime's mix (no interval), and per label and over
    the OOD labels with Clopper-Pearson intervals (the OOD labels pooled: they have equal
    weights and, as drawn, equal numbers of pads)."""
    from scipy.stats import binomtest

    rates = oc.failures_per_100(pads, out)
    res = {"all": Estimate.exact(rates["all"])}
    strata = pads.strata()
    groups = {k: [k] for k in ("id", "ood-slow", "ood-fast")}
    groups["ood"] = ["ood-slow", "ood-fast"]
    for name, labels in groups.items():
        idx = [strata[k] for k in labels if k in strata]
        if not idx:
            res[name] = Estimate.exact(float("nan"))
            continue
        fails = out.failed[np.concatenate(idx)]
        ci = binomtest(int(fails.sum()), fails.size).proportion_ci(level, method="exact")
        res[name] = Estimate(100.0 * fails.mean(), 100.0 * ci.low, 100.0 * ci.high)
    return res
