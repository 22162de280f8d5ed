"""The fleet's vectorised pads: bit for bit BrakeWear-v0's pad life on the uniform route,
the same events whether vehicles are stepped together or one by one, exact truth ahead,
bounded memory; and the routes' wear from the atlas."""

from __future__ import annotations

import numpy as np
import pytest

from brake_env.env.config import EnvConfig
from brake_env.env.fleet.pads import FleetPads
from brake_env.env.fleet.routes import HOT, MILD, ROUTES, UNIFORM, Route, route_mean
from brake_env.env.pad_life import PadLife
from brake_env.model.streams import SENSOR_CHANNELS

KS = (1.0e-5, 1.2e-5, 0.9e-5)
ENTROPY = (11, 22, 33)
U = ROUTES.index(UNIFORM)


def fleet(atlas, n: int = 3, capacity: int = 1024) -> FleetPads:
    pads = FleetPads(atlas, n, EnvConfig().noise, capacity)
    for v in range(n):
        pads.install(v, KS[v], "id", ENTROPY[v])
    return pads


def test_uniform_route_is_bit_for_bit_brakewear_pad_life(atlas) -> None:
    pads = fleet(atlas)
    parts, vols = [], []
    for n in (300, 1, 777, 1024, 50) * 4:  # odd sizes: blocks cut anywhere
        ev = pads.advance(np.full(3, n), np.full(3, U))
        parts.append(ev.measured)
        vols.append(ev.volume_frac)
    measured, volume = np.concatenate(parts, axis=2), np.concatenate(vols, axis=1)
    total = measured.shape[2]
    cfg = EnvConfig(truth=False)
    for v in range(3):
        ref = PadLife(atlas, cfg, KS[v], "id", np.random.SeedSequence(ENTROPY[v]))
        b = ref.events(0, total)
        np.testing.assert_array_equal(
            measured[:, v], np.stack([getattr(b, c) for c in SENSOR_CHANNELS])
        )
        np.testing.assert_array_equal(volume[v], b.volume_frac)
        assert pads.vol[v] == ref.volume_after(total - 1)


def test_true_rul_is_brakewear_life_left(atlas) -> None:
    pads = fleet(atlas, capacity=8192)
    pads.advance(np.array([1000, 5000, 0]), np.full(3, U))
    rul = pads.events_to_failure(np.full(3, U))
    for v, done in enumerate((1000, 5000, 0)):
        ref = PadLife(atlas, EnvConfig(), KS[v], "id", np.random.SeedSequence(ENTROPY[v]))
        assert rul[v] == ref.n_events - done
    before = pads.pos.copy()
    assert np.array_equal(pads.pos, before)  # simulating ahead changed nothing


def test_vectorised_step_equals_one_vehicle_at_a_time(atlas) -> None:
    """Vehicles on different routes and in different layers, stepped together, brake the
    same events as each stepped alone (the reference: a fleet of one per vehicle)."""
    together = fleet(atlas)
    alone = [FleetPads(atlas, 1, EnvConfig().noise, 1024) for _ in range(3)]
    for v, p in enumerate(alone):
        p.install(0, KS[v], "id", ENTROPY[v])
    rng = np.random.default_rng(0)
    for _ in range(40):
        n = rng.integers(0, 400, 3)
        route = rng.integers(0, 3, 3)
        ev = together.advance(n, route)
        for v, p in enumerate(alone):
            one = p.advance(n[v : v + 1], route[v : v + 1])
            k = int(n[v])
            np.testing.assert_array_equal(ev.measured[:, v, :k], one.measured[:, 0, :k])
            np.testing.assert_array_equal(ev.volume_frac[v, :k], one.volume_frac[0, :k])
            assert ev.valid[v].sum() == k and one.n_done[0] == k
    for v, p in enumerate(alone):
        assert (together.layer[v], together.vol[v]) == (p.layer[0], p.vol[0])
    assert together.layer.max() > 0  # layers were crossed inside shifts


def test_pad_fails_at_end_of_life_and_memory_is_bounded(atlas) -> None:
    pads = fleet(atlas, n=1, capacity=512)
    shapes = (pads._u.shape, pads._z.shape)
    failed = False
    for _ in range(1000):
        ev = pads.advance(np.array([500]), np.array([0]))
        if ev.failed[0]:
            failed = True
            break
    assert failed and pads.done[0]
    assert pads.vol[0] <= atlas.failure_volume + 1e-12
    assert (pads._u.shape, pads._z.shape) == shapes  # buffers never grew
    assert ev.n_done[0] < 500 and ev.valid[0].sum() == ev.n_done[0]


def test_route_wear_from_the_atlas(atlas) -> None:
    hot, mild, uni = (route_mean(atlas, r) for r in (HOT, MILD, UNIFORM))
    np.testing.assert_allclose(uni, atlas.expected("wear_per_k_m3"), rtol=1e-12)
    assert hot[0] / mild[0] > 3.0 and hot[-1] / mild[-1] > hot[0] / mild[0]
    assert hot[-1] / hot[0] > mild[-1] / mild[0]  # the coupling bites on the ramp
    with pytest.raises(ValueError, match="envelope"):
        Route("steep", (4.0, 15.0), (42.0, 54.0), (0.0, 12.0)).bounds(atlas)
