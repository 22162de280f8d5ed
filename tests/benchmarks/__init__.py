"""Tests of the scripts under ``benchmarks/`` and ``benchmarks/analysis/`` (not a package: each
is loaded by path)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

BENCHMARKS = Path(__file__).resolve().parents[2] / "benchmarks"


def load_script(name: str) -> ModuleType:
    """``benchmarks/<name>.py``, else ``benchmarks/analysis/<name>.py``, as a module
    (registered in ``sys.modules``: dataclasses look their module up)."""
    path = BENCHMARKS / f"{name}.py"
    if not path.exists():
        path = BENCHMARKS / "analysis" / f"{name}.py"
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module
