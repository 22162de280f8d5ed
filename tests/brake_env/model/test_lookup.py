"""The atlas lookup: every layer at once agrees with per-layer queries."""

from __future__ import annotations

import numpy as np

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
