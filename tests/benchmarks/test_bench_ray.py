"""benchmarks/bench_ray.py's account of where the time goes: the stored units' own seconds
(a number or a dict of parts) summed, and nothing for a command that keeps none."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.benchmarks import load_script

bench_ray = load_script("bench_ray")


def _unit(path: Path, result: object) -> None:
    path.write_text(json.dumps({"key": path.stem, "arrays_sha256": None, "result": result}))


def test_unit_seconds_sums_every_units_parts(tmp_path):
    units = tmp_path / "units"
    units.mkdir()
    _unit(units / "a.json", {"seconds": {"tune": 2.5, "evaluate": 1.0}, "cost": 9.0})
    _unit(units / "b.json", {"seconds": 4.0})
    _unit(units / "c.json", {"cost": 1.0})  # no time kept: not counted
    (units / "settings.json").write_text(json.dumps({"size": "small"}))
    assert bench_ray.unit_seconds(tmp_path) == pytest.approx(7.5)


def test_no_units_no_figure(tmp_path):
    assert bench_ray.unit_seconds(tmp_path) is None
    (tmp_path / "units").mkdir()
    _unit(tmp_path / "units" / "a.json", [1, 2])
    assert bench_ray.unit_seconds(tmp_path) is None
