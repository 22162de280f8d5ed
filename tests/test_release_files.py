"""LICENSE, CITATION.cff and CHANGELOG.md agree with pyproject.toml and the package."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import brake_env

ROOT = Path(__file__).resolve().parents[1]


def _cff(key: str) -> str:
    """A top-level ``key: value`` of CITATION.cff (no YAML reader needed)."""
    found = re.search(rf"^{key}: *(.+)$", (ROOT / "CITATION.cff").read_text(), re.M)
    assert found, f"CITATION.cff has no top-level {key!r}"
    return found.group(1).strip().strip("\"'")


def test_versions_agree() -> None:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert project["version"] == brake_env.__version__ == _cff("version")
    assert _cff("cff-version") == "1.2.0"


def test_license_agrees() -> None:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert project["license"] == "MIT" == _cff("license")
    assert (ROOT / "LICENSE").read_text().startswith("MIT License")


def test_changelog_has_an_unreleased_section() -> None:
    text = (ROOT / "CHANGELOG.md").read_text()
    assert "## [Unreleased]" in text
    assert f"## [{brake_env.__version__}]" in text
