"""BrakeWearFleet-v0's PettingZoo version and its RUL observation wrapper."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.route_rul import duty_clocks
from brake_env.env.fleet.wrappers import FleetRULObservation
from brake_env.prognostics.protocol import NoPrognostics, Oracle

pytest.importorskip("pettingzoo")
from pettingzoo.test import parallel_api_test

from brake_env.env.fleet.parallel import STORE, BrakeWearFleetParallelEnv
from tests.brake_env.env.fleet.small import SMALL


def test_parallel_api(atlas) -> None:
    env = BrakeWearFleetParallelEnv(atlas=atlas, **SMALL)
    parallel_api_test(env, num_cycles=1000)
    assert env.observation_space("vehicle_0") is env.observation_space("vehicle_0")
    assert env.possible_agents[-1] == STORE


def _digest(seed: int) -> str:
    env = BrakeWearFleetParallelEnv(**SMALL)
    obs, _ = env.reset(seed=seed)
    out = []
    for agent in env.agents:
        env.action_space(agent).seed(1)
    for _ in range(20):
        actions = {
            a: int(env.action_space(a).sample(mask=obs[a]["action_mask"])) for a in env.agents
        }
        obs, rew, *_ = env.step(actions)
        out.append(round(sum(float(o["observation"].sum()) for o in obs.values()), 6))
        out.append(rew[STORE])
    return repr(out)


_SCRIPT = "from tests.brake_env.env.fleet.test_fleet_parallel import _digest; print(_digest(9))"


def test_parallel_reset_seed_reproducible_across_processes() -> None:
    runs = {
        subprocess.run(
            [sys.executable, "-c", _SCRIPT], capture_output=True, text=True, check=True
        ).stdout
        for _ in range(2)
    }
    assert runs == {_digest(9) + "\n"}


def test_parallel_step_is_the_single_env_step(atlas) -> None:
    par = BrakeWearFleetParallelEnv(atlas=atlas, **SMALL)
    single = BrakeWearFleetEnv(atlas=atlas, **SMALL)
    obs_p, _ = par.reset(seed=4)
    obs_s, _ = single.reset(seed=4)
    for _ in range(10):
        joint = np.array([0, 1, 2, 1])
        actions = {f"vehicle_{v}": int(joint[v]) for v in range(3)} | {STORE: 1}
        obs_p, rew, *_ = par.step(actions)
        obs_s, r, *_ = single.step(joint)
        assert rew["vehicle_2"] == r
        np.testing.assert_array_equal(par.state(), obs_s)
        np.testing.assert_array_equal(obs_p[STORE]["action_mask"], single.action_masks()[12:])


def test_oracle_wrapper_gives_the_true_route_rul(atlas) -> None:
    env = FleetRULObservation(BrakeWearFleetEnv(atlas=atlas, **SMALL), Oracle())
    obs, info = env.reset(seed=0)
    assert obs.shape == (35 + 3 * 2 * 3,)  # 3 vehicles, 2 routes, 3 fields
    for _ in range(6):
        obs, _, _, _, info = env.step(np.array([0, 0, 0, 1]))
    per_shift = env.unwrapped.config.events_per_shift
    for j, route in enumerate(("hot", "mild")):
        truth = env.unwrapped.true_rul(route) / per_shift
        np.testing.assert_array_equal(info["rul_estimate"][f"{route}_rul_mean"], truth)
        np.testing.assert_allclose(obs[35:].reshape(3, 2, 3)[:, j, 0], truth, rtol=1e-6)


def test_wrapper_resets_a_vehicle_with_a_new_pad(atlas) -> None:
    pred = NoPrognostics(mean_life_events=5000.0)
    env = FleetRULObservation(BrakeWearFleetEnv(atlas=atlas, **SMALL), pred, ("rul_mean",))
    env.reset(seed=0)
    env.step(np.array([0, 1, 0, 0]))
    _, _, _, _, info = env.step(np.array([3, 1, 0, 0]))  # vehicle 0: a shop visit
    est = info["rul_estimate"]["hot_rul_mean"]
    cfg = env.unwrapped.config
    fresh = duty_clocks(atlas).routes[0].life(cfg.k_mean) / cfg.events_per_shift
    assert est[0] == pytest.approx(fresh)  # new pad, nothing braked yet
    # Its events restart at 0: the slot was reset (else the predictor rejects the batch).
    _, _, _, _, info = env.step(np.array([0, 1, 0, 0]))
    assert info["rul_estimate"]["rul_mean"][0] == 5000.0


# The store's spaces differ from the vehicles' by design (it orders spares); PettingZoo's
# api_test warns about that, not about an error.
@pytest.mark.filterwarnings("ignore:Agents have different observation space sizes")
@pytest.mark.filterwarnings("ignore:Observations are different shapes")
@pytest.mark.filterwarnings("ignore:Observation is not a NumPy array")
@pytest.mark.filterwarnings("ignore:Observation space for each agent probably should be")
@pytest.mark.filterwarnings("ignore:We recommend agents to be named")
def test_factories_state_and_the_aec_version(atlas) -> None:
    from pettingzoo.test import api_test

    from brake_env.env.fleet import parallel

    par = parallel.parallel_env(atlas=atlas, **SMALL)
    with pytest.raises(RuntimeError, match="reset"):
        par.state()
    obs, _ = par.reset(seed=3)
    single = BrakeWearFleetEnv(atlas=atlas, **SMALL)
    flat, _ = single.reset(seed=3)
    # The state is the single env's observation, step by step on the same actions.
    for _ in range(15):
        state = par.state()
        assert par.state_space.contains(state)
        np.testing.assert_array_equal(state, flat)
        actions = {
            a: int(par.action_space(a).sample(mask=obs[a]["action_mask"])) for a in par.agents
        }
        obs, *_ = par.step(actions)
        joint = [actions[a] for a in par.possible_agents]
        flat, *_ = single.step(np.array(joint, dtype=np.int64))
    api_test(parallel.env(atlas=atlas, **SMALL), num_cycles=200)
