"""BrakeWear-v0: checkers, determinism, pickling, vector equivalence, costs, validation."""

from __future__ import annotations

import pickle
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import brake_env  # noqa: F401  (registers BrakeWear-v0)
from agents.policies.rules import ReplaceOnFailure, RULThreshold
from brake_env.env.brake_wear import OBS_NAMES, BrakeWearEnv
from brake_env.env.config import CostWeights, EnvConfig
from brake_env.env.pads import RetiredPad
from brake_env.env.vector import BrakeWearVectorEnv
from brake_env.env.wrappers import RULObservation
from brake_env.prognostics.protocol import NoPrognostics, Oracle

# Fast pads (life ~2.4e4 events) so an episode holds several lives in a few hundred steps.
FAST = {"k_mean": 1e-5, "k_std": 1e-6, "decision_interval": 500, "episode_events": 100_000}


@pytest.fixture(scope="module")
def make(atlas):
    def _make(**kw):
        return BrakeWearEnv(atlas=atlas, **{**FAST, **kw})

    return _make


def rollout(env, seed, n_steps, action_seed=0, p_replace=0.02):
    """Observations, rewards and truth of ``n_steps`` random-action steps."""
    rng = np.random.default_rng(action_seed)
    obs, info = env.reset(seed=seed)
    out = [(obs.copy(), 0.0, info["truth"]["rul_events"])]
    for _ in range(n_steps):
        obs, r, term, trunc, info = env.step(int(rng.random() < p_replace))
        out.append((obs.copy(), float(r), info["truth"]["rul_events"]))
        if term or trunc:
            obs, info = env.reset()
    return out


def same(a, b):
    return all(
        np.array_equal(x[0], y[0]) and x[1] == y[1] and x[2] == y[2]
        for x, y in zip(a, b, strict=True)
    )


def test_registered_and_made_both_ways(atlas):
    env = gym.make("BrakeWear-v0", atlas=atlas, **FAST)
    env2 = gym.make("brake_env:BrakeWear-v0", atlas=atlas, **FAST)
    assert env.unwrapped.config == env2.unwrapped.config
    assert env.observation_space.shape == (len(OBS_NAMES),)


def test_gymnasium_and_sb3_checkers_pass(make):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # "wrapped env" notices
        for env in (
            make(),
            RULObservation(make(), Oracle()),
            RULObservation(make(), NoPrognostics(3e4)),
        ):
            gym_check_env(env, skip_render_check=True)
            sb3_check_env(env, warn=False)


def test_same_seed_same_rollout_and_different_seed_differs(make):
    a, b = rollout(make(), 7, 400), rollout(make(), 7, 400)
    assert same(a, b)
    assert not same(a, rollout(make(), 8, 400))


def test_pickle_round_trip_continues_identically(make):
    env = make()
    env.reset(seed=3)
    for _ in range(50):
        env.step(0)
    clone = pickle.loads(pickle.dumps(env))
    for i in range(140):  # to the end of the 200-step episode
        o1, r1, _, t1, i1 = env.step(int(i % 97 == 0))
        o2, r2, _, t2, i2 = clone.step(int(i % 97 == 0))
        assert np.array_equal(o1, o2) and r1 == r2 and t1 == t2
        assert i1["truth"] == i2["truth"]


def test_step_serves_interval_events_and_truncates_at_episode_events(make):
    env = make(decision_interval=700, episode_events=10_001)
    obs, info = env.reset(seed=0)
    total, age = len(info["events"]), int(obs[-1])
    assert total == 1 and age == 1
    steps, trunc = 0, False
    while not trunc:
        obs, _, term, trunc, info = env.step(0)
        ev = info["events"]
        assert not term
        total += len(ev)
        steps += 1
        # Event indices continue the pad's age; the observation is the step's last event.
        assert np.array_equal(ev.event, np.arange(age, age + len(ev)))
        age = int(obs[-1])
        assert age == ev.event[-1] + 1
        assert np.isclose(obs[4], ev.temp_c[-1], rtol=1e-6)
    assert total == 10_001 and steps == env.config.steps_per_episode == 15
    with pytest.raises(RuntimeError, match="reset"):
        env.step(0)


def test_failure_forces_replacement_and_costs_match_weights(make):
    costs = CostWeights(
        planned_replacement=3.0, corrective_replacement=5.0, downtime=7.0, damage=11.0, revenue=0.5
    )
    env = make(costs=costs, decision_interval=5000)
    env.reset(seed=1)
    failures = 0
    while True:
        _, r, _, trunc, info = env.step(0)
        c = info["costs"]
        assert c["revenue"] == 0.5 * len(info["events"])
        assert r == pytest.approx(c["revenue"] - 23.0 * info["failures"])
        if info["failures"]:
            failures += 1
            ev = info["events"]
            # The failed pad used all its life; the new pad braked the rest of the step.
            cut = int(np.flatnonzero(ev.event == 0)[-1])
            assert cut == 0 or ev.rul_events[cut - 1] == 0
            assert [(p.life_left, p.failed) for p in info["retired"]] == [(0, True)]
            assert ev.event[-1] + 1 == info["truth"]["life_events"] - info["truth"]["rul_events"]
        if trunc:
            break
    assert failures >= 2
    _, info = env.reset(seed=1)
    _, r, *_, info = env.step(1)
    assert info["replaced"] and info["costs"]["planned_replacement"] == 3.0
    (pad,) = info["retired"]  # the first pad, taken off after its first event
    assert pad == RetiredPad(pad.life - 1, pad.life, "id") and not pad.failed
    assert r == pytest.approx(0.5 * 5000 - 3.0)


def test_truth_rul_counts_down_to_zero_over_a_life(make):
    env = make(decision_interval=1, episode_events=60_000)
    _, info = env.reset(seed=5)
    life = info["truth"]["life_events"]
    prev_vol = info["truth"]["volume_frac"]
    for k in range(1, life):
        _, _, _, _, info = env.step(0)
        assert info["truth"]["rul_events"] == life - 1 - k
        assert info["truth"]["volume_frac"] < prev_vol  # every event wears the pad
        prev_vol = info["truth"]["volume_frac"]
    assert prev_vol <= env.atlas.failure_volume + 1e-12
    _, _, _, _, info = env.step(0)
    assert info["failures"] == 1 and info["truth"]["rul_events"] == info["truth"]["life_events"] - 1


def test_regimes_draw_the_right_kind_of_pads(make):
    labels = {}
    for regime in ("id", "ood", "mixed"):
        env = make(regime=regime, decision_interval=10_000, episode_events=400_000)
        env.reset(seed=0)
        seen = []
        for _ in range(40):
            _, _, _, trunc, info = env.step(1)
            seen.append((info["truth"]["regime"], info["truth"]["wear_coeff"]))
            if trunc:
                break
        labels[regime] = seen
    assert {lab for lab, _ in labels["id"]} == {"id"}
    assert {lab for lab, _ in labels["ood"]} == {"ood-slow", "ood-fast"}
    assert {lab for lab, _ in labels["mixed"]} == {"id", "ood-slow", "ood-fast"}
    slow = [k for lab, k in labels["ood"] if lab == "ood-slow"]
    fast = [k for lab, k in labels["ood"] if lab == "ood-fast"]
    assert max(slow) < 1e-5 < min(fast)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"decison_interval": 5}, "unknown argument.*decison_interval"),
        ({"decision_interval": 0}, "decision_interval must be an int"),
        ({"decision_interval": 2.5}, "decision_interval must be an int"),
        ({"regime": "weird"}, "regime must be one of"),
        ({"ood_share": 1.5}, "ood_share must be in"),
        ({"costs": {"failure": 3.0}}, "unknown parameter.*failure"),
        ({"costs": {"damage": -1.0}}, "damage must be >= 0"),
        ({"noise": {"temp_c": -1.0}}, "temp_c must be >= 0"),
        ({"preset": "icy"}, "preset must be one of"),
        ({"render_mode": "video"}, "render_mode"),
    ],
)
# gym.make warns about an unsupported render_mode before the env raises its own error.
@pytest.mark.filterwarnings("ignore:.*render_mode.*:UserWarning")
def test_invalid_arguments_raise_one_clear_error(atlas, kwargs, match):
    with pytest.raises(ValueError, match=match):
        gym.make("BrakeWear-v0", atlas=atlas, **kwargs)


def test_invalid_action_is_rejected(make):
    env = make()
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action must be 0"):
        env.step(2)


def test_config_object_and_kwargs_agree(atlas):
    cfg = EnvConfig(decision_interval=250, regime="mixed")
    assert (
        BrakeWearEnv(cfg, atlas=atlas).config
        == BrakeWearEnv(atlas=atlas, decision_interval=250, regime="mixed").config
    )


def test_native_vector_env_matches_single_envs_and_sync_vector(atlas):
    n, seed, steps = 3, 11, 220
    kw = {**FAST, "episode_events": 50_000}  # truncation and autoreset inside the rollout
    rng = np.random.default_rng(0)
    actions = (rng.random((steps, n)) < 0.02).astype(np.int64)
    vec = gym.make_vec("BrakeWear-v0", num_envs=n, atlas=atlas, **kw)
    assert isinstance(vec.unwrapped, BrakeWearVectorEnv)
    sync = gym.make_vec("BrakeWear-v0", num_envs=n, vectorization_mode="sync", atlas=atlas, **kw)
    singles = [BrakeWearEnv(atlas=atlas, **kw) for _ in range(n)]
    o_v, _ = vec.reset(seed=seed)
    o_s, _ = sync.reset(seed=seed)
    o_1 = np.stack([e.reset(seed=seed + i)[0] for i, e in enumerate(singles)])
    assert np.array_equal(o_v, o_s) and np.array_equal(o_v, o_1)
    done = np.zeros(n, dtype=bool)
    truncations = 0
    for a in actions:
        o_v, r_v, _, t_v, _ = vec.step(a)
        o_s, r_s, _, t_s, _ = sync.step(a)
        rows = []
        for i, e in enumerate(singles):  # next-step autoreset, as the vector envs do
            if done[i]:
                rows.append((e.reset()[0], 0.0, False))
            else:
                o, r, _, t, _ = e.step(int(a[i]))
                rows.append((o, r, t))
        done = np.array([row[2] for row in rows])
        assert np.array_equal(o_v, o_s) and np.array_equal(r_v, r_s) and np.array_equal(t_v, t_s)
        assert np.array_equal(o_v, np.stack([row[0] for row in rows]))
        assert np.array_equal(r_v, [row[1] for row in rows])
        truncations += int(t_v.sum())
    assert truncations == 2 * n  # every sub-env was truncated and reset twice


def test_works_in_sb3_vec_envs(atlas):
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

    def fn(i):
        return lambda: RULObservation(BrakeWearEnv(atlas=atlas, **FAST), Oracle())

    dummy = DummyVecEnv([fn(0), fn(1)])
    dummy.seed(4)
    o_d = dummy.reset()
    sub = SubprocVecEnv([fn(0), fn(1)], start_method="fork")
    sub.seed(4)
    o_p = sub.reset()
    assert np.array_equal(o_d, o_p)
    for _ in range(30):
        o_d, r_d, *_ = dummy.step(np.array([0, 0]))
        o_p, r_p, *_ = sub.step(np.array([0, 0]))
    assert np.array_equal(o_d, o_p) and np.array_equal(r_d, r_p)
    sub.close()


def test_oracle_threshold_never_fails_where_replace_on_failure_does(make):
    seed = 2
    base = make()
    base.reset(seed=seed)
    failures = 0
    trunc = False
    while not trunc:
        _, _, _, trunc, info = base.step(ReplaceOnFailure().predict(np.zeros(7))[0])
        failures += info["failures"]
    assert failures > 0
    env = RULObservation(make(), Oracle())
    policy = RULThreshold(env.unwrapped.config.decision_interval)
    obs, _ = env.reset(seed=seed)
    failures, trunc, replaced = 0, False, 0
    while not trunc:
        action, _ = policy.predict(obs)
        obs, _, _, trunc, info = env.step(action)
        failures += info["failures"]
        replaced += info["replaced"]
    assert failures == 0 and replaced > 0


def test_wrapper_space_matches_and_feeds_every_event(make):
    class Counting(Oracle):
        seen = 0

        def _update(self, events):
            Counting.seen += len(events)
            return super()._update(events)

    env = RULObservation(make(decision_interval=3000), Counting(), fields=("rul_mean",))
    assert env.observation_space.shape == (len(OBS_NAMES) + 1,)
    obs, info = env.reset(seed=9)
    assert env.observation_space.contains(obs) and Counting.seen == 1
    rng = np.random.default_rng(1)
    expected, installs = 1, 0
    for _ in range(env.unwrapped.config.steps_per_episode):  # replacements and failures
        obs, _, _, trunc, info = env.step(int(rng.random() < 0.1))
        assert env.observation_space.contains(obs)
        assert obs[-1] == np.float32(info["truth"]["rul_events"])
        assert info["rul_estimate"]["rul_mean"] == info["truth"]["rul_events"]
        fresh = np.flatnonzero(info["events"].event == 0)
        # Events of a pad taken off during the step are not fed: the predictor was reset.
        expected += len(info["events"]) - (int(fresh[-1]) if fresh.size else 0)
        installs += int(info["replaced"]) + info["failures"]
    assert trunc and installs >= 3
    assert Counting.seen == expected


def test_wrapper_rejects_missing_interval_fields(make):
    env = RULObservation(make(), Oracle(), fields=("rul_mean", "rul_lower"))
    with pytest.raises(ValueError, match="gives no rul_lower"):
        env.reset(seed=0)
    with pytest.raises(ValueError, match="fields must be among"):
        RULObservation(make(), Oracle(), fields=("volume",))


@pytest.mark.parametrize("predictor", [Oracle, lambda: NoPrognostics(2e4)])
def test_precomputed_wrapper_gives_the_incremental_observations(make, predictor):
    a = RULObservation(make(), predictor())
    b = RULObservation(make(cache_pads=8), predictor(), precompute=True)
    assert same(rollout(a, 3, 199, p_replace=0.05), rollout(b, 3, 199, p_replace=0.05))
    # Replaying the seed reuses the cached pads and their estimates.
    n_cached = len(b._lives)
    assert same(rollout(a, 3, 199, p_replace=0.05), rollout(b, 3, 199, p_replace=0.05))
    assert len(b._lives) == n_cached > 0
