import numpy as np
import pytest

from brake_env.model.simulator import (
    TRAJECTORY_ARRAYS,
    AlternatingRoutes,
    Runs,
    simulate_runs,
)
from brake_env.model.simulator_reference import simulate_run_reference
from brake_env.model.wear import WearModel

K_FAST = 4e-5  # 20x the nominal coefficient: short lives for quick tests


def seeds(n: int, seed: int = 0) -> list[np.random.SeedSequence]:
    return np.random.SeedSequence(seed).spawn(n)


def test_vectorised_equals_per_event_reference(small_atlas) -> None:
    ss = seeds(3)
    fast = simulate_runs(small_atlas, [K_FAST, 1.3 * K_FAST, 0.8 * K_FAST], ss)
    for k, s, traj in zip([K_FAST, 1.3 * K_FAST, 0.8 * K_FAST], ss, fast, strict=True):
        ref = simulate_run_reference(small_atlas, k, s)
        assert ref.n_events == traj.n_events
        for f in TRAJECTORY_ARRAYS:
            np.testing.assert_array_equal(getattr(traj, f), getattr(ref, f), err_msg=f)
        assert traj.final_volume_frac == ref.final_volume_frac


def test_layer_blending_equals_per_event_reference(small_atlas) -> None:
    # The closed-form solution of the blended recurrence against the literal event loop.
    ss = seeds(2, seed=9)
    fast = simulate_runs(small_atlas, [K_FAST, 0.7 * K_FAST], ss, interpolate_layers=True)
    for k, s, traj in zip([K_FAST, 0.7 * K_FAST], ss, fast, strict=True):
        ref = simulate_run_reference(small_atlas, k, s, interpolate_layers=True)
        assert ref.n_events == traj.n_events
        np.testing.assert_allclose(traj.volume_frac, ref.volume_frac, rtol=0, atol=1e-13)
        np.testing.assert_allclose(traj.wear_frac, ref.wear_frac, rtol=1e-10)
        np.testing.assert_allclose(traj.temp_mean_c, ref.temp_mean_c, rtol=1e-12)
    # Wear per event rises with every layer at every node, so blending in the next layer
    # wears more on the same stream: the blended pad is never thicker, and fails no later.
    assert np.all(np.diff(small_atlas.fields["wear_per_k_m3"], axis=0) > 0)
    plain = simulate_runs(small_atlas, [K_FAST, 0.7 * K_FAST], ss)
    for p, f in zip(plain, fast, strict=True):
        n = f.n_events
        assert np.all(f.volume_frac[:n] <= p.volume_frac[:n])  # equal while w = 0 at V = 1
        assert f.volume_frac[n - 1] < p.volume_frac[n - 1]
        assert 0.97 * p.n_events < n <= p.n_events


@pytest.mark.parametrize("interpolate", [False, True])
def test_a_run_does_not_depend_on_its_neighbours(small_atlas, interpolate) -> None:
    ss = seeds(4)
    ks = [K_FAST, 2e-6 * 5, K_FAST * 2, 1.1 * K_FAST]
    together = simulate_runs(small_atlas, ks, ss, interpolate_layers=interpolate)
    alone = simulate_runs(small_atlas, [ks[2]], [ss[2]], interpolate_layers=interpolate)[0]
    for f in TRAJECTORY_ARRAYS:
        np.testing.assert_array_equal(getattr(together[2], f), getattr(alone, f), err_msg=f)
    # A block at a time, as a streamed pad is simulated: the same run, bit for bit.
    runs = Runs(small_atlas, [ks[3]], [ss[3]], interpolate_layers=interpolate)
    blocks = []
    while not runs.done[0]:
        blocks += runs.advance(np.zeros(1, dtype=np.intp))
    assert [b.first for b in blocks] == list(
        np.cumsum([0] + [len(b.volume_frac) for b in blocks[:-1]])
    )
    for f in TRAJECTORY_ARRAYS[:-1]:
        got = np.concatenate([getattr(b, f) for b in blocks])
        np.testing.assert_array_equal(got, getattr(together[3], f), err_msg=f)
    layers = np.concatenate([np.full(len(b.volume_frac), b.layer) for b in blocks])
    np.testing.assert_array_equal(layers, together[3].layer)
    assert runs.vol[0] == together[3].final_volume_frac
    # Wear only (how the env finds a pad's end of life ahead): the same life.
    count = Runs(small_atlas, [ks[3]], [ss[3]], interpolate_layers=interpolate)
    while not count.done[0]:
        (b,) = count.advance(np.zeros(1, dtype=np.intp), response=False)
        assert b.temp_mean_c is None
    assert count.pos[0] == together[3].n_events and count.vol[0] == runs.vol[0]


def test_condition_stream_keeps_about_a_block() -> None:
    from brake_env.model.simulator import ConditionStream

    seq = np.random.SeedSequence(2)
    stream = ConditionStream(np.random.default_rng(seq))
    got = [stream.take(a, 2000).copy() for a in range(0, 200_000, 2000)]
    assert len(stream.u) <= 2000 + 16_384  # not the 200,000 events taken so far
    np.testing.assert_array_equal(
        np.concatenate(got), np.random.default_rng(seq).random((200_000, 3))
    )
    with pytest.raises(ValueError, match="in order"):
        stream.take(0, 10)


def test_sensor_channels_agree_everywhere() -> None:
    from brake_env.data.schema import SENSOR_CHANNELS
    from brake_env.model import streams
    from brake_env.prognostics.protocol import MEASURED

    assert SENSOR_CHANNELS == MEASURED == streams.SENSOR_CHANNELS


def test_volume_layers_and_failure_are_consistent(small_atlas) -> None:
    a = small_atlas
    (t,) = simulate_runs(a, [K_FAST], seeds(1))
    v = t.volume_frac
    assert v[0] == 1.0
    assert np.all(np.diff(v) < 0) and np.all(t.wear_frac > 0)
    np.testing.assert_allclose(v[1:], v[:-1] - t.wear_frac[:-1], rtol=0, atol=1e-12)
    # Every event ran on the layer whose 1% band holds the volume at its start.
    lower = a.lower_edges[t.layer]
    assert np.all(v <= a.volumes[t.layer] + 1e-12) and np.all(v >= lower)
    # The run ends with the event that takes the pad below the critical volume.
    assert t.final_volume_frac < a.failure_volume <= v[-1]
    assert a.failure_mode == "cannot-stop" and a.failure_volume == a.critical_volume
    np.testing.assert_array_equal(t.rul_events, t.n_events - 1 - np.arange(t.n_events))


def test_lifetime_scales_as_one_over_k(small_atlas) -> None:
    ks = np.array([1.0, 2.0, 4.0]) * K_FAST
    trajs = simulate_runs(small_atlas, ks, seeds(3, seed=11))
    k_life = ks * np.array([t.n_events for t in trajs])
    # Exact in expectation; the simulated lives scatter by the operating-condition noise.
    np.testing.assert_allclose(k_life, k_life.mean(), rtol=0.02)
    life = WearModel.from_atlas(small_atlas).life(ks)
    np.testing.assert_allclose(ks * life, k_life.mean(), rtol=0.02)


def test_same_seed_same_trajectory_other_seed_differs(small_atlas) -> None:
    a1 = simulate_runs(small_atlas, [K_FAST], seeds(1, 5))[0]
    a2 = simulate_runs(small_atlas, [K_FAST], seeds(1, 5))[0]
    b = simulate_runs(small_atlas, [K_FAST], seeds(1, 6))[0]
    np.testing.assert_array_equal(a1.temp_mean_c, a2.temp_mean_c)
    assert a1.n_events != b.n_events or not np.array_equal(a1.speed_mps, b.speed_mps)


def test_operating_conditions_are_uniform_over_the_envelope(small_atlas) -> None:
    (t,) = simulate_runs(small_atlas, [K_FAST / 4], seeds(1))
    kmh = t.speed_mps * 3.6
    assert kmh.min() >= 4.0 and kmh.max() <= 15.0
    assert abs(kmh.mean() - 9.5) < 0.1 and abs(t.mass_kg.mean() - 48e3) < 150


def test_bad_wear_coefficients_are_rejected(small_atlas) -> None:
    with pytest.raises(ValueError, match="wear coefficients"):
        simulate_runs(small_atlas, [-1e-6], seeds(1))
    with pytest.raises(ValueError, match="one seed per"):
        simulate_runs(small_atlas, [1e-6, 2e-6], seeds(1))
    with pytest.raises(ValueError, match="half an atlas layer"):
        simulate_runs(small_atlas, [1e-2], seeds(1))


def test_an_event_that_skips_a_layer_is_handled_alike(small_atlas) -> None:
    # K near the limit: single events can cross more than one 1% level near end of life.
    ss = seeds(1, seed=1)
    (fast,) = simulate_runs(small_atlas, [6e-4], ss)
    ref = simulate_run_reference(small_atlas, 6e-4, ss[0])
    assert np.diff(fast.layer).max() == 2  # this seed does skip a layer
    assert fast.n_events == ref.n_events
    np.testing.assert_array_equal(fast.layer, ref.layer)
    assert fast.final_volume_frac == ref.final_volume_frac < small_atlas.failure_volume


def test_trajectory_array_names_match_the_dataclass() -> None:
    import dataclasses

    from brake_env.model.simulator import Trajectory

    names = [f.name for f in dataclasses.fields(Trajectory)]
    assert names == ["wear_coeff", *TRAJECTORY_ARRAYS, "final_volume_frac"]


def test_alternating_routes_vectorised_equals_reference_and_keeps_the_mix(small_atlas) -> None:
    duty = AlternatingRoutes(block_events=300)
    ss = seeds(2, seed=5)
    fast = simulate_runs(small_atlas, [K_FAST, 1.2 * K_FAST], ss, duty=duty)
    for k, s, traj in zip([K_FAST, 1.2 * K_FAST], ss, fast, strict=True):
        ref = simulate_run_reference(small_atlas, k, s, duty=duty)
        assert ref.n_events == traj.n_events
        for f in TRAJECTORY_ARRAYS:
            np.testing.assert_array_equal(getattr(traj, f), getattr(ref, f), err_msg=f)
    lo, hi = small_atlas.speed_mps[0], small_atlas.speed_mps[-1]
    mid = 0.5 * (lo + hi)
    t = fast[0]
    block = np.arange(t.n_events) // 300
    assert np.all(t.speed_mps[block % 2 == 0] >= mid)  # haul road: upper half
    assert np.all(t.speed_mps[block % 2 == 1] < mid)  # pit: lower half
    # Mass and slope are the independent draws' own; the speed mix stays uniform overall.
    plain = simulate_runs(small_atlas, [K_FAST], ss[:1])[0]
    n = min(t.n_events, plain.n_events)
    np.testing.assert_array_equal(t.mass_kg[:n], plain.mass_kg[:n])
    u = (t.speed_mps - lo) / (hi - lo)
    assert abs(u.mean() - 0.5) < 0.02 and abs(np.mean(u < 0.5) - 0.5) < 0.05


def test_alternating_routes_rejects_bad_blocks() -> None:
    with pytest.raises(ValueError, match="block_events"):
        AlternatingRoutes(block_events=0)
    from brake_env.data.datasets import DatasetSpec

    with pytest.raises(ValueError, match="route_block_events"):
        DatasetSpec(route_block_events=-1)
    assert DatasetSpec().duty is None
    assert DatasetSpec(route_block_events=500).duty == AlternatingRoutes(500)


def test_duty_applies_by_absolute_event_when_the_stream_grows() -> None:
    from brake_env.model.simulator import ConditionStream

    duty = AlternatingRoutes(block_events=700)
    seq = np.random.SeedSequence(8)
    grown = ConditionStream(np.random.default_rng(seq), 10, duty)
    # Taken in pieces, so that the stream grows several times past its first chunk.
    got = np.concatenate(
        [grown.take(a, b - a) for a, b in ((0, 4000), (4000, 7000), (7000, 12_000))]
    )
    whole = duty.apply(np.random.default_rng(seq).random((12_000, 3)), 0)
    np.testing.assert_array_equal(got, whole)
