"""Streamed pads: the same events as the whole-life simulation, truth on demand, bounded memory."""

from __future__ import annotations

import tracemalloc

import gymnasium as gym
import numpy as np
import pytest

import brake_env  # noqa: F401  (registers BrakeWear-v0)
from brake_env.env import pad_life
from brake_env.env.brake_wear import BrakeWearEnv
from brake_env.env.config import EnvConfig
from brake_env.env.pads import PadLife, simulate_pad
from brake_env.env.wrappers import RULObservation
from brake_env.model.simulator import SensorNoise, simulate_runs
from brake_env.prognostics.protocol import MEASURED, TRUTH, EventBatch, NoPrognostics, Oracle

K_FAST = 4e-5  # lives of ~6000 events on the small atlas
FAST = {"k_mean": 1e-5, "k_std": 1e-6, "decision_interval": 500, "episode_events": 60_000}


def stream_in_chunks(pad: PadLife, rng: np.random.Generator) -> list:
    """Every event of the pad, asked for in random chunks as the env does."""
    parts, pos = [], 0
    while True:
        n = pad.available(pos, int(rng.integers(1, 3000)))
        if n == 0:
            return parts
        parts.append(pad.events(pos, pos + n))
        pos += n


def concat(parts: list) -> EventBatch:
    return EventBatch(
        **{k: np.concatenate([getattr(p, k) for p in parts]) for k in ("event", *MEASURED, *TRUTH)}
    )


def assert_same_events(parts: list, whole) -> None:
    for k in ("event", *MEASURED, *TRUTH):
        got = np.concatenate([getattr(p, k) for p in parts])
        assert np.array_equal(got, getattr(whole, k)), k


@pytest.mark.parametrize("interpolate", [False, True])
def test_streamed_pad_equals_the_whole_life_simulation(small_atlas, interpolate, monkeypatch):
    # A small buffer, so that the store also drops events and the life is counted ahead
    # on a copy of the stream.
    monkeypatch.setattr(pad_life, "BUFFER_EVENTS", 2500)
    config = EnvConfig(interpolate_layers=interpolate)
    for i, k in enumerate((K_FAST, 0.6 * K_FAST)):
        whole = simulate_pad(small_atlas, config, k, "id", np.random.SeedSequence(i))
        streamed = PadLife(small_atlas, config, k, "id", np.random.SeedSequence(i))
        assert streamed.n_events == whole.n_events > 2 * 2500  # known ahead
        parts = stream_in_chunks(streamed, np.random.default_rng(i))
        assert_same_events(parts, whole.events())
        last = whole.n_events - 1
        assert streamed.volume_after(last) == whole.volume_after(last)
        # Asked again from installation after the buffer dropped them: the same events.
        assert_same_events([streamed.events(0, 700)], whole.events(0, 700))


def test_a_pad_is_a_dataset_run_with_noise_drawn_per_channel(small_atlas):
    # The same conditions and truth as a dataset run of the same seed (simulate_runs).
    pad = PadLife(small_atlas, EnvConfig(), K_FAST, "id", np.random.SeedSequence(3))
    ev = concat(stream_in_chunks(pad, np.random.default_rng(0)))
    cond = np.random.SeedSequence(3).spawn(2)[0]
    (t,) = simulate_runs(small_atlas, [K_FAST], [cond])
    assert np.array_equal(ev.volume_frac, t.volume_frac)
    assert np.array_equal(ev.rul_events, t.rul_events)
    assert np.array_equal(ev.mass_kg, t.mass_kg) and np.array_equal(ev.speed_kmh, t.speed_mps * 3.6)
    assert pad.volume_after(t.n_events - 1) == t.final_volume_frac
    # Each channel has its own stream: the temperature noise is the same whatever the other
    # channels' noise, and it has the configured spread.
    quiet = EnvConfig(noise=SensorNoise(temp_c=5.0, stop_dist_m=0, energy_j=0, slope_rad=0))
    alone = PadLife(small_atlas, quiet, K_FAST, "id", np.random.SeedSequence(3))
    assert np.array_equal(alone.events(0, 5000).temp_c, ev.temp_c[:5000])
    assert np.array_equal(alone.events(0, 5000).slope_rad, t.slope_rad[:5000])
    assert np.std(ev.temp_c - t.temp_mean_c) == pytest.approx(5.0, rel=0.05)


def test_without_truth_nothing_is_simulated_ahead_and_the_rollout_is_the_same(atlas):
    with_truth, without = (BrakeWearEnv(atlas=atlas, truth=t, **FAST) for t in (True, False))
    rng = np.random.default_rng(0)
    actions = (rng.random(120) < 0.05).astype(int)
    o1, i1 = with_truth.reset(seed=4)
    o2, i2 = without.reset(seed=4)
    assert without.installed_pad.life is None  # only its first block simulated
    assert i2["truth"]["rul_events"] is None and i2["truth"]["life_events"] is None
    assert i2["events"].rul_events is None and not i2["events"].has_truth
    kinds = set()
    for a in actions:
        o1, r1, _, _, i1 = with_truth.step(a)
        o2, r2, _, _, i2 = without.step(a)
        assert np.array_equal(o1, o2) and r1 == r2
        assert i1["truth"]["volume_frac"] == i2["truth"]["volume_frac"]
        for k in ("event", *MEASURED, "volume_frac", "wear_coeff"):
            assert np.array_equal(getattr(i1["events"], k), getattr(i2["events"], k))
        for p1, p2 in zip(i1["retired"], i2["retired"], strict=True):
            kinds.add(p1.failed)
            # A failed pad's life is known without truth; a replaced pad's is not.
            assert (p2.life_left, p2.life) == ((0, p1.life) if p1.failed else (None, None))
    assert kinds == {True, False}  # both kinds of retirement were seen


def test_oracle_needs_truth(atlas):
    env = RULObservation(BrakeWearEnv(atlas=atlas, truth=False, **FAST), Oracle())
    with pytest.raises(ValueError, match="no ground truth"):
        env.reset(seed=0)
    with pytest.raises(ValueError, match="truth must be a bool"):
        BrakeWearEnv(atlas=atlas, truth=1)


def test_precompute_and_cache_work_on_streamed_pads(atlas):
    a = RULObservation(BrakeWearEnv(atlas=atlas, truth=False, **FAST), NoPrognostics(2e4))
    b = RULObservation(
        BrakeWearEnv(atlas=atlas, truth=False, cache_pads=4, **FAST),
        NoPrognostics(2e4),
        precompute=True,
    )
    for env in (a, b):
        env.reset(seed=2)
    first = b.unwrapped.installed_pad
    for i in range(60):
        oa, *_ = a.step(int(i % 25 == 24))
        ob, *_ = b.step(int(i % 25 == 24))
        assert np.array_equal(oa, ob)
    assert b.unwrapped.installed_pad is not first
    b.reset(seed=2)
    assert b.unwrapped.installed_pad is first  # replayed from the cache, events and all


def test_served_events_are_never_overwritten(atlas, monkeypatch):
    # The store drops and regrows its rows into new arrays: batches handed out stay valid.
    monkeypatch.setattr(pad_life, "BUFFER_EVENTS", 3000)
    env = BrakeWearEnv(atlas=atlas, truth=False, **FAST)
    env.reset(seed=1)
    kept = []
    for _ in range(40):
        info = env.step(0)[-1]
        kept.append((info["events"], info["events"].temp_c.copy()))
    assert all(np.array_equal(ev.temp_c, copy) for ev, copy in kept)


def test_memory_stays_bounded_for_a_pad_of_a_billion_events(atlas):
    # K 1e4 times below the default: a life of ~1.2e9 events (~75 GB if simulated whole).
    small_k = {"k_mean": 2e-10, "k_std": 2e-11, "truth": False, "atlas": atlas}
    env = gym.make("BrakeWear-v0", **small_k)
    gym.make("BrakeWear-v0", atlas=atlas).reset(seed=0)  # atlas lookup tables built first
    tracemalloc.start()
    _, info = env.reset(seed=0)
    for _ in range(60):  # 30,000 events, two blocks
        _, _, _, _, info = env.step(0)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert info["failures"] == 0 and env.unwrapped.pad_age == 30_001
    assert peak < 25e6, f"peak {peak / 1e6:.1f} MB"
