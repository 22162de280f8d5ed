"""Closed-form wear path and the atlas temperature table."""

from __future__ import annotations

import numpy as np
import pytest

from brake_env.model.atlas import Atlas
from brake_env.model.simulator import expected_life
from brake_env.model.wear import TemperatureTable, WearModel


def test_life_matches_simulator_expected_life(atlas: Atlas) -> None:
    wm = WearModel.from_atlas(atlas)
    ks = np.array([1e-6, 2e-6, 3.3e-6])
    np.testing.assert_allclose(wm.life(ks), expected_life(atlas, ks), rtol=1e-12)


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


def test_temperature_table_matches_atlas_query(atlas: Atlas) -> None:
    rng = np.random.default_rng(0)
    n = 50
    s = rng.uniform(atlas.speed_mps[0], atlas.speed_mps[-1], n)
    m = rng.uniform(atlas.mass_kg[0], atlas.mass_kg[-1], n)
    th = rng.uniform(atlas.slope_rad[0], atlas.slope_rad[-1], n)
    table = TemperatureTable(atlas)
    t_all, dt_all = table.all_layers(s, m, th)
    layers = np.arange(atlas.n_layers)
    ref = atlas.query(s[:, None], m[:, None], th[:, None], layer=layers[None, :])["temp_mean_c"]
    np.testing.assert_allclose(t_all, ref, rtol=1e-12)
    h = 1e-6  # the slope derivative is the trilinear interpolant's, away from cell faces
    up = atlas.query(s[:, None], m[:, None], th[:, None] + h, layer=layers[None, :], clip=True)
    np.testing.assert_allclose(dt_all, (up["temp_mean_c"] - ref) / h, rtol=1e-4, atol=1e-3)
    lay = rng.integers(0, atlas.n_layers, n)
    t_one, dt_one = table.at_layers(s, m, th, lay)
    np.testing.assert_allclose(t_one, t_all[np.arange(n), lay], rtol=1e-12)
    np.testing.assert_allclose(dt_one, dt_all[np.arange(n), lay], rtol=1e-12)


def test_bad_volume_is_rejected(atlas: Atlas) -> None:
    wm = WearModel.from_atlas(atlas)
    with pytest.raises(ValueError, match="volume must be in"):
        wm.work_at_volume(0.01)
    with pytest.raises(ValueError, match="n_events > 0"):
        wm.identify_k(0.5, 0)
