"""An atlas built with an unmodelled effect: the effect is in its spec, its hash, its file
and its cache entry, so a model fitted on it never meets the nominal atlas in silence."""

from __future__ import annotations

import dataclasses
import hashlib
import json
from pathlib import Path

import numpy as np
import pytest

from brake_env.model.atlas import FORMAT_VERSION, PHYSICS_VERSION, Atlas, AtlasSpec, cached_atlas
from brake_env.model.effects import canonical_effects

TINY = AtlasSpec(n_speed=4, n_mass=2, n_slope=3)


def test_a_nominal_spec_hashes_as_before_effects_existed() -> None:
    """Cached atlases and saved models of the nominal physics stay valid."""
    spec = AtlasSpec()
    old = {k: v for k, v in dataclasses.asdict(spec).items() if k != "effects"}
    payload = json.dumps(
        {"format": FORMAT_VERSION, "physics": PHYSICS_VERSION, "spec": old}, sort_keys=True
    )
    assert spec.content_hash() == hashlib.sha256(payload.encode()).hexdigest()


def test_an_effect_changes_the_hash_and_survives_json() -> None:
    with_effect = dataclasses.replace(TINY, effects=("heat_partition:phi=0.25",))
    other = dataclasses.replace(TINY, effects=("heat_partition:phi=0.2",))
    hashes = {TINY.content_hash(), with_effect.content_hash(), other.content_hash()}
    assert len(hashes) == 3
    back = AtlasSpec.from_dict(json.loads(json.dumps(with_effect.to_dict())))
    assert back == with_effect and back.content_hash() == with_effect.content_hash()


def test_effects_are_canonical_and_checked() -> None:
    assert canonical_effects(["heat_partition:phi=0.250"]) == ("heat_partition:phi=0.25",)
    assert canonical_effects(["tc_bias:bias_k=0"]) == ()  # neutral: the nominal physics
    with pytest.raises(ValueError, match="acts between events"):
        canonical_effects(["newton_cooling:tau_s=60"])
    with pytest.raises(ValueError, match="unknown effect 'glaze'"):
        canonical_effects(["glaze:g=1"])
    with pytest.raises(ValueError, match="more than once"):
        canonical_effects(["heat_partition:phi=0.1", "heat_partition:phi=0.2"])
    with pytest.raises(ValueError, match=r"AtlasSpec\.effects"):
        AtlasSpec(effects=("",))


def test_a_sensor_effect_changes_only_the_logged_temperature() -> None:
    nominal = Atlas.build(TINY)
    biased = Atlas.build(dataclasses.replace(TINY, effects=("tc_bias:bias_k=7.5",)))
    np.testing.assert_array_equal(biased.fields["temp_mean_c"], nominal.fields["temp_mean_c"] + 7.5)
    for name in set(nominal.fields) - {"temp_mean_c"}:
        np.testing.assert_array_equal(biased.fields[name], nominal.fields[name])
    lagged = Atlas.build(dataclasses.replace(TINY, effects=("tc_lag:tau_s=0.5",)))
    # A lagging sensor reads the mean of a rising temperature low, never high.
    assert (lagged.fields["temp_mean_c"] < nominal.fields["temp_mean_c"]).all()


def test_an_effect_atlas_saves_loads_and_caches_under_its_own_hash(tmp_path: Path) -> None:
    spec = dataclasses.replace(TINY, effects=("heat_partition:phi=0.25",))
    built = cached_atlas(spec, tmp_path)
    nominal = cached_atlas(TINY, tmp_path)
    assert len(list(tmp_path.glob("atlas-*.npz"))) == 2
    assert built.content_hash != nominal.content_hash
    # Less heat into the pad: every event runs cooler than on the nominal atlas.
    n = min(built.n_layers, nominal.n_layers)
    assert (built.fields["temp_mean_c"][:n] < nominal.fields["temp_mean_c"][:n]).all()
    loaded = Atlas.load(built.save(tmp_path / "effect.npz"))
    assert loaded.spec.effects == ("heat_partition:phi=0.25",)
    np.testing.assert_array_equal(loaded.fields["temp_mean_c"], built.fields["temp_mean_c"])
