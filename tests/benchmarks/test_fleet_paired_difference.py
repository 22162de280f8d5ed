"""benchmarks/analysis/fleet_paired_difference.py on made-up studies: paired figures,
refused mismatches."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.benchmarks import load_script


def _study(path: Path, policy: str, cost: list[float], seeds: list[int]) -> str:
    row = {"predictor": "oracle", "policy": policy,
           "episodes": {"seed": seeds, "cost": cost, "net": [c - 1 for c in cost]}}  # fmt: skip
    path.write_text(json.dumps({"config": {"size": "default", "shifts": 365}, "rows": [row]}))
    return str(path)


def test_two_studies_are_paired_episode_by_episode_or_refused(tmp_path):
    fp = load_script("fleet_paired_difference")
    a = _study(tmp_path / "a.json", "x", [3.0, 2.0, 4.0], [0, 1, 2])
    b = _study(tmp_path / "b.json", "y", [3.5, 2.5, 4.5], [0, 1, 2])
    got = fp.compare((a, "oracle/x"), (b, "oracle/y"))
    assert [r[0] for r in got[1:]] == ["cost", "net"]
    assert got[1][1:3] == ["3.000", "3.500"] and got[2][1:3] == ["2.000", "2.500"]
    assert got[1][3].startswith("-0.5 [-0.5, -0.5]")  # the same difference on every episode
    c = _study(tmp_path / "c.json", "y", [3.5, 2.5, 4.5], [0, 1, 3])
    with pytest.raises(SystemExit, match="the episodes differ"):
        fp.compare((a, "oracle/x"), (c, "oracle/y"))
    with pytest.raises(SystemExit, match="no row 'oracle/z'"):
        fp.compare((a, "oracle/z"), (b, "oracle/y"))
