"""Fleet costs, paired intervals and tuning (agents.fleet.evaluation.costs, fleet_tuning)."""

from __future__ import annotations

import numpy as np
import pytest

from agents.fleet.evaluation.costs import (
    figures,
    paired_interval,
    run_episode,
    run_episodes,
    term_means,
)
from agents.fleet.evaluation.tuning import SPACES, tune
from agents.fleet.policies.view import FleetLayout
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.wrappers import ExpectedRULObservation


def test_paired_interval_difference_and_ratio():
    rng = np.random.default_rng(0)
    b = rng.uniform(5, 10, 30)
    a = b * 1.2 + rng.normal(0, 0.1, 30)
    d = paired_interval(a, b, "difference")
    r = paired_interval(a, b, "ratio")
    assert d.low < d.point < d.high and d.low > 0
    assert r.low < 1.2 < r.high and r.point == pytest.approx(a.mean() / b.mean())
    same = paired_interval(b, b, "difference")
    assert (same.point, same.low, same.high) == (0.0, 0.0, 0.0)
    with pytest.raises(ValueError, match="one length"):
        paired_interval(a, b[:-1])
    with pytest.raises(ValueError, match="statistic"):
        paired_interval(a, b, "t")  # type: ignore[arg-type]


@pytest.fixture(scope="module")
def tiny():
    cfg = FleetConfig(
        n_vehicles=2, hot_need=1, mild_need=1, episode_shifts=30, k_mean=1e-5, k_std=1e-6
    )
    return ExpectedRULObservation(BrakeWearFleetEnv(cfg)), FleetLayout.of(cfg)


def test_episode_costs_add_up(tiny):
    env, layout = tiny
    rule = SPACES["threshold"](_Fixed({"threshold": 5.0}), layout, 14)
    ep = run_episode(env, rule, seed=1)
    assert ep.shifts == 30 and ep.billed == pytest.approx(ep.total / 60)
    # pads priced when fitted instead of ordered
    fitted = ep.total - ep.terms["pad"] + ep.pad_price * ep.fits
    assert ep.per_vehicle_shift == pytest.approx(fitted / 60)
    assert ep.model_terms <= ep.per_vehicle_shift
    # the terms, pads priced when fitted, add up to the headline figure
    eps = [ep, run_episode(env, rule, seed=2)]
    terms = term_means(eps)
    assert sum(terms.values()) == pytest.approx(np.mean([e.per_vehicle_shift for e in eps]))
    assert terms["pad"] == pytest.approx(np.mean([e.pad_price * e.fits / 60 for e in eps]))


def test_tuning_is_deterministic_for_a_seed(tiny):
    env, layout = tiny
    a = tune("time-to-window", env, layout, seeds=[7], n_trials=3, sampler_seed=4)
    b = tune("time-to-window", env, layout, seeds=[7], n_trials=3, sampler_seed=4)
    assert a.params == b.params and a.tuning_cost == b.tuning_cost
    assert a.rule.params == b.rule.params
    with pytest.raises(ValueError, match="unknown heuristic"):
        tune("magic", env, layout, seeds=[7], n_trials=1)


def test_tuning_on_the_net_cost_minimises_the_net_cost(tiny):
    """The net objective is the mean net cost of the tuned rule on the tuning seeds, the
    headline objective its mean headline cost: each is what its trials minimised."""
    env, layout = tiny
    seeds = [7, 8]
    net = tune("threshold", env, layout, seeds=seeds, n_trials=4, sampler_seed=1, objective="net")
    eps = run_episodes(env, net.rule, seeds)
    assert net.tuning_cost == pytest.approx(np.mean([e.net for e in eps]))
    assert net.tuning_cost == pytest.approx(figures(eps, "net").mean())
    gross = tune("threshold", env, layout, seeds=seeds, n_trials=4, sampler_seed=1)
    eps = run_episodes(env, gross.rule, seeds)
    assert gross.tuning_cost == pytest.approx(np.mean([e.per_vehicle_shift for e in eps]))
    # pads left with life at the end are credited: the net figure is the lower one
    assert all(e.life_value > 0 and e.net < e.per_vehicle_shift for e in eps)
    with pytest.raises(ValueError, match="objective must be one of"):
        figures(eps, "gross")  # type: ignore[arg-type]


class _Fixed:
    """A stand-in for an Optuna trial with fixed values (no optuna needed)."""

    def __init__(self, values: dict) -> None:
        self.values = values

    def suggest_float(self, name: str, low: float, high: float) -> float:
        return self.values[name]

    def suggest_int(self, name: str, low: int, high: int) -> int:
        return self.values[name]

    def suggest_categorical(self, name: str, choices: list) -> object:
        return self.values[name]
