"""Predictors by name."""

from __future__ import annotations

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
