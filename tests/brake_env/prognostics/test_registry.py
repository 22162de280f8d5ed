"""Predictors by name."""

from __future__ import annotations

import subprocess
import sys

import pytest

from brake_env.model.atlas import Atlas
from brake_env.prognostics.protocol import Predictor
from brake_env.prognostics.registry import make_predictor, predictor_names


@pytest.mark.parametrize("name", predictor_names())
def test_every_name_makes_its_predictor(name: str, small_atlas: Atlas) -> None:
    p = make_predictor(name, small_atlas, seed=3)
    assert isinstance(p, Predictor)
    assert p.name == name
    if name == "data":
        assert p.config.seed == 3  # type: ignore[attr-defined]


def test_unknown_name(small_atlas: Atlas) -> None:
    with pytest.raises(ValueError, match=r"valid are.*physics"):
        make_predictor("lstm", small_atlas)


def test_plugins_are_listed_in_pipeline_order_without_importing_them() -> None:
    code = (
        "import sys; from brake_env.prognostics.registry import predictor_names;"
        " names = predictor_names();"
        " loaded = [m for m in ('torch', 'twin', 'baselines') if m in sys.modules];"
        " print(','.join(names)); print(','.join(loaded))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    names, loaded = out.stdout.splitlines()
    assert names.split(",")[:4] == ["none", "physics", "data", "twin"]
    assert names.split(",")[-1] == "oracle"
    assert loaded == ""  # names come from entry-point metadata, not from importing
