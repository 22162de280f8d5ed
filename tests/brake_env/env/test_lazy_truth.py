"""BrakeWear-v0's truth is simulated only when read, and is then exactly what it was when
every pad was simulated ahead at installation."""

from __future__ import annotations

import pickle

import numpy as np

from brake_env.env.brake_wear import BrakeWearEnv
from brake_env.env.lazy_truth import LazyTruth, PendingRULEvents
from brake_env.env.pad_life import PadLife

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


def test_lazy_infos_pickle_as_plain_values(atlas) -> None:
    env = BrakeWearEnv(atlas=atlas, **FAST)
    env.reset(seed=4)
    env.step(0)
    info = env.step(1)[4]
    back = pickle.loads(pickle.dumps(info))
    assert type(back["truth"]) is dict and back["truth"] == info["truth"]
    assert back["retired"][0].life_left == info["retired"][0].life_left > 0
    np.testing.assert_array_equal(back["events"].rul_events, info["events"].rul_events)
