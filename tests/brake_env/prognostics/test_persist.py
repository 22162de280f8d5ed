"""Saved predictors: same estimates after loading, versioned header, atlas checked, and no
pickle on the way in."""

from __future__ import annotations

import hashlib
import json
import math
import pathlib
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
from numpy.typing import NDArray

from brake_env.data.datasets import Dataset, DatasetSpec, make_dataset
from brake_env.model.atlas import Atlas, AtlasSpec
from brake_env.model.regime import WearRegime
from brake_env.prognostics.persist import (
    ARRAYS,
    FORMAT_VERSION,
    HEADER,
    load_predictor,
    read_header,
    save_predictor,
)
from brake_env.prognostics.protocol import NoPrognostics, Oracle, Predictor, predict_log
from brake_env.prognostics.registry import make_predictor

SPEC = DatasetSpec(n_train=3, n_id=2, n_ood_slow=0, n_ood_fast=0, wear=WearRegime(1e-4, 1e-5))


@pytest.fixture(scope="module")
def data(small_atlas: Atlas) -> Dataset:
    return make_dataset(small_atlas, SPEC, seed=4)


def _strict(path: Path) -> Any:
    def refuse(token: str) -> None:
        raise ValueError(f"non-standard JSON token {token}")

    return json.loads(path.read_text(), parse_constant=refuse)


@pytest.mark.parametrize("name", ["none", "oracle", "physics", "twin"])
def test_loaded_predictor_gives_the_same_estimates(
    name: str, small_atlas: Atlas, data: Dataset, tmp_path: Path
) -> None:
    fitted = make_predictor(name, small_atlas).fit(data.logs["train"])
    save_predictor(fitted, tmp_path / "m", small_atlas, info={"data": "train"})
    loaded = load_predictor(tmp_path / "m", small_atlas)
    assert type(loaded) is type(fitted) and loaded is not fitted
    pd.testing.assert_frame_equal(
        predict_log(loaded, data.logs["id"]), predict_log(fitted, data.logs["id"])
    )
    header = _strict(tmp_path / "m" / HEADER)
    assert header["format_version"] == FORMAT_VERSION and header["predictor"] == name
    assert header["atlas_hash"] == small_atlas.content_hash
    assert AtlasSpec.from_dict(header["atlas_spec"]).content_hash() == small_atlas.content_hash
    assert header["package_version"] and header["info"] == {"data": "train"}
    assert sorted(p.name for p in (tmp_path / "m").iterdir()) == [ARRAYS, HEADER]


def test_state_round_trips_settings_json_cannot_hold(small_atlas: Atlas, tmp_path: Path) -> None:
    save_predictor(NoPrognostics(mean_life_events=math.inf), tmp_path / "m", small_atlas)
    assert _strict(tmp_path / "m" / HEADER)["meta"] == {"mean_life_events": {"$float": "inf"}}
    loaded = load_predictor(tmp_path / "m", small_atlas)
    assert isinstance(loaded, NoPrognostics) and loaded.mean_life_events == math.inf
    assert Oracle().get_state() == ({}, {})


def test_another_atlas_or_format_version_is_refused(small_atlas: Atlas, tmp_path: Path) -> None:
    m = save_predictor(NoPrognostics(1000.0), tmp_path / "m", small_atlas)
    other = Atlas.build(AtlasSpec(n_speed=4, n_mass=2, n_slope=3))
    with pytest.raises(ValueError, match="fitted with atlas") as e:
        load_predictor(m, other)
    assert small_atlas.content_hash[:16] in str(e.value) and other.content_hash[:16] in str(e.value)
    header = json.loads((m / HEADER).read_text())
    for version, hint in ((FORMAT_VERSION + 1, "upgrade brakewear"), (0, "refit")):
        (m / HEADER).write_text(json.dumps({**header, "format_version": version}))
        with pytest.raises(ValueError, match=f"format version {version}.*{hint}"):
            read_header(m)
    (m / HEADER).write_text(json.dumps({**header, "predictor": "lstm"}))
    with pytest.raises(ValueError, match="unknown predictor 'lstm'"):
        load_predictor(m, small_atlas)


def test_cut_off_or_mixed_model_directories_are_refused(small_atlas: Atlas, tmp_path: Path) -> None:
    a = save_predictor(NoPrognostics(1000.0), tmp_path / "a", small_atlas)
    b = save_predictor(NoPrognostics(2000.0), tmp_path / "b", small_atlas)
    (a / ARRAYS).write_bytes((b / ARRAYS).read_bytes() + b"\0")
    with pytest.raises(
        ValueError, match=r"arrays\.npz is not the file its header was written with"
    ):
        load_predictor(a, small_atlas)
    (b / HEADER).unlink()  # the header is written last: a cut-off save has none
    with pytest.raises(FileNotFoundError, match="cut off"):
        load_predictor(b, small_atlas)
    (b / HEADER).write_text("{not json")
    with pytest.raises(ValueError, match="not valid JSON"):
        read_header(b)
    with pytest.raises(FileNotFoundError, match="no such directory"):
        read_header(tmp_path / "nowhere")


class _Marker:
    """Pickles to a call that creates a file: proof that unpickling happened."""

    def __init__(self, path: Path) -> None:
        self.path = path

    def __reduce__(self) -> tuple[Any, ...]:
        return (pathlib.Path.touch, (pathlib.Path(self.path),))


def test_arrays_are_never_unpickled(small_atlas: Atlas, tmp_path: Path) -> None:
    m = save_predictor(NoPrognostics(1000.0), tmp_path / "m", small_atlas)
    marker = tmp_path / "unpickled"
    payload = np.empty(1, dtype=object)
    payload[0] = _Marker(marker)
    np.savez(m / ARRAYS, w=payload)  # a crafted file with a pickled object inside
    header = json.loads((m / HEADER).read_text())
    header["arrays_sha256"] = hashlib.sha256((m / ARRAYS).read_bytes()).hexdigest()
    (m / HEADER).write_text(json.dumps(header))
    with pytest.raises(ValueError, match=r"unreadable arrays\.npz"):
        load_predictor(m, small_atlas)
    assert not marker.exists()


class _Objects(NoPrognostics):
    def get_state(self) -> tuple[dict[str, Any], dict[str, NDArray[Any]]]:
        return {}, {"w": np.array([{"a": 1}], dtype=object)}


class _Unsaveable(Predictor):
    def _update(self, events: Any) -> Any:
        raise NotImplementedError


def test_what_cannot_be_saved_without_pickle_is_refused(small_atlas: Atlas, tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="state array 'w' is object"):
        save_predictor(_Objects(1.0), tmp_path / "m", small_atlas)
    with pytest.raises(NotImplementedError, match="cannot be saved"):
        save_predictor(_Unsaveable(), tmp_path / "m", small_atlas)
    assert not (tmp_path / "m").exists()
    (tmp_path / "f").write_text("")
    with pytest.raises(ValueError, match="not a directory"):
        save_predictor(NoPrognostics(1.0), tmp_path / "f", small_atlas)
