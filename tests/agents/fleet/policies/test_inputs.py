"""Every numeric input of the Lagrangian bound, the rollout planner and the price-directed
policy checked where it enters (issue 44, item 4): ranges, finiteness, shapes, the config a
policy was built for, and a size check before a large allocation; each case of the issue's
"silent wrong" and "other exceptions" lists refused with one ValueError naming the argument
and value. The cases that must keep working (a fleet whose K spread is a quarter of its
mean) are shown to work."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from agents.fleet.policies.lagrangian import BoundModel, Prices, bound, solve, start_counts
from agents.fleet.policies.lagrangian_search import search
from agents.fleet.policies.planning import PlanningModel
from agents.fleet.policies.priced import PricedPolicy
from agents.fleet.policies.rollout import RolloutPolicy
from agents.fleet.policies.rules import FleetRule, FleetRuleParams
from agents.fleet.policies.view import FleetLayout
from brake_env.env.fleet.config import SMALL_FLEET, FleetConfig
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.spaces import FLEET_FEATURES, N_VF
from brake_env.env.fleet.wrappers import ExpectedRULObservation

SMALL = FleetConfig(**{**SMALL_FLEET, "episode_shifts": 12})
RULE = FleetRuleParams(must=3, window_limit=20, shop_limit=15, greedy=True, duty="rul")


@pytest.fixture(scope="module")
def bound_model(atlas) -> BoundModel:
    return BoundModel.build(SMALL, atlas, units=4)


@pytest.fixture(scope="module")
def planner(atlas):
    env = ExpectedRULObservation(BrakeWearFleetEnv(SMALL, atlas=atlas))
    return env, PlanningModel.build(SMALL, atlas), FleetRule(FleetLayout.of(SMALL), RULE)


# ------------------------------------------------------------------------- the bound
@pytest.mark.parametrize(
    ("kwargs", "names"),
    [
        ({"units": 1.5}, "units must be an integer.*1.5"),
        ({"units": 0}, "units must be an integer >= 1, got 0"),
        ({"units": float("nan")}, "units must be an integer.*nan"),
        ({"slack_shifts": -5}, "slack_shifts must be >= 0.*-5"),
        ({"slack_shifts": float("nan")}, "slack_shifts must be a finite number, got nan"),
        ({"slack_shifts": float("inf")}, "slack_shifts must be a finite number, got inf"),
    ],
)
def test_bound_model_refuses_bad_arguments(atlas, kwargs, names):
    with pytest.raises(ValueError, match=names):
        BoundModel.build(SMALL, atlas, **kwargs)


def test_a_bound_too_large_for_memory_is_refused_before_it_allocates(atlas):
    long = dataclasses.replace(SMALL, episode_shifts=5000)
    with pytest.raises(ValueError, match=r"would allocate \d+\.\d GiB.*units"):
        BoundModel.build(long, atlas, units=20)
    BoundModel.build(long, atlas, units=1)  # the same horizon at a coarser clock fits


@pytest.mark.parametrize("field", ["hot", "work", "bay", "crew"])
def test_nan_prices_are_refused_naming_the_price_and_shift(bound_model, field):
    z = Prices.zeros(SMALL)
    bad = getattr(z, field).copy()
    bad[3] = np.nan
    with pytest.raises(
        ValueError, match=rf"prices\.{field} must be finite, got nan at index \(3,\)"
    ):
        solve(bound_model, dataclasses.replace(z, **{field: bad}))


def test_prices_of_another_length_are_refused(bound_model):
    z = Prices.zeros(SMALL)
    short = dataclasses.replace(z, hot=np.zeros(5))
    with pytest.raises(ValueError, match=r"prices\.hot has shape \(5,\), expected \(12,\)"):
        solve(bound_model, short)
    program = solve(bound_model, z)
    with pytest.raises(ValueError, match=r"prices\.hot has shape \(5,\)"):
        bound(bound_model, program, short, start_counts(bound_model, np.array([3, 4])))


def test_start_counts_and_states_out_of_range_are_refused(bound_model):
    H = bound_model.H
    with pytest.raises(ValueError, match=rf"states must be integers in \[0, {H}\], got {H + 1}"):
        start_counts(bound_model, np.array([1, H + 1]))
    with pytest.raises(ValueError, match=r"states must be integers in .*got -1"):
        start_counts(bound_model, np.array([-1, 2]))
    with pytest.raises(ValueError, match=r"states must be integers.*1.5"):
        start_counts(bound_model, np.array([1.5, 2.0]))
    program = solve(bound_model, Prices.zeros(SMALL))
    z = Prices.zeros(SMALL)
    with pytest.raises(ValueError, match=rf"start has shape \(3,\), expected \({H + 1},\)"):
        bound(bound_model, program, z, np.ones(3))
    start = start_counts(bound_model, np.array([2, 3]))
    start[0] = np.nan
    with pytest.raises(ValueError, match="start must be finite, got nan"):
        bound(bound_model, program, z, start)


@pytest.mark.parametrize(
    ("kwargs", "names"),
    [({"iterations": -1}, "iterations must be an integer >= 0, got -1"),
     ({"iterations": 2.5}, "iterations must be an integer.*2.5"),
     ({"step": float("nan")}, "step must be a finite number, got nan"),
     ({"step": 0.0}, r"step must be >= 1e-12")],
)  # fmt: skip
def test_the_search_refuses_bad_arguments(bound_model, kwargs, names):
    with pytest.raises(ValueError, match=names):
        search(bound_model, start_counts(bound_model, np.array([3, 4])), **kwargs)


# ----------------------------------------------------------------------- the planner
@pytest.mark.parametrize(
    ("kwargs", "names"),
    [
        ({"confidence": float("nan")}, "confidence must be a finite number, got nan"),
        ({"confidence": -1.0}, "confidence must be >= 0.*-1.0"),
        ({"samples": 1.5}, "samples must be an integer.*1.5"),
        ({"samples": 0}, r"samples must be an integer in \[1, "),
        ({"horizon": float("nan")}, "horizon must be an integer.*nan"),
        ({"horizon": 0}, r"horizon must be an integer in \[1, "),
        ({"seed": -1}, "seed must be an integer >= 0, got -1"),
        ({"service_below": float("nan")}, "service_below must be a number.*nan|finite.*nan"),
        ({"samples": 10**6, "horizon": 10**4}, r"would allocate .* GiB"),
    ],
)
def test_the_rollout_planner_refuses_bad_arguments(planner, kwargs, names):
    _, model, base = planner
    with pytest.raises(ValueError, match=names):
        RolloutPolicy(base, model, **kwargs)


def test_the_rollout_planner_refuses_nan_ruls_naming_the_vehicle(planner):
    env, model, base = planner
    obs, _ = env.reset(seed=0)
    policy = RolloutPolicy(base, model, horizon=3, samples=4)
    policy.act(obs)  # a good observation is acted on
    lay = FleetLayout.of(SMALL)
    bad = obs.copy()
    # vehicle 1's hot RUL: after the vehicles' and fleet's features and vehicle 0's values
    col = lay.n_vehicles * N_VF + len(FLEET_FEATURES) + lay.per_vehicle
    col += lay.column("hot", "rul_mean")
    bad[col] = np.nan
    with pytest.raises(ValueError, match=r"RUL of vehicle 1 is nan"):
        policy.act(bad)


def test_a_planner_for_two_vehicles_refuses_a_twelve_vehicle_observation(planner, atlas):
    _, model, base = planner
    big = ExpectedRULObservation(BrakeWearFleetEnv(FleetConfig(episode_shifts=12), atlas=atlas))
    obs, _ = big.reset(seed=0)
    with pytest.raises(ValueError, match="observation"):
        RolloutPolicy(base, model, horizon=3, samples=4).act(obs)


def test_a_planning_model_on_a_wide_k_spread_the_env_accepts_is_built(atlas):
    wide = dataclasses.replace(SMALL, k_std=SMALL.k_mean / 4)
    BrakeWearFleetEnv(wide, atlas=atlas).reset(seed=0)  # the env takes it
    model = PlanningModel.build(wide, atlas)
    assert np.isfinite(model.r_mild).all() and model.r_mild.size > 1


# ------------------------------------------------------------------ the priced policy
@pytest.mark.parametrize(
    ("kwargs", "names"),
    [
        ({"s": 5, "S": 3}, r"s must be .*<= S.*got s=5, S=3"),
        ({"s": -1}, "s must be an integer >= 0, got -1"),
        ({"S": 2.5}, "S must be an integer.*2.5"),
        ({"must": float("nan")}, "must must be a finite number, got nan"),
        ({"must": -1.0}, "must must be >= 0"),
        ({"margin": float("nan")}, "margin must be a finite number, got nan"),
        ({"shop_limit": float("nan")}, "shop_limit must be a finite number, got nan"),
        ({"damping": float("nan")}, "damping must be a finite number, got nan"),
    ],
)
def test_the_priced_policy_refuses_bad_arguments(atlas, bound_model, kwargs, names):
    env = BrakeWearFleetEnv(SMALL, atlas=atlas)
    z = Prices.zeros(SMALL)
    with pytest.raises(ValueError, match=names):
        PricedPolicy(env, bound_model, z, solve(bound_model, z), **kwargs)


def test_a_priced_policy_for_two_vehicles_refuses_a_twelve_vehicle_env(atlas, bound_model):
    env = BrakeWearFleetEnv(FleetConfig(episode_shifts=12), atlas=atlas)
    z = Prices.zeros(SMALL)
    with pytest.raises(ValueError, match=r"built for another fleet config \(2 vehicles\).*\(12"):
        PricedPolicy(env, bound_model, z, solve(bound_model, z))
