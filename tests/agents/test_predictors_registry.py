"""Predictors by name."""

from __future__ import annotations

import pytest

from agents.predictors import PREDICTORS, make_predictor
from brake_env.atlas import Atlas
from brake_env.predictors import Predictor


@pytest.mark.parametrize("name", PREDICTORS)
def test_every_name_makes_its_predictor(name: str, small_atlas: Atlas) -> None:
    p = make_predictor(name, small_atlas, seed=3)
    assert isinstance(p, Predictor)
    assert p.name == name
    if name == "data":
        assert p.config.seed == 3  # type: ignore[attr-defined]


def test_unknown_name(small_atlas: Atlas) -> None:
    with pytest.raises(ValueError, match=r"valid are.*physics"):
        make_predictor("lstm", small_atlas)
