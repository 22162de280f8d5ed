"""The wear clock: work <-> volume <-> life."""

from __future__ import annotations

import numpy as np
import pytest

from brake_env.model.atlas import Atlas
from brake_env.model.wear import WearModel


def test_life_is_the_sum_of_layer_crossings(atlas: Atlas) -> None:
    wm = WearModel.from_atlas(atlas)
    ks = np.array([1e-6, 2e-6, 3.3e-6])
    per_event = ks[:, None] * atlas.expected("wear_per_k_m3") / atlas.spec.model.brake.pad_volume_m3
    expected = ((atlas.volumes - atlas.lower_edges) / per_event).sum(axis=1)
    np.testing.assert_allclose(wm.life(ks), expected, rtol=1e-12)
    assert wm.life_std(2e-6) > 0


def test_constant_wear_gives_a_straight_clock() -> None:
    tops, bottoms = np.array([1.0, 0.9, 0.8]), np.array([0.9, 0.8, 0.75])
    wm = WearModel.from_layer_wear(tops, bottoms, np.full(3, 2e-3), pad_volume_m3=1e-4)
    k = 2e-6
    assert wm.life(k) == pytest.approx(0.25 * 1e-4 / (k * 2e-3), rel=1e-12)
    assert wm.life_std(k) == 0.0
    np.testing.assert_allclose(wm.volume_at_work([0.0, wm.life_work / 2]), [1.0, 0.875])


def test_identify_and_rul_invert_each_other(atlas: Atlas) -> None:
    wm = WearModel.from_atlas(atlas)
    k, n = 2.3e-6, np.array([100, 5_000, 40_000, 90_000])
    v = wm.volume_at_work(k * n)
    np.testing.assert_allclose(wm.identify_k(v, n), k, rtol=1e-10)
    np.testing.assert_allclose(wm.rul(v, k), wm.life(k) - n, rtol=1e-10)
    assert wm.volume_at_work(0.0) == 1.0
    assert wm.volume_at_work(wm.life_work) == pytest.approx(atlas.failure_volume)


def test_layer_at_work_follows_the_edges(atlas: Atlas) -> None:
    wm = WearModel.from_atlas(atlas)
    edges = wm.work_edges
    assert wm.layer_at_work(0.0) == 0
    assert wm.layer_at_work(edges[0] * (1 - 1e-9)) == 0
    assert wm.layer_at_work(edges[0]) == 1  # reaching a level activates the next layer
    assert wm.layer_at_work(edges[-1] * 2) == atlas.n_layers - 1


def test_bad_volume_is_rejected(atlas: Atlas) -> None:
    wm = WearModel.from_atlas(atlas)
    with pytest.raises(ValueError, match="volume must be in"):
        wm.work_at_volume(0.01)
    with pytest.raises(ValueError, match="n_events > 0"):
        wm.identify_k(0.5, 0)


def test_layers_that_do_not_tile_the_volume_are_rejected() -> None:
    one = np.array([2e-3])
    with pytest.raises(ValueError, match="run down from volume"):
        WearModel.from_layer_wear(np.array([0.9]), np.array([0.8]), one, 1e-4)
    with pytest.raises(ValueError, match="run down from volume"):  # a gap between layers
        WearModel.from_layer_wear(np.array([1.0, 0.85]), np.array([0.9, 0.8]), one.repeat(2), 1e-4)
    with pytest.raises(ValueError, match="wear_per_k_m3 must be finite and > 0"):
        WearModel.from_layer_wear(np.array([1.0]), np.array([0.8]), np.array([0.0]), 1e-4)
    with pytest.raises(ValueError, match="1-D arrays of one length"):
        WearModel.from_layer_wear(np.array([1.0]), np.array([0.8]), one.repeat(2), 1e-4)
