"""BrakeWearFleet-v0: checkers, determinism across processes, pickling, masks, the capacity
rule, costs, stock arithmetic, validation and rendering."""

from __future__ import annotations

import os
import pickle
import subprocess
import sys
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import brake_env  # noqa: F401  (registers BrakeWearFleet-v0)
from brake_env.env.fleet.config import FleetConfig, FleetCosts
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.routes import HOT as HOT_ROUTE
from brake_env.env.fleet.routes import MILD as MILD_ROUTE
from brake_env.env.fleet.routes import route_mean
from brake_env.env.fleet.shop import HOT, MILD, PARK, SERVICE
from brake_env.env.fleet.spaces import FLEET_FEATURES, VEHICLE_FEATURES, split_observation
from tests.brake_env.env.fleet.small import SMALL


@pytest.fixture(scope="module")
def make(atlas):
    def _make(**kw):
        return BrakeWearFleetEnv(atlas=atlas, **{**SMALL, **kw})

    return _make


def act(*duties: int, order: int = 0) -> np.ndarray:
    return np.array([*duties, order], dtype=np.int64)


def test_gymnasium_and_sb3_checkers(make) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        gym_check_env(make())
        sb3_check_env(make())


def test_registered_with_defaults() -> None:
    env = gym.make("BrakeWearFleet-v0", **SMALL)
    obs, _ = env.reset(seed=0)
    assert obs.shape == (10 * 3 + 5,)
    assert env.action_space.nvec.tolist() == [4, 4, 4, 9]
    assert len(VEHICLE_FEATURES) == 10 and len(FLEET_FEATURES) == 5


def _episode_digest(env: BrakeWearFleetEnv, seed: int, steps: int) -> list[float]:
    obs, _ = env.reset(seed=seed)
    rng = np.random.default_rng(7)
    out = [float(obs.sum())]
    for _ in range(steps):
        mask = env.action_masks()
        a = [int(rng.choice(np.flatnonzero(mask[4 * v : 4 * v + 4]))) for v in range(3)]
        obs, r, _, _, _ = env.step(act(*a, order=int(rng.integers(3))))
        out += [float(obs.sum()), float(r)]
    return out


_SCRIPT = """
import numpy as np
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.routes import HOT as HOT_ROUTE
from brake_env.env.fleet.routes import MILD as MILD_ROUTE
from brake_env.env.fleet.routes import route_mean
from tests.brake_env.env.fleet.small import SMALL
from tests.brake_env.env.fleet.test_fleet_env import _episode_digest
print(repr(_episode_digest(BrakeWearFleetEnv(**SMALL), 5, 30)))
"""


def test_same_seed_same_episode_in_two_processes(make) -> None:
    """This process and a fresh one (with its own hash seed) give the same episode."""
    here = _episode_digest(make(), 5, 30)
    env = {**os.environ, "PYTHONHASHSEED": "random"}
    run = subprocess.run(
        [sys.executable, "-c", _SCRIPT], capture_output=True, text=True, check=True, env=env
    ).stdout
    assert run == repr(here) + "\n"
    assert _episode_digest(make(), 6, 30) != here


def test_pickle_round_trip_continues_identically(make) -> None:
    env = make()
    env.reset(seed=3)
    for _ in range(5):
        env.step(act(HOT, MILD, PARK, order=1))
    twin = pickle.loads(pickle.dumps(env))
    for _ in range(10):
        a = act(HOT, MILD, HOT, order=1)
        o1, r1, *_ = env.step(a)
        o2, r2, *_ = twin.step(a)
        np.testing.assert_array_equal(o1, o2)
        assert r1 == r2


def test_masks_block_duties_in_windows_and_while_down(make) -> None:
    env = make(window_period=4, breakdown_rate=0.0)
    env.reset(seed=0)
    for _ in range(3):
        m = env.action_masks().reshape(-1)[: 4 * 3].reshape(3, 4)
        assert m[:, [HOT, MILD]].all()  # working shifts
        env.step(act(HOT, MILD, PARK))
    assert env.config.is_window(env.shift)
    m = env.action_masks()[:12].reshape(3, 4)
    assert not m[:, [HOT, MILD]].any() and m[:, PARK].all() and m[:, SERVICE].all()
    _, _, _, _, info = env.step(act(HOT, MILD, PARK))  # mask ignored: refused, reported
    assert info["refused"] == [(0, "hot", "window"), (1, "mild", "window")]
    assert info["counts"]["refused"] == 2 and info["counts"]["events"] == 0


def test_masked_random_policy_is_never_refused(make) -> None:
    env = make(window_period=5, breakdown_rate=0.2, initial_stock=1, bays=1)
    env.reset(seed=1)
    rng = np.random.default_rng(0)
    for _ in range(40):
        mask = env.action_masks()
        a = [int(rng.choice(np.flatnonzero(mask[4 * v : 4 * v + 4]))) for v in range(3)]
        _, _, _, _, info = env.step(act(*a))
        assert info["refused"] == []
    assert len(env.action_masks()) == int(env.action_space.nvec.sum())


def test_no_spare_masks_service(make) -> None:
    env = make(initial_stock=0)
    env.reset(seed=0)
    assert not env.action_masks()[:12].reshape(3, 4)[:, SERVICE].any()
    age = env.truth()["pad_age"]
    _, _, _, _, info = env.step(act(SERVICE, SERVICE, HOT))
    first = 0 if (age[0], -0) >= (age[1], -1) else 1
    assert info["deferred"] == [(first, "spare"), (1 - first, "spare")]
    assert info["counts"]["deferred"] == 2 and info["vehicles"]["route"][:2].tolist() == [-1, -1]


def test_requests_beyond_bays_are_deferred_oldest_pad_first(make) -> None:
    costs = FleetCosts(deferred=10.0)
    env = make(bays=1, initial_stock=5, costs=costs, breakdown_rate=0.0)
    env.reset(seed=2)
    age = env.truth()["pad_age"]
    _, _, _, _, info = env.step(act(SERVICE, SERVICE, SERVICE))
    served = int(np.argmax(age))
    assert info["vehicles"]["replaced"].tolist() == [v == served for v in range(3)]
    order = [v for v in np.lexsort((np.arange(3), -age)) if v != served]
    assert info["deferred"] == [(int(v), "bay") for v in order]
    assert info["counts"]["visits"] == 1 and info["counts"]["deferred"] == 2
    assert info["costs"]["deferred"] == 20.0
    assert info["costs"]["shop_visit"] == env.config.costs.shop_visit
    assert info["costs"]["labour"] == env.config.costs.labour
    assert info["counts"]["stock"] == 4 and env.truth()["pad_age"][served] == 0


def test_window_crew_fits_window_slots_and_defers_the_rest(make) -> None:
    env = make(window_period=2, initial_stock=3, window_slots=1, breakdown_rate=0.0)
    env.reset(seed=3)
    env.step(act(HOT, MILD, PARK))
    age = env.truth()["pad_age"]
    _, _, _, _, info = env.step(act(SERVICE, SERVICE, SERVICE))
    order = [int(v) for v in np.lexsort((np.arange(3), -age))]  # most worn first
    assert info["window"] and info["counts"]["window_fits"] == 1
    assert info["vehicles"]["replaced"].tolist() == [v == order[0] for v in range(3)]
    assert info["deferred"] == [(v, "crew") for v in order[1:]]
    assert env.shop.stock == 2  # a deferred request takes no spare


def test_shortfall_counts_hot_then_mild_need(make) -> None:
    env = make(n_vehicles=4, hot_need=2, mild_need=1, window_period=10_000, breakdown_rate=0.0)
    w = env.config.costs
    env.reset(seed=0)
    cases = {  # duties -> (hot short, mild short)
        (HOT, HOT, MILD, PARK): (0, 0),
        (HOT, PARK, PARK, PARK): (1, 1),
        (HOT, HOT, HOT, PARK): (0, 0),  # an extra ramp truck covers the drift
        (MILD, MILD, MILD, PARK): (2, 0),
        (PARK, PARK, PARK, PARK): (2, 1),
    }
    for duties, (hot, mild) in cases.items():
        _, _, _, _, info = env.step(np.array([*duties, 0]))
        assert (info["counts"]["shortfall"], info["counts"]["mild_shortfall"]) == (hot, mild)
        assert info["costs"]["shortfall"] == hot * w.shortfall
        assert info["costs"]["mild_shortfall"] == mild * w.mild_shortfall


def test_window_fits_cost_labour_only(make) -> None:
    env = make(window_period=2, initial_stock=3)
    env.reset(seed=0)
    env.step(act(HOT, MILD, PARK))
    _, r, _, _, info = env.step(act(SERVICE, SERVICE, PARK))
    assert info["window"] and info["counts"]["window_fits"] == 2
    assert info["costs"]["labour"] == 2 * env.config.costs.labour
    assert info["costs"]["shop_visit"] == 0.0 and info["costs"]["shortfall"] == 0.0
    assert info["costs"]["mild_shortfall"] == 0.0  # nobody works in a window
    assert r == -sum(info["costs"].values())


def test_failure_costs_damage_downtime_and_shortfall(make) -> None:
    env = make(
        window_period=10_000, breakdown_rate=0.0, hot_need=3, mild_need=0, episode_shifts=200
    )
    env.reset(seed=4)
    totals = dict.fromkeys(env.config.costs.__dataclass_fields__, 0.0)
    failed_at = None
    for s in range(150):  # 15,000 events: more than a whole pad's life on the hot route
        _, _, _, _, info = env.step(act(HOT, HOT, HOT))
        for k, v in info["costs"].items():
            totals[k] += v
        if info["counts"]["failures"] and failed_at is None:
            failed_at, fail_info = s, info
    assert failed_at is not None, "a pad must fail within a whole life on the hot route"
    n = fail_info["counts"]["failures"]
    assert fail_info["costs"]["damage"] == n * env.config.costs.damage
    assert fail_info["counts"]["corrective_fits"] == n  # spares in stock: fitted at once
    assert totals["downtime"] >= env.config.failure_repair_shifts * env.config.costs.downtime
    assert totals["shortfall"] > 0  # the failed vehicle is missing from the ramp


def test_stock_and_lead_time_arithmetic(make) -> None:
    env = make(lead_time=3, initial_stock=2, breakdown_rate=0.0, window_period=10_000)
    env.reset(seed=0)
    w = env.config.costs
    _, _, _, _, info = env.step(act(PARK, PARK, PARK, order=5))
    assert info["costs"]["pad"] == 5 * w.pad and info["costs"]["order"] == w.order
    obs = env._observation()
    fleet = split_observation(obs, 3)[1]
    assert (fleet[2], fleet[3]) == (2, 5)  # stock, in transit
    env.step(act(PARK, PARK, PARK))
    assert env.shop.stock == 2
    _, _, _, _, info = env.step(act(PARK, PARK, PARK))  # shift 2 ends: shift 3 opens
    assert info["counts"]["arrived"] == 5 and env.shop.stock == 7 and env.shop.in_transit == 0
    assert info["costs"]["holding"] == pytest.approx(2 * w.holding)  # held during the shift


def test_hot_route_wears_faster_than_mild(make, atlas) -> None:
    env = make(n_vehicles=2, hot_need=0, initial_age_max=0.0, k_std=1e-12, window_period=10_000)
    env.reset(seed=0)
    for _ in range(20):
        env.step(np.array([HOT, MILD, 0]))
    t = env.truth()
    lost = (1.0 - t["volume_frac"]) / t["wear_coeff"]
    ratio = lost[0] / lost[1]
    expected = route_mean(atlas, HOT_ROUTE)[:3].mean() / route_mean(atlas, MILD_ROUTE)[0]
    assert ratio > 3.0  # measured ~4.7 on fresh pads (routes.py)
    assert ratio == pytest.approx(expected, rel=0.1)


def test_config_validation() -> None:
    with pytest.raises(ValueError, match="unknown argument"):
        FleetConfig.from_kwargs(n_vehicle=3)
    with pytest.raises(ValueError, match="hot_need"):
        FleetConfig(n_vehicles=2, hot_need=3)
    with pytest.raises(ValueError, match="mild_need"):
        FleetConfig(n_vehicles=4, hot_need=2, mild_need=3)
    with pytest.raises(ValueError, match="window_slots"):
        FleetConfig(window_slots=-1)
    with pytest.raises(ValueError, match="lead_time"):
        FleetConfig(lead_time=0)
    with pytest.raises(ValueError, match="breakdown_rate"):
        FleetConfig(breakdown_rate=1.5)
    with pytest.raises(ValueError, match="unknown parameter"):
        FleetConfig.from_kwargs(costs={"pads": 1.0})
    with pytest.raises(ValueError, match="must be >= 0"):
        FleetCosts(damage=-1.0)
    assert FleetConfig.from_kwargs(costs={"pad": 1.0}).costs.pad == 1.0


def test_bad_actions_raise_one_clear_error(make) -> None:
    env = make()
    env.reset(seed=0)
    with pytest.raises(ValueError, match="outside"):
        env.step(act(5, 0, 0))
    with pytest.raises(ValueError, match="integers"):
        env.step(np.zeros(2, dtype=np.int64))


def test_render_modes(make) -> None:
    env = make(render_mode="rgb_array")
    env.reset(seed=0)
    env.step(act(HOT, MILD, PARK))
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.shape == (40 + 16 * 3 + 8, 320, 3)
    env = make(render_mode="ansi")
    env.reset(seed=0)
    env.step(act(HOT, MILD, PARK))
    text = env.render()
    assert "stock" in text and len(text.splitlines()) == 4


def test_truncated_after_episode_shifts(make) -> None:
    env = make(episode_shifts=5)
    env.reset(seed=0)
    flags = [env.step(act(PARK, PARK, PARK))[3] for _ in range(5)]
    assert flags == [False] * 4 + [True]
    with pytest.raises(RuntimeError, match="over"):
        env.step(act(PARK, PARK, PARK))


def test_maskable_ppo_trains_and_honours_the_masks(make) -> None:
    """sb3-contrib's MaskablePPO takes the env's flat mask (tiny budget: a smoke test)."""
    sb3c = pytest.importorskip("sb3_contrib")
    env = make(window_period=4, episode_shifts=16)
    model = sb3c.MaskablePPO(
        "MlpPolicy", env, n_steps=32, batch_size=16, n_epochs=1, seed=0,
        policy_kwargs={"net_arch": [16]}, device="cpu",
    )  # fmt: skip
    model.learn(total_timesteps=64)
    obs, _ = env.reset(seed=0)
    for _ in range(16):
        action, _ = model.predict(obs, action_masks=env.action_masks(), deterministic=False)
        obs, _, _, truncated, info = env.step(action)
        assert info["refused"] == []  # masked duties are never chosen
        if truncated:
            break


def test_vehicle_in_the_shop_gets_pads_for_labour_only_and_takes_a_bay(make) -> None:
    env = make(breakdown_rate=0.99, bays=2, initial_stock=3, window_period=10_000)
    env.reset(seed=0)
    _, _, _, _, info = env.step(act(HOT, MILD, PARK))
    broke = info["vehicles"]["broke_down"]
    assert broke[:2].all() and not broke[2]  # a parked vehicle does not break down
    assert env.shop.free_bays() == 0  # both bays hold the broken vehicles
    mask = env.action_masks()[:12].reshape(3, 4)
    assert mask[:2, SERVICE].all() and not mask[2, SERVICE]  # no bay for a visit
    assert not mask[:2, [HOT, MILD]].any()
    _, _, _, _, info = env.step(act(SERVICE, PARK, SERVICE))
    assert info["counts"]["shop_fits"] == 1 and info["counts"]["visits"] == 0
    assert info["deferred"] == [(2, "bay")]
    assert info["costs"]["labour"] == env.config.costs.labour
    assert info["costs"]["shop_visit"] == 0.0


def test_a_vehicles_pads_do_not_depend_on_the_policy(make) -> None:
    """Common random numbers: vehicle v's n-th pad is the same whatever the others did."""
    ks = []
    for other in (PARK, SERVICE):  # vehicle 1 replaced or not before vehicle 0's visit
        env = make(initial_stock=5, breakdown_rate=0.0)
        env.reset(seed=8)
        env.step(act(PARK, other, PARK))
        env.step(act(SERVICE, PARK, PARK))
        ks.append(env.truth()["wear_coeff"][0])
        env.step(act(HOT, PARK, PARK))
        ks.append(env.truth()["volume_frac"][0])
    assert ks[0] == ks[2] and ks[1] == ks[3]


def test_an_unknown_keyword_is_a_type_error_as_torchrl_expects() -> None:
    """The fleet env's keywords are refused like BrakeWear-v0's (one check for both)."""
    with pytest.raises(TypeError, match="unexpected keyword argument 'frameskip'"):
        FleetConfig.from_kwargs(frameskip=1)
