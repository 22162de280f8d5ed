"""The sim-to-real example runs and names the withheld effect."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def load(name: str) -> ModuleType:
    spec = importlib.util.spec_from_file_location(name, EXAMPLES / f"{name}.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_diagnose_log_example(capsys) -> None:
    out = load("diagnose_log").main(candidates=("heat_partition", "tc_bias", "speed_friction"))
    assert out["verdict"] == out["withheld"] == "heat_partition"
    assert out["channel"] == "temp" and out["gap_after"] < 0.3 * out["gap_before"]
    printed = capsys.readouterr().out
    assert "diagnosis: heat_partition" in printed and "structured gap in temp" in printed
