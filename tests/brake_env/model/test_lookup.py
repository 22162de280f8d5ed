"""The atlas lookup: every layer at once agrees with per-layer queries."""

from __future__ import annotations

import numpy as np
import pytest

from brake_env.model.atlas import Atlas


def test_profile_matches_atlas_query(atlas: Atlas) -> None:
    rng = np.random.default_rng(0)
    n = 50
    s = rng.uniform(atlas.speed_mps[0], atlas.speed_mps[-1], n)
    m = rng.uniform(atlas.mass_kg[0], atlas.mass_kg[-1], n)
    th = rng.uniform(atlas.slope_rad[0], atlas.slope_rad[-1], n)
    t_all, dt_all = atlas.lookup.profile(s, m, th)
    layers = np.arange(atlas.n_layers)
    ref = atlas.query(s[:, None], m[:, None], th[:, None], layer=layers[None, :])["temp_mean_c"]
    np.testing.assert_allclose(t_all, ref, rtol=1e-12)
    h = 1e-6  # the slope derivative is the trilinear interpolant's, away from cell faces
    up = atlas.query(s[:, None], m[:, None], th[:, None] + h, layer=layers[None, :], clip=True)
    np.testing.assert_allclose(dt_all, (up["temp_mean_c"] - ref) / h, rtol=1e-4, atol=1e-3)
    lay = rng.integers(0, atlas.n_layers, n)
    t_one, dt_one = atlas.lookup.profile(s, m, th, layer=lay)
    np.testing.assert_allclose(t_one, t_all[np.arange(n), lay], rtol=1e-12)
    np.testing.assert_allclose(dt_one, dt_all[np.arange(n), lay], rtol=1e-12)


def test_profiles_is_profile_as_one_matrix_product(atlas: Atlas) -> None:
    rng = np.random.default_rng(1)
    n = 400
    lo = np.array([atlas.speed_mps[0], atlas.mass_kg[0], atlas.slope_rad[0]])
    hi = np.array([atlas.speed_mps[-1], atlas.mass_kg[-1], atlas.slope_rad[-1]])
    s, m, th = (lo - 0.05 * (hi - lo) + 1.1 * (hi - lo) * rng.random((n, 3))).T  # some outside
    s[:40] = rng.choice(atlas.speed_mps, 40)  # on nodes
    # The one-pass locate is locate's arithmetic: the same cells and fractions, bit for bit.
    cell, frac = atlas.lookup.locate(s, m, th, clip=True)
    cell1, frac1 = atlas.lookup._locate_points(s, m, th)
    assert np.array_equal(cell, cell1) and np.array_equal(frac, frac1)
    t, dt = atlas.lookup.profile(s, m, th)
    both = atlas.lookup.profiles(s, m, th)
    np.testing.assert_allclose(both[:, 0], t, rtol=1e-14)
    np.testing.assert_allclose(both[:, 1], dt, rtol=0, atol=1e-14 * np.abs(dt).max())
    part = atlas.lookup.profiles(s, m, th, layers=slice(10, 30))
    np.testing.assert_allclose(part, both[:, :, 10:30], rtol=1e-14, atol=1e-14)
    with pytest.raises(ValueError, match="slope_rad must be finite"):
        atlas.lookup.profiles(s[:2], m[:2], np.array([0.1, np.nan]))
