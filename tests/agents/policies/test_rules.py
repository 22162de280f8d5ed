"""Rule-based policies and the cost evaluator."""

from __future__ import annotations

import json

import numpy as np
import pytest

from agents.policies.rules import (
    AGE_INDEX,
    FixedInterval,
    Policy,
    PolicyId,
    ReplaceOnFailure,
    RULThreshold,
)
from agents.study.episodes import compare_policies, oracle_policy, run_episodes, summary_rows
from brake_env.env.brake_wear import BrakeWearEnv
from brake_env.env.wrappers import RULObservation
from brake_env.prognostics.protocol import NoPrognostics

FAST = {"k_mean": 1e-5, "k_std": 1e-6, "decision_interval": 500, "episode_events": 100_000}


def test_rules_follow_sb3_predict_for_one_obs_and_a_batch():
    obs = np.zeros((3, 8), dtype=np.float32)
    obs[:, AGE_INDEX] = [10, 1000, 5000]
    obs[:, -1] = [100, 600, 5000]
    a, state = FixedInterval(1000).predict(obs)
    assert a.tolist() == [0, 1, 1] and state is None
    assert RULThreshold(500).predict(obs)[0].tolist() == [1, 0, 0]
    assert ReplaceOnFailure().predict(obs)[0].tolist() == [0, 0, 0]
    single, _ = FixedInterval(1000).predict(obs[1])
    assert single.shape == () and int(single) == 1
    for rule in (FixedInterval(1), RULThreshold(1), ReplaceOnFailure()):
        assert isinstance(rule, Policy)


def test_rule_arguments_are_checked():
    with pytest.raises(ValueError, match="interval_events must be > 0"):
        FixedInterval(0)
    with pytest.raises(ValueError, match="threshold_events must be >= 0"):
        RULThreshold(-1)
    with pytest.raises(ValueError, match="wrap the env in RULObservation"):
        RULThreshold(10).predict(np.zeros(7))


def test_replace_on_failure_report_counts_every_pad_as_failed(atlas):
    r = run_episodes(ReplaceOnFailure(), BrakeWearEnv(atlas=atlas, **FAST), [0, 1])
    assert r.events == 2 * FAST["episode_events"]
    assert r.failures > 0 and r.planned_replacements == 0
    assert r.failures_per_100_pads == 100.0 and r.mean_unused_life_frac == 0.0
    # Default weights: a failure costs 1000 + 4000 + 5000.
    assert r.cost == pytest.approx(10_000.0 * r.failures)


def test_oracle_is_cheapest_and_ratios_are_relative_to_it(atlas):
    def make():
        return BrakeWearEnv(atlas=atlas, regime="mixed", **FAST)

    entries = {
        "replace-on-failure": (ReplaceOnFailure(), make()),
        "fixed": (FixedInterval(15_000), make()),
        "none": (RULThreshold(500), RULObservation(make(), NoPrognostics(2.4e4))),
    }
    reports = compare_policies(entries, seeds=[0, 1, 2], make_env=make)
    oracle = reports["oracle"]
    assert oracle.ratio_to_oracle == 1.0 and oracle.failures == 0
    for name, r in reports.items():
        assert r.cost >= oracle.cost, name
        assert r.ratio_to_oracle == pytest.approx(r.cost / oracle.cost)
    # Replacing with the true RUL wastes less than one decision interval of each pad.
    assert max(pad.life_left for pad in oracle.retired) < FAST["decision_interval"]
    assert summary_rows(reports)[1][0] == "oracle"
    json.dumps({k: r.to_dict() for k, r in reports.items()})
    lo, hi = oracle.interval()
    assert lo <= oracle.cost_per_1000_events <= hi


def test_same_seeds_same_report(atlas):
    a = run_episodes(*oracle_policy(BrakeWearEnv(atlas=atlas, **FAST)), seeds=[4])
    b = run_episodes(*oracle_policy(BrakeWearEnv(atlas=atlas, **FAST)), seeds=[4])
    assert a.cost == b.cost and a.retired == b.retired


def test_policy_ids_label_and_group_policies():
    candidate = PolicyId("threshold", "twin", parameter=1000.0)
    assert candidate.label == str(candidate) == "twin/threshold/1000"
    assert candidate.family == PolicyId("threshold", "twin")
    assert candidate.family.label == "twin/threshold"
    assert PolicyId("threshold", "data", parameter=750.5).label == "data/threshold/750.5"
    assert PolicyId("fixed-interval", parameter=65_000.0).label == "fixed-interval/65000"
    assert PolicyId("agent", "twin", algo="ppo").label == "twin/ppo"
    assert PolicyId("oracle").label == "oracle"
    assert PolicyId("replace-on-failure").label == "replace-on-failure"
    # Hashable and equal by value: the keys of the comparison's reports.
    assert len({candidate, PolicyId("threshold", "twin", parameter=1000.0)}) == 1


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"kind": "threshold"}, "have a predictor"),
        ({"kind": "oracle", "predictor": "twin"}, "have a predictor"),
        ({"kind": "agent", "predictor": "twin"}, "have an algo"),
        ({"kind": "agent", "predictor": "twin", "algo": "ppo", "parameter": 1.0}, "no parameter"),
        ({"kind": "crystal-ball"}, "kind must be one of"),
    ],
)
def test_policy_ids_are_validated(kwargs, message):
    with pytest.raises(ValueError, match=message):
        PolicyId(**kwargs)
