"""The layout rules of README "Architecture": imports flow one way, heavy libraries only
where used, short functions and modules."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOWNSTREAM = {"twin", "baselines", "agents", "sim2real"}
HEAVY = {"torch", "stable_baselines3"}


def imported_packages(package: str) -> dict[str, set[str]]:
    """Top-level packages imported anywhere in ``package`` (functions included), by file."""
    out: dict[str, set[str]] = {}
    for path in sorted((ROOT / package).rglob("*.py")):
        names: set[str] = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names |= {a.name.split(".")[0] for a in node.names}
            elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                names.add(node.module.split(".")[0])
        out[str(path.relative_to(ROOT))] = names
    return out


@pytest.mark.parametrize(
    ("package", "forbidden"),
    [
        ("brake_env", DOWNSTREAM | HEAVY),
        ("twin", (DOWNSTREAM - {"twin"}) | HEAVY),
        ("baselines", DOWNSTREAM - {"baselines"}),
        ("agents", {"sim2real"}),
        ("sim2real", {"agents"}),
    ],
)
def test_imports_flow_one_way(package: str, forbidden: set[str]) -> None:
    bad = {f: sorted(n & forbidden) for f, n in imported_packages(package).items() if n & forbidden}
    assert not bad, f"{package} imports what README 'Architecture' forbids: {bad}"


def test_torch_only_in_the_mlp_and_the_agents() -> None:
    users = {
        f
        for pkg in ("baselines", "sim2real")
        for f, names in imported_packages(pkg).items()
        if "torch" in names
    }
    assert users <= {"baselines/mlp.py"}


PACKAGES = ("brake_env", "twin", "baselines", "agents", "sim2real")
MAX_FUNCTION_LINES = 60
MAX_MODULE_LINES = 400


def test_functions_and_modules_stay_short() -> None:
    """Long functions are split into named steps; modules keep to one job."""
    long_functions, long_modules = [], []
    for path in sorted(p for pkg in PACKAGES for p in (ROOT / pkg).rglob("*.py")):
        src = path.read_text()
        rel = path.relative_to(ROOT)
        if src.count("\n") > MAX_MODULE_LINES:
            long_modules.append(f"{rel} ({src.count(chr(10))} lines)")
        for node in ast.walk(ast.parse(src)):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                n = (node.end_lineno or node.lineno) - node.lineno + 1
                if n > MAX_FUNCTION_LINES:
                    long_functions.append(f"{rel}:{node.name} ({n} lines)")
    assert not long_functions, f"functions over {MAX_FUNCTION_LINES} lines: {long_functions}"
    assert not long_modules, f"modules over {MAX_MODULE_LINES} lines: {long_modules}"


# brake_env's sub-packages in pipeline order; each imports only the ones before it (and the
# shared helpers). A stage's own command modules (commands/, cli.py, *_cli.py) may also use
# brake_env.cli.
PIPELINE = ("model", "data", "prognostics", "env", "cli")
HELPERS = {"_validate", "output", "runner", "saved", "units"}


def test_brake_env_stages_import_only_earlier_stages() -> None:
    bad = []
    for path in sorted((ROOT / "brake_env").rglob("*.py")):
        parts = path.relative_to(ROOT / "brake_env").parts
        if len(parts) == 1:
            continue  # the package's own __init__ and helpers
        stage = PIPELINE.index(parts[0])
        command = "commands" in parts or parts[-1] == "cli.py" or parts[-1].endswith("_cli.py")
        allowed = {*PIPELINE[: stage + 1], *HELPERS} | ({"cli"} if command else set())
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("brake_env."):
                target = node.module.split(".")[1]  # type: ignore[union-attr]
                if target not in allowed:
                    bad.append(f"{path.relative_to(ROOT)} imports brake_env.{target}")
    assert not bad, bad
