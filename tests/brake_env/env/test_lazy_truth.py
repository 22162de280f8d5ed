"""BrakeWear-v0's truth is simulated only when read, and is then exactly what it was when
every pad was simulated ahead at installation."""

from __future__ import annotations

import copy
import pickle

import numpy as np
import pytest

from brake_env.env.brake_wear import BrakeWearEnv
from brake_env.env.lazy_truth import LazyTruth, PendingRULEvents, StackedTruth
from brake_env.env.pad_life import PadLife
from brake_env.env.pads import RetiredPad
from brake_env.prognostics.protocol import EventBatch

FAST = {"k_mean": 1e-5, "k_std": 1e-6, "decision_interval": 500, "episode_events": 60_000}


def _actions(n: int) -> list[int]:
    return (np.random.default_rng(3).random(n) < 0.3).astype(int).tolist()


def test_exploration_never_simulates_ahead(atlas) -> None:
    env = BrakeWearEnv(atlas=atlas, **FAST)  # truth=True, the default
    _, info = env.reset(seed=0)
    for a in _actions(40):
        _, _, _, _, info = env.step(a)
    assert env.installed_pad.life is None  # nothing read, nothing simulated ahead
    assert isinstance(info["truth"], LazyTruth)
    assert isinstance(info["events"], PendingRULEvents)


def test_truth_read_late_equals_truth_read_at_once(atlas) -> None:
    eager, lazy = (BrakeWearEnv(atlas=atlas, **FAST) for _ in range(2))
    eager.reset(seed=1)
    lazy.reset(seed=1)
    read_now, kept = [], []
    for a in _actions(60):
        info = eager.step(a)[4]
        read_now.append(
            (
                dict(info["truth"]),
                info["events"].rul_events.copy(),
                [(r.life_left, r.life) for r in info["retired"]],
            )
        )
        kept.append(lazy.step(a)[4])
    for (truth, rul, retired), info in zip(read_now, kept, strict=True):
        assert info["truth"] == truth
        np.testing.assert_array_equal(info["events"].rul_events, rul)
        assert [(r.life_left, r.life) for r in info["retired"]] == retired
    assert any(r for _, _, r in read_now)  # replacements happened


def test_lazy_truth_is_the_pads_life(atlas) -> None:
    env = BrakeWearEnv(atlas=atlas, **FAST)
    env.reset(seed=2)
    info = env.step(0)[4]
    pad: PadLife = env.installed_pad
    assert info["truth"]["life_events"] == pad.n_events
    assert info["truth"]["rul_events"] == pad.n_events - env.pad_age
    assert info["events"].rul_events[-1] == info["truth"]["rul_events"]
    sliced = info["events"][100:]
    np.testing.assert_array_equal(sliced.rul_events, info["events"].rul_events[100:])


def _never_simulate(monkeypatch) -> None:
    def refuse(self: PadLife) -> int:
        if self.life is None:
            raise AssertionError("a pad was simulated ahead")
        return self.life

    monkeypatch.setattr(PadLife, "n_events", property(refuse))


def _assert_same_truth(a: dict, b: dict) -> None:
    assert b["truth"] == a["truth"]
    np.testing.assert_array_equal(b["events"].rul_events, a["events"].rul_events)
    assert [(r.life_left, r.life, r.regime) for r in b["retired"]] == [
        (r.life_left, r.life, r.regime) for r in a["retired"]
    ]


def test_copying_and_pickling_infos_never_simulates(atlas, monkeypatch) -> None:
    env = BrakeWearEnv(atlas=atlas, **FAST)
    env.reset(seed=4)
    with monkeypatch.context() as m:
        _never_simulate(m)
        infos = [env.step(a)[4] for a in _actions(30)]  # every copy reads every pad's life
        assert sum(i["replaced"] for i in infos) >= 8
        deep = copy.deepcopy(infos)
        shallow = [
            {**i, "truth": i["truth"].copy(), "retired": copy.copy(i["retired"])} for i in infos
        ]
        pickled = pickle.loads(pickle.dumps(infos))
    assert isinstance(deep[-1]["truth"], LazyTruth)
    assert isinstance(pickled[-1]["truth"], LazyTruth)
    assert isinstance(pickled[-1]["events"], PendingRULEvents)
    for copies in (deep, shallow, pickled):  # read the copies first, then the originals
        for original, copied in zip(infos, copies, strict=True):
            _assert_same_truth(original, copied)


def test_a_pickled_info_holds_the_shared_atlas_by_its_key(monkeypatch) -> None:
    env = BrakeWearEnv(**FAST)  # the preset's shared atlas (~13 MB pickled whole)
    env.reset(seed=5)
    with monkeypatch.context() as m:
        _never_simulate(m)
        info = [env.step(a)[4] for a in (0, 1, 1)][-1]
        blob = pickle.dumps(info)
    assert len(blob) < 200_000
    _assert_same_truth(info, pickle.loads(blob))


def test_read_infos_copy_and_pickle_as_plain_values(atlas) -> None:
    env = BrakeWearEnv(atlas=atlas, **FAST)
    env.reset(seed=4)
    env.step(0)
    info = env.step(1)[4]
    assert info["retired"][0].life_left > 0 and info["truth"]["rul_events"] > 0
    info["events"].rul_events  # noqa: B018 (read)
    for back in (pickle.loads(pickle.dumps(info)), copy.deepcopy(info)):
        assert type(back["truth"]) is dict and back["truth"] == info["truth"]
        assert type(back["retired"][0]) is RetiredPad
        assert back["retired"][0] == info["retired"][0]
        assert type(back["events"]) is EventBatch
        np.testing.assert_array_equal(back["events"].rul_events, info["events"].rul_events)


def test_sb3_dummy_vec_env_never_simulates(monkeypatch) -> None:
    pytest.importorskip("stable_baselines3")
    from stable_baselines3.common.env_util import make_vec_env

    vec = make_vec_env("BrakeWear-v0", n_envs=1, seed=0, env_kwargs=FAST)
    vec.reset()
    for a in (1, 1):  # Gymnasium's env checker reads the first two steps' infos whole
        vec.step(np.array([a]))
    with monkeypatch.context() as m:
        _never_simulate(m)
        infos = [vec.step(np.array([a]))[3][0] for a in _actions(40)]
    assert isinstance(infos[-1]["truth"], LazyTruth)
    assert infos[-1]["truth"]["rul_events"] > 0  # read now


def test_gymnasium_vector_env_stacks_the_truth_without_reading_it(atlas, monkeypatch) -> None:
    import gymnasium as gym

    n = 2
    actions = (np.random.default_rng(5).random((16, n)) < 0.4).astype(np.int64)
    native = gym.make_vec("BrakeWear-v0", num_envs=n, atlas=atlas, **FAST)
    sync = gym.make_vec("BrakeWear-v0", num_envs=n, vectorization_mode="sync", atlas=atlas, **FAST)
    native.reset(seed=6)
    sync.reset(seed=6)
    with monkeypatch.context() as m:
        _never_simulate(m)
        kept = [native.step(a)[4] for a in actions]
        copies = copy.deepcopy(kept), pickle.loads(pickle.dumps(kept))
    assert isinstance(kept[-1]["truth"], StackedTruth) and kept[-1]["truth"].pending
    for a, *infos in zip(actions, kept, *copies, strict=True):
        expected = sync.step(a)[4]["truth"]  # Gymnasium's own stacking, read at once
        for info in infos:
            truth = info["truth"]
            assert set(truth) == set(expected)
            for key, value in expected.items():
                np.testing.assert_array_equal(truth[key], value)


def test_vector_truth_of_known_and_pending_pads_together(atlas) -> None:
    """Reading a step's truth simulates its pads: the next steps mix sub-envs whose truth
    is known (plain dicts) with sub-envs that replaced their pad (pending)."""
    import gymnasium as gym

    n = 3
    actions = (np.random.default_rng(8).random((12, n)) < 0.3).astype(np.int64)
    native = gym.make_vec("BrakeWear-v0", num_envs=n, atlas=atlas, **FAST)
    sync = gym.make_vec("BrakeWear-v0", num_envs=n, vectorization_mode="sync", atlas=atlas, **FAST)
    native.reset(seed=9)
    sync.reset(seed=9)
    kinds = set()
    for t, a in enumerate(actions):
        truth, expected = native.step(a)[4]["truth"], sync.step(a)[4]["truth"]
        if isinstance(truth, StackedTruth):
            kinds.add(tuple(isinstance(p, LazyTruth) for p in truth._pending.values()))
        if t % 3 == 0 or t == len(actions) - 1:
            assert set(truth) == set(expected)
            for key, value in expected.items():
                np.testing.assert_array_equal(truth[key], value)
    assert any(any(k) and not all(k) for k in kinds)  # a mixed step happened
