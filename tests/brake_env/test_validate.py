"""Every configuration dataclass of brake_env takes numpy scalars wherever it takes Python
numbers (issue 29), stores them as Python numbers, and still refuses bools and words."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from brake_env._validate import is_number, plain_numbers
from brake_env.env.config import CostWeights, EnvConfig, PadRegime
from brake_env.env.fleet.config import FleetConfig, FleetCosts
from brake_env.model.atlas import AtlasSpec
from brake_env.model.materials import FrictionParams, HardnessParams
from brake_env.model.params import BrakeModel, BrakeParams, OperatingRange, VehicleParams
from brake_env.model.regime import WearRegime
from brake_env.model.streams import AlternatingRoutes, SensorNoise

CONFIGS = [
    CostWeights(),
    PadRegime(),
    EnvConfig(),
    FleetCosts(),
    FleetConfig(),
    VehicleParams(),
    BrakeParams(),
    OperatingRange(),
    BrakeModel(),
    SensorNoise(),
    AlternatingRoutes(block_events=100),
    AtlasSpec(),
    WearRegime(),
    FrictionParams(),
    HardnessParams(),
]


def _numpy(value: object, kind: str) -> object:
    """``value`` (a field's default) as numpy scalars: ints as ``kind``'s integer type,
    floats as its floating type, tuples element by element; anything else unchanged."""
    if isinstance(value, bool):
        return value
    if isinstance(value, int):
        return {"32": np.int32, "64": np.int64}[kind](value)
    if isinstance(value, float):
        return {"32": np.float32, "64": np.float64}[kind](value)
    if isinstance(value, tuple):
        return tuple(_numpy(v, kind) for v in value)
    return value


def _python(value: object) -> object:
    if isinstance(value, tuple):
        return tuple(_python(v) for v in value)
    return value.item() if isinstance(value, np.generic) else value


@pytest.mark.parametrize("kind", ["32", "64"], ids=["float32-int32", "float64-int64"])
@pytest.mark.parametrize("config", CONFIGS, ids=lambda c: type(c).__name__)
def test_configs_take_numpy_scalars_as_python_numbers(config, kind) -> None:
    given = {f.name: _numpy(getattr(config, f.name), kind) for f in dataclasses.fields(config)}
    assert any(isinstance(v, np.generic | tuple) for v in given.values())
    made = type(config)(**given)
    # The same config as one made of the Python numbers the numpy scalars hold...
    assert made == type(config)(**{k: _python(v) for k, v in given.items()})
    # ...holding Python numbers: it hashes and saves like one.
    for f in dataclasses.fields(made):
        v = getattr(made, f.name)
        assert not isinstance(v, np.generic), f.name
        if isinstance(v, tuple):
            assert not any(isinstance(x, np.generic) for x in v), f.name
    hash(made)
    json.dumps(dataclasses.asdict(made))


def test_numpy_integers_in_float_fields() -> None:
    assert FleetCosts(pad=np.int64(600)).pad == 600
    assert SensorNoise(temp_c=np.int32(5)) == SensorNoise()
    assert WearRegime(ood_shift_sigma=np.int8(6)) == WearRegime()


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda: CostWeights(damage=np.bool_(True)), "CostWeights.damage must be a number"),
        (lambda: CostWeights(damage=np.float32(np.nan)), "CostWeights.damage must be >= 0"),
        (lambda: FrictionParams(mu1=np.float64(np.inf)), "FrictionParams.mu1 must be finite"),
        (lambda: WearRegime(k_mean="2e-6"), "WearRegime.k_mean must be a number"),
        (lambda: VehicleParams(n_braked_wheels=np.float32(4)), "n_braked_wheels"),
        (lambda: AtlasSpec(n_speed=np.float64(23)), "AtlasSpec.n_speed must be an int"),
        (lambda: EnvConfig(decision_interval=np.float32(500)), "decision_interval"),
        (lambda: EnvConfig(truth=np.int64(1)), "truth must be a bool"),
    ],
)
def test_configs_still_refuse_bools_nan_and_wrong_kinds(make, match) -> None:
    with pytest.raises((TypeError, ValueError), match=match):
        make()


def test_is_number() -> None:
    for x in (1, 1.5, np.int8(1), np.uint64(1), np.float32(1.5), np.float16(1)):
        assert is_number(x)
    for x in (True, np.bool_(True), "1", None, np.array(1.0), 1j):
        assert not is_number(x)


def test_plain_numbers_keeps_other_values() -> None:
    @dataclasses.dataclass(frozen=True)
    class C:
        a: object
        b: object

    c = C(np.array([1, 2]), "x")
    plain_numbers(c)
    assert isinstance(c.a, np.ndarray) and c.b == "x"
