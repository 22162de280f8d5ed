import numpy as np
import pytest

from brake_env.model.atlas import FIELDS, Atlas, AtlasSpec, cached_atlas
from brake_env.model.physics import simulate_events


def test_layers_run_from_fresh_to_failure_in_one_percent_steps(atlas) -> None:
    assert atlas.volumes[0] == 1.0
    np.testing.assert_allclose(np.diff(atlas.volumes), -0.01, atol=1e-12)
    assert atlas.volumes[-1] > atlas.critical_volume > atlas.volumes[-1] - 0.01
    assert all(np.isfinite(a).all() for a in atlas.fields.values())


def test_node_values_are_the_physics_exactly(small_atlas) -> None:
    a = small_atlas
    j, i, k, n = 5, 2, 1, 3
    r = simulate_events(a.speed_mps[i], a.mass_kg[k], a.slope_rad[n], a.volumes[j], a.spec.model)
    for f in FIELDS:
        assert a.fields[f][j, i, k, n] == getattr(r, f)


def test_query_at_every_node_returns_the_stored_value(small_atlas) -> None:
    a = small_atlas
    s, m, th = np.meshgrid(a.speed_mps, a.mass_kg, a.slope_rad, indexing="ij")
    for j in (0, a.n_layers // 2, a.n_layers - 1):
        q = a.query(s, m, th, layer=np.int64(j))
        for f in FIELDS:
            np.testing.assert_array_equal(q[f], a.fields[f][j])
        # By volume: the layer's own volume selects it exactly, with or without blending.
        qv = a.query(s, m, th, volume_frac=a.volumes[j], interpolate_layers=True)
        np.testing.assert_array_equal(qv["temp_mean_c"], a.fields["temp_mean_c"][j])


def test_interpolation_is_close_to_the_physics_between_nodes(atlas) -> None:
    rng = np.random.default_rng(3)
    n = 3000
    s, m = rng.uniform(4, 15, n) / 3.6, rng.uniform(42e3, 54e3, n)
    th = np.radians(rng.uniform(0, 10, n))
    lay = rng.integers(0, atlas.n_layers, n)
    q = atlas.query(s, m, th, layer=lay)
    r = simulate_events(s, m, th, atlas.volumes[lay], atlas.spec.model)
    for f, tol in (("temp_mean_c", 1e-3), ("stop_dist_m", 5e-3), ("wear_per_k_m3", 5e-3)):
        rel = np.abs(q[f] / getattr(r, f) - 1)
        assert rel.mean() < tol, (f, rel.mean())


def test_layer_interpolation_blends_linearly(small_atlas) -> None:
    a = small_atlas
    s, m, th = a.speed_mps[2], a.mass_kg[1], a.slope_rad[3]
    v = a.volumes[4] - 0.25 * a.spec.layer_step
    q = a.query(s, m, th, volume_frac=v, interpolate_layers=True)["wear_per_k_m3"]
    w4, w5 = a.fields["wear_per_k_m3"][4:6, 2, 1, 3]
    assert q == pytest.approx(0.75 * w4 + 0.25 * w5, rel=1e-12)
    active = a.query(s, m, th, volume_frac=v)["wear_per_k_m3"]
    assert active == w4  # without blending, the active (higher-volume) layer


def test_expected_is_the_uniform_mean_of_the_interpolant(small_atlas) -> None:
    a = small_atlas
    # Midpoint rule on a fine grid converges to the exact mean of the trilinear interpolant.
    n = 60
    u = (np.arange(n) + 0.5) / n
    s = a.speed_mps[0] + u * (a.speed_mps[-1] - a.speed_mps[0])
    m = a.mass_kg[0] + u * (a.mass_kg[-1] - a.mass_kg[0])
    th = a.slope_rad[0] + u * (a.slope_rad[-1] - a.slope_rad[0])
    S, M, T = np.meshgrid(s, m, th, indexing="ij")
    for j in (0, a.n_layers - 1):
        mean = a.query(S, M, T, layer=np.int64(j))["wear_per_k_m3"].mean()
        assert a.expected("wear_per_k_m3")[j] == pytest.approx(mean, rel=2e-4)


def test_save_load_round_trip_without_pickle(tmp_path, small_atlas) -> None:
    path = small_atlas.save(tmp_path / "a.npz")
    b = Atlas.load(path)
    assert b.content_hash == small_atlas.content_hash
    assert b.critical_volume == small_atlas.critical_volume
    for f in FIELDS:
        np.testing.assert_array_equal(b.fields[f], small_atlas.fields[f])
    with np.load(path, allow_pickle=False) as z:  # loads with pickle disabled
        assert "meta" in z


def test_tampered_file_is_rejected(tmp_path, small_atlas) -> None:
    import json

    path = small_atlas.save(tmp_path / "a.npz")
    with np.load(path, allow_pickle=False) as z:
        data = {k: z[k] for k in z.files}
    meta = json.loads(str(data["meta"]))
    meta["spec"]["n_speed"] = 99  # parameters no longer match the stored hash
    data["meta"] = np.array(json.dumps(meta))
    np.savez(tmp_path / "bad.npz", **data)
    with pytest.raises(ValueError, match="hash"):
        Atlas.load(tmp_path / "bad.npz")


def _leaves(d: dict, prefix: tuple = ()):
    for k, v in d.items():
        if isinstance(v, dict):
            yield from _leaves(v, (*prefix, k))
        else:
            yield (*prefix, k), v


def _nudged(v):
    if isinstance(v, bool):
        return not v
    if isinstance(v, int):
        return v + 1
    if isinstance(v, float):
        return v * 1.01 + 1e-3
    if v == ():  # the effects: none -> one
        return ("heat_partition:phi=0.1",)
    return (v[0], v[1] * 0.99)  # a (min, max) range


def test_hash_depends_on_every_parameter() -> None:
    base = AtlasSpec()
    assert base.content_hash() == AtlasSpec().content_hash()
    seen = set()
    for path, value in _leaves(base.to_dict()):
        d = base.to_dict()
        node = d
        for k in path[:-1]:
            node = node[k]
        node[path[-1]] = _nudged(value)
        changed = AtlasSpec.from_dict(d).content_hash()
        assert changed != base.content_hash(), path
        seen.add(changed)
    assert len(seen) == len(list(_leaves(base.to_dict())))  # every leaf, a different hash


def test_edited_arrays_are_rejected(tmp_path, small_atlas) -> None:
    path = small_atlas.save(tmp_path / "a.npz")
    with np.load(path, allow_pickle=False) as z:
        data = {k: z[k] for k in z.files}
    data["field_wear_per_k_m3"] = data["field_wear_per_k_m3"] * 1.0001
    np.savez(tmp_path / "edited.npz", **data)
    with pytest.raises(ValueError, match="checksum"):
        Atlas.load(tmp_path / "edited.npz")


def test_corrupt_cache_entry_is_rebuilt(tmp_path) -> None:
    spec = AtlasSpec(n_speed=4, n_mass=2, n_slope=3)
    first = cached_atlas(spec, tmp_path)
    (entry,) = tmp_path.glob("atlas-*.npz")
    entry.write_bytes(entry.read_bytes()[:1000])  # truncated, e.g. by a full disk
    again = cached_atlas(spec, tmp_path)
    np.testing.assert_array_equal(again.fields["temp_mean_c"], first.fields["temp_mean_c"])
    Atlas.load(entry)  # the entry was rewritten whole


def test_cache_builds_once(tmp_path, monkeypatch) -> None:
    spec = AtlasSpec(n_speed=4, n_mass=2, n_slope=3)
    first = cached_atlas(spec, tmp_path)
    assert len(list(tmp_path.glob("atlas-*.npz"))) == 1

    def no_build(*a, **k):
        raise AssertionError("rebuilt although cached")

    monkeypatch.setattr(Atlas, "build", no_build)
    second = cached_atlas(spec, tmp_path)
    np.testing.assert_array_equal(second.fields["temp_mean_c"], first.fields["temp_mean_c"])


def test_bad_queries_name_the_argument(small_atlas) -> None:
    a = small_atlas
    with pytest.raises(ValueError, match="speed_mps"):
        a.query(20.0, 5e4, 0.1, layer=np.int64(0))
    with pytest.raises(ValueError, match="slope_rad"):
        a.query(3.0, 5e4, -0.2, layer=np.int64(0))
    with pytest.raises(ValueError, match="layer"):
        a.query(3.0, 5e4, 0.1, layer=np.int64(a.n_layers))
    with pytest.raises(ValueError, match="volume_frac"):
        a.query(3.0, 5e4, 0.1, volume_frac=0.05)
    with pytest.raises(ValueError, match="finite"):
        a.query(np.nan, 5e4, 0.1, layer=np.int64(0))
    with pytest.raises(ValueError, match="volume_frac"):
        a.query(3.0, 5e4, 0.1, volume_frac=np.nan)
    with pytest.raises(ValueError, match="exactly one"):
        a.query(3.0, 5e4, 0.1)
    with pytest.raises(ValueError, match="unknown atlas field"):
        a.query(3.0, 5e4, 0.1, layer=np.int64(0), fields=("friction",))
    clipped = a.query(20.0, 5e4, 0.1, layer=np.int64(0), clip=True)["temp_mean_c"]
    edge = a.query(a.speed_mps[-1], 5e4, 0.1, layer=np.int64(0))["temp_mean_c"]
    assert clipped == edge
