"""The cost study's arithmetic on constructed pads: outcomes of rules against a per-pad
reference loop, tuning, the never-replace fallback and the bootstrap intervals."""

from __future__ import annotations

import numpy as np
import pytest

from agents.policies.rules import PolicyId
from agents.study import outcomes as oc
from agents.study.bootstrap import bootstrap_figures
from agents.study.config import StudyConfig
from agents.study.pads import PadDraws, PadSet
from agents.study.ranking import rank_policies
from agents.study.tuning import tune
from brake_env.env.config import CostWeights, EnvConfig

D = 100  # decision interval of the constructed pads [events]


def constructed(lives, labels=None, estimates=None, first=None) -> PadSet:
    """Pads of the given lives decided on every D events from ``first`` (default D); the
    oracle's estimate is the true RUL, ``estimates`` name -> f(true RUL, pad) add others."""
    lives = np.asarray(lives, dtype=np.int64)
    n = len(lives)
    labels = np.asarray(labels if labels is not None else ["id"] * n)
    first = np.full(n, D, dtype=np.int64) if first is None else np.asarray(first, np.int64)
    counts = np.where(lives >= first, (lives - first) // D + 1, 0)
    starts = np.r_[0, np.cumsum(counts)].astype(np.int64)
    weights = {k: 1.0 / len(set(labels)) for k in dict.fromkeys(labels.tolist())}
    draws = PadDraws(np.ones(n), labels, np.arange(n, dtype=np.int64), weights)
    pads = PadSet(draws, D, first, lives, starts, np.zeros((starts[-1], 6)), {})
    truth = (np.repeat(lives, counts) - pads.age).astype(np.float64)
    pads.estimates["oracle"] = {"rul_mean": truth}
    for name, f in (estimates or {}).items():
        pads.estimates[name] = {"rul_mean": f(truth, pads.pad_of_row)}
    return pads


def reference_threshold(pads: PadSet, values, h):
    """A per-pad loop: replace at the first decision whose float32 estimate is below h."""
    events, failed = [], []
    for i in range(len(pads)):
        a, b = pads.starts[i], pads.starts[i + 1]
        seen = np.clip(values[a:b], 0, 1e7).astype(np.float32)
        hit = np.flatnonzero(seen < h)
        if hit.size:
            events.append(pads.first[i] + hit[0] * D)
            failed.append(False)
        else:
            events.append(pads.life[i])
            failed.append(True)
    return np.array(events), np.array(failed)


def test_rule_outcomes_equal_a_per_pad_loop():
    rng = np.random.default_rng(0)
    lives = rng.integers(250, 4000, 60)
    pads = constructed(lives, first=rng.integers(1, 2 * D, 60))
    noisy = pads.estimates["oracle"]["rul_mean"] * rng.lognormal(0, 0.3, pads.starts[-1])
    thresholds = np.array([0.0, 50.0, 100.0, 150.5, 400.0, 1e9])
    out = oc.threshold_outcomes(pads, noisy, thresholds)
    for j, h in enumerate(thresholds):
        events, failed = reference_threshold(pads, noisy, h)
        assert np.array_equal(out.events[j], events) and np.array_equal(out.failed[j], failed)
    assert out.failed[0].all()  # threshold 0: never replaces
    ages = np.array([1.0, 333.0, 1000.0, np.inf])
    fixed = oc.fixed_interval_outcomes(pads, ages)
    for j, a in enumerate(ages):
        age = pads.first + np.maximum(np.ceil((a - pads.first) / D), 0) * D
        planned = age <= pads.life
        assert np.array_equal(fixed.failed[j], ~planned)
        assert np.array_equal(fixed.events[j], np.where(planned, age, pads.life))


def test_the_oracle_never_fails_and_wastes_less_than_one_step():
    pads = constructed([150, 199, 200, 201, 999, 1000, 1001])
    out = oc.oracle(pads)
    assert not out.failed.any()
    left = pads.life - out.events
    assert np.all((left >= 0) & (left < D))


def test_cost_rate_is_a_ratio_of_mixture_means():
    pads = constructed([200, 400, 1000, 3000], labels=["id", "id", "ood-slow", "ood-fast"])
    out = oc.Outcomes(np.array([200, 300, 1000, 2000]), np.array([True, False, True, False]))
    w = CostWeights()
    cost = np.array([w.failure, w.planned_replacement, w.failure, w.planned_replacement])
    # weights: 1/3 each label (as constructed); id has two pads
    num = (cost[:2].mean() + cost[2] + cost[3]) / 3
    den = (np.mean([200, 300]) + 1000 + 2000) / 3
    assert oc.cost_per_1000(pads, out, w) == pytest.approx(1000 * num / den)


def test_tuning_picks_the_cheapest_threshold_and_can_fall_back_to_never():
    rng = np.random.default_rng(1)
    lives = rng.integers(2000, 6000, 300)
    # "physics" here estimates 3 steps too much: the best threshold is 4 steps, not 1;
    # "none" estimates a constant: no threshold beats never replacing. (Constructed
    # estimates under registered names.)
    pads = constructed(
        lives,
        estimates={"physics": lambda t, p: t + 3 * D, "none": lambda t, p: np.full(t.shape, 1e5)},
    )
    config = StudyConfig(
        predictors=("physics", "none", "oracle"),
        agent_predictors=(),
        env=EnvConfig(regime="mixed", decision_interval=D),
        thresholds=(0.0, 0.996, 1.0, 2.0, 3.0, 4.0, 5.0, 8.0),
        ages=(0.5, 1.0),
        min_tune_pads=1,
        n_resamples=300,
    )
    tuning = tune(config, pads, id_life=3000.0)
    for r, best in tuning.best.items():
        for fam, p in best.items():
            curve = tuning.curves[r][fam]
            grid = tuning.parameters[fam]
            assert curve[list(grid).index(p)] == curve.min()
            assert p == grid[int(np.argmin(curve))]  # the first of equals
    best = tuning.best[10.0]
    assert best[PolicyId("threshold", "physics")] == 4 * D
    # 0.996 and 1 decision interval act alike on integer RULs: the cautious one is kept.
    assert best[PolicyId("threshold", "oracle")] == 1 * D
    assert best[PolicyId("threshold", "none")] == 0  # never: replace-on-failure
    ranked = rank_policies(config, pads, tuning, {}, 10.0)
    blind = ranked.policies[PolicyId("threshold", "none")]
    rof = ranked.policies[PolicyId("replace-on-failure")]
    assert blind.ratio_to_oracle == rof.ratio_to_oracle and "never" in blind.note
    pair = {PolicyId("threshold", "none"), PolicyId("replace-on-failure")}
    (gap,) = [g for g in ranked.gaps if {g.cheaper, g.dearer} == pair]  # equal: adjacent
    assert not gap.significant and gap.difference.point == 0


def test_bootstrap_intervals_hold_the_estimate_and_never_go_below_the_oracle():
    rng = np.random.default_rng(2)
    lives = rng.integers(800, 5000, 120)
    labels = np.array(["id", "ood-slow", "ood-fast"] * 40)
    pads = constructed(lives, labels, {"data": lambda t, p: t * rng.lognormal(0, 0.5, t.size)})
    config = StudyConfig(
        predictors=("data",),
        agent_predictors=(),
        env=EnvConfig(regime="mixed", decision_interval=D),
        thresholds=(0.0, 1.0, 2.0, 4.0, 8.0),
        ages=(0.2, 0.5),
        min_tune_pads=1,
        n_resamples=500,
    )
    for ratio in (5.0, 10.0, 200.0):
        ranked = rank_policies(config, pads, tune(config, pads, 3000.0), {}, ratio)
        for p, row in ranked.policies.items():
            r = row.ratio_to_oracle
            assert r.low <= r.point <= r.high, p
            assert r.low >= 1.0 - 1e-12, p  # the oracle is the cheapest on every resample
            c = row.cost_per_1000_events
            assert 0 <= c.low <= c.point <= c.high
            for e in row.failures_per_100_pads.values():
                assert np.isnan(e.point) or 0 <= e.low <= e.point <= e.high <= 100
        for g in ranked.gaps:
            assert g.difference.low <= g.difference.point <= g.difference.high
            assert g.difference.point >= 0  # ranked cheapest first


def test_bootstrap_is_paired_over_pads():
    pads = constructed(np.arange(1000, 1100), labels=["id"] * 100)
    x = np.random.default_rng(3).normal(10.0, 1.0, 100)
    # The same pad-level noise in both: their ratio is exactly 2 on every resample.
    iv = bootstrap_figures(pads, np.stack([x, 2 * x]), lambda m: m[..., 1:] / m[..., :1])
    assert iv[0] == (2.0, 2.0, 2.0)
    iv = bootstrap_figures(pads, np.stack([x]), lambda m: m, n_resamples=2000, seed=1)
    point, lo, hi = iv[0]
    assert point == pytest.approx(x.mean()) and lo < point < hi
    assert hi - lo == pytest.approx(2 * 1.96 * x.std() / 10, rel=0.2)
    with pytest.raises(ValueError, match="variables must be"):
        bootstrap_figures(pads, x[None, :50], lambda m: m)
