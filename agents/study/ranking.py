"""Every policy on the held-out pads under one cost ratio: the ranking, with paired bootstrap
intervals of each ratio to the oracle and of each gap between neighbours in the ranking
(docs/results/single-pad.md)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from agents.policies.rules import ESTIMATE_FIELD, ORACLE, REPLACE_ON_FAILURE, PolicyId
from agents.study import outcomes as oc
from agents.study.bootstrap import Intervals, bootstrap_figures
from agents.study.config import StudyConfig
from agents.study.costs import OOD_LABELS
from agents.study.pads import PadSet
from agents.study.results import Estimate, Gap, PolicyRow, RatioResult, Tuning
from brake_env.model.regime import LABELS

F64 = oc.F64


def tuned_outcomes(pads: PadSet, family: PolicyId, parameter: float) -> oc.Outcomes:
    """A tuned family's outcomes on ``pads`` with its parameter [events]."""
    if family.kind == "fixed-interval":
        return oc.fixed_interval_outcomes(pads, np.array([parameter]))[0]
    assert family.predictor is not None
    values = pads.estimates[family.predictor][ESTIMATE_FIELD[family.kind]]
    return oc.threshold_outcomes(pads, values, np.array([parameter]))[0]


def rank_policies(
    config: StudyConfig,
    pads: PadSet,
    tuning: Tuning,
    agents: Mapping[PolicyId, oc.Outcomes],
    ratio: float,
    seed: int = 0,
) -> RatioResult:
    """Each tuned family (with its parameter tuned for ``ratio``; none if the tuning had too
    few pads), each agent, replace-on-failure and the oracle, priced at ``ratio``, cheapest
    first, with intervals."""
    costs = config.weights(ratio)
    runs: dict[PolicyId, tuple[oc.Outcomes, float | None]] = {ORACLE: (oc.oracle(pads), None)}
    if tuning.enough:
        for fam, p in tuning.best[ratio].items():
            runs[fam] = (tuned_outcomes(pads, fam, p), p)
    runs.update((k, (v, None)) for k, v in agents.items())
    runs[REPLACE_ON_FAILURE] = (oc.never(pads), None)
    cost = {k: float(oc.cost_per_1000(pads, out, costs)) for k, (out, _) in runs.items()}
    order = sorted(runs, key=lambda k: cost[k])  # stable: the oracle wins a tie
    outs = [runs[k][0] for k in order]
    ood = _ood_pair(order, config.ood_pair)
    fig = _Figures.of(_intervals(pads, outs, costs, ood, config, seed), len(order), ood)
    rows = {
        k: _row(pads, runs[k][0], runs[k][1], k, (fig.cost[i], fig.ratio[i]), config.level)
        for i, k in enumerate(order)
    }
    gaps = tuple(Gap(a, b, d) for a, b, d in zip(order[:-1], order[1:], fig.gap, strict=True))
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
        ood_pair=config.ood_pair,
        ood_failure_gap=fig.ood_gap,
    )


def _ood_pair(order: list[PolicyId], pair: tuple[str, str]) -> tuple[int, int] | None:
    """Where the best policies of the two predictors of ``pair`` are in ``order``."""
    first: dict[str, int] = {}
    for i, k in enumerate(order):
        if k.predictor in pair and k.predictor not in first:
            first[k.predictor] = i
    return (first[pair[0]], first[pair[1]]) if len(first) == 2 else None


@dataclass(frozen=True)
class _Figures:
    """The figures of :func:`_intervals` by name: each policy's cost per 1000 events and
    ratio to the oracle, the gaps between neighbours, the OOD failure gap."""

    cost: list[Estimate]
    ratio: list[Estimate]
    gap: list[Estimate]
    ood_gap: Estimate | None

    @classmethod
    def of(cls, iv: Intervals, n: int, ood: tuple[int, int] | None) -> _Figures:
        est = [Estimate(*iv[i]) for i in range(len(iv.point))]
        ratio = [Estimate.exact(1.0), *est[n + 1 : 2 * n]]  # the oracle's own is exact
        return cls(est[:n], ratio, est[2 * n : 3 * n - 1], est[3 * n - 1] if ood else None)


def _intervals(
    pads: PadSet,
    outs: list[oc.Outcomes],
    costs: oc.CostWeights,
    ood: tuple[int, int] | None,
    config: StudyConfig,
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
    figures: tuple[Estimate, Estimate],
    level: float,
) -> PolicyRow:
    never = parameter is not None and (parameter == 0 or np.isinf(parameter))
    note = "never replaces: tuning fell back to replace-on-failure" if never else ""
    return PolicyRow(
        parameter=parameter,
        cost_per_1000_events=figures[0],
        ratio_to_oracle=figures[1],
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
    groups: dict[str, tuple[str, ...]] = {k: (k,) for k in LABELS}
    groups["ood"] = OOD_LABELS
    for name, labels in groups.items():
        idx = [strata[k] for k in labels if k in strata]
        if not idx:
            res[name] = Estimate.exact(float("nan"))
            continue
        fails = out.failed[np.concatenate(idx)]
        ci = binomtest(int(fails.sum()), fails.size).proportion_ci(level, method="exact")
        res[name] = Estimate(100.0 * fails.mean(), 100.0 * ci.low, 100.0 * ci.high)
    return res
