"""examples/rl_rule_policy.py runs and does what it says (every example is run by a
test with the Agg backend)."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

import pytest

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "rl_rule_policy.py"


def _load() -> ModuleType:
    spec = importlib.util.spec_from_file_location("rl_rule_policy", EXAMPLE)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_rl_rule_policy_example(monkeypatch: pytest.MonkeyPatch, capsys) -> None:
    monkeypatch.setenv("MPLBACKEND", "Agg")
    result = _load().main(episodes=2, episode_events=60_000)
    assert result["episodes"] == 2 and result["events"] == 120_000
    # Pads last ~2.4e4 events, so every episode takes some off; at the default weights a
    # planned replacement costs 1000 and a failure 10,000.
    assert result["planned_replacements"] + result["failures"] >= 2
    cost = 1000 * result["planned_replacements"] + 10_000 * result["failures"]
    assert result["cost_per_1000_events"] == pytest.approx(1000 * cost / result["events"])
    assert result["oracle_cost_per_1000_events"] > 0
    assert "per 1000 braking events" in capsys.readouterr().out
