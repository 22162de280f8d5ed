"""Saved models (issue 22 item 4): each predictor refuses a state that does not match its
own schema (unknown or missing keys, non-finite numbers, another predictor's state) with
one ValueError naming the field, never a KeyError or a confident estimate."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from baselines.mlp import MLPConfig, MLPPredictor
from baselines.physics import PhysicsPredictor
from baselines.window import WindowPredictor
from brake_env.model.atlas import Atlas
from brake_env.output import write_arrays
from brake_env.prognostics.persist import ARRAYS, HEADER, load_predictor, save_predictor
from brake_env.prognostics.protocol import NoPrognostics, Oracle, Predictor
from tests.baselines.synthetic import wear_log
from twin import DigitalTwin, TwinCalibration

LIVES = [3000, 3600, 4200, 3300]


@pytest.fixture(scope="module")
def fitted(small_atlas: Atlas) -> dict[str, Predictor]:
    train = wear_log(LIVES)
    cal = TwinCalibration(k_log_mean=math.log(2e-6), k_log_scale=0.1, n_runs=3)
    return {
        "twin": DigitalTwin(small_atlas, calibration=cal),
        "physics": PhysicsPredictor(small_atlas).fit(train),
        "window": WindowPredictor().fit(train),
        "none": NoPrognostics().fit(train),
        "data": MLPPredictor(MLPConfig(epochs=1)).fit(train),
        "oracle": Oracle(),
    }


def _fresh(p: Predictor, atlas: Atlas) -> Predictor:
    return {
        "twin": lambda: DigitalTwin(atlas),
        "physics": lambda: PhysicsPredictor(atlas),
        "window": WindowPredictor,
        "none": NoPrognostics,
        "data": MLPPredictor,
        "oracle": Oracle,
    }[p.name]()


def _roundtrip(meta: dict[str, Any]) -> dict[str, Any]:
    return json.loads(json.dumps(meta))


NAMES = ["twin", "physics", "window", "none", "data", "oracle"]


@pytest.mark.parametrize("name", NAMES)
def test_unknown_setting_is_named(fitted, small_atlas, name) -> None:
    meta, arrays = fitted[name].get_state()
    with pytest.raises(ValueError, match=r"unknown \['surprise'\]"):
        _fresh(fitted[name], small_atlas).set_state({**_roundtrip(meta), "surprise": 1}, arrays)


@pytest.mark.parametrize("name", [n for n in NAMES if n != "oracle"])
def test_missing_setting_is_named(fitted, small_atlas, name) -> None:
    meta, arrays = fitted[name].get_state()
    meta = _roundtrip(meta)
    key = sorted(k for k in meta if k not in ("state_version", "channels", "features"))[0]
    del meta[key]
    with pytest.raises(ValueError, match=rf"lacks \['{key}'\]"):
        _fresh(fitted[name], small_atlas).set_state(meta, arrays)


@pytest.mark.parametrize("name", ["window", "data"])  # physics: NaN K of censored runs
def test_non_finite_arrays_are_refused(fitted, small_atlas, name) -> None:
    meta, arrays = fitted[name].get_state()
    key = next(k for k, a in arrays.items() if a.dtype.kind == "f")
    bad = {**arrays, key: np.full_like(arrays[key], np.nan)}
    with pytest.raises(ValueError, match=rf"'{key}' holds \d+ non-finite"):
        _fresh(fitted[name], small_atlas).set_state(_roundtrip(meta), bad)


@pytest.mark.parametrize(
    ("name", "field", "value", "match"),
    [
        ("physics", "k_avg", float("nan"), "'k_avg' holds 1 non-finite"),
        ("none", "mean_life_events", "lots", "'mean_life_events' is 'lots', not a life"),
        ("none", "mean_life_events", float("nan"), "'mean_life_events' is nan"),
        ("window", "index_sd", float("inf"), "'index_sd' holds 1 non-finite"),
        ("data", "x_std", [1.0, float("nan"), 1, 1, 1], "'x_std' holds 1 non-finite"),
    ],
)
def test_non_finite_settings_are_refused(fitted, small_atlas, name, field, value, match) -> None:
    meta, arrays = fitted[name].get_state()
    with pytest.raises(ValueError, match=match):
        _fresh(fitted[name], small_atlas).set_state({**meta, field: value}, arrays)


def test_twin_calibration_fields_are_checked(fitted, small_atlas) -> None:
    meta = _roundtrip(fitted["twin"].get_state()[0])
    twin = DigitalTwin(small_atlas)
    cal = meta["calibration"]
    with pytest.raises(ValueError, match=r"TwinCalibration.*lacks \['k_log_scale'\]"):
        twin.set_state(
            {**meta, "calibration": {k: v for k, v in cal.items() if k != "k_log_scale"}}, {}
        )
    with pytest.raises(ValueError, match=r"TwinCalibration.*unknown \['k_typo'\]"):
        twin.set_state({**meta, "calibration": {**cal, "k_typo": 1.0}}, {})
    with pytest.raises(ValueError, match="k_log_mean is 'x', not a number"):
        twin.set_state({**meta, "calibration": {**cal, "k_log_mean": "x"}}, {})
    with pytest.raises(ValueError, match="k_log_mean must be finite"):
        twin.set_state({**meta, "calibration": {**cal, "k_log_mean": "nan"}}, {})
    with pytest.raises(ValueError, match="TwinConfig is list, not a dict"):
        twin.set_state({**meta, "config": [1, 2]}, {})


def _edit_saved(path: Path, name: str | None = None, arrays: dict | None = None) -> None:
    header = json.loads((path / HEADER).read_text())
    if name is not None:
        header["predictor"] = name
    if arrays is not None:  # the checksum recomputed: a deliberate edit, not damage
        header["arrays_sha256"] = write_arrays(arrays, path / ARRAYS, compress=True)
    (path / HEADER).write_text(json.dumps(header))


@pytest.mark.parametrize(
    ("saved", "edited"),
    [("twin", "physics"), ("physics", "twin"), ("window", "none"), ("none", "window")],
)
def test_predictor_name_edited_is_one_clear_error(fitted, small_atlas, tmp_path, saved, edited):
    path = save_predictor(fitted[saved], tmp_path / saved, small_atlas)
    _edit_saved(path, name=edited)
    with pytest.raises(ValueError, match=rf"names predictor '{edited}', and the saved state"):
        load_predictor(path, small_atlas)


def test_window_with_all_nan_arrays_is_refused(fitted, small_atlas, tmp_path) -> None:
    path = save_predictor(fitted["window"], tmp_path / "w", small_atlas)
    _, arrays = fitted["window"].get_state()
    _edit_saved(path, arrays={k: np.full_like(a, np.nan) for k, a in arrays.items()})
    with pytest.raises(ValueError, match=r"non-finite value.*refit it"):
        load_predictor(path, small_atlas)


@pytest.mark.parametrize("name", NAMES)
def test_untouched_states_still_load(fitted, small_atlas, tmp_path, name) -> None:
    path = save_predictor(fitted[name], tmp_path / name, small_atlas)
    got = load_predictor(path, small_atlas).get_state()[0]
    assert got == _roundtrip(fitted[name].get_state()[0])
