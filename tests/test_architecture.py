"""The layout rules of docs/architecture.md: imports flow one way, heavy libraries only
where used, short functions and modules."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from scripts.import_graph import counts, cycles, documented_counts, graph, inner_imports_by_reason

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
    assert not bad, f"{package} imports what docs/architecture.md forbids: {bad}"


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
HELPERS = {"_validate", "csv_safe", "output", "run_lock", "runner", "saved", "units"}


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


# ---------------------------------------------------------------------- import graph
def test_no_import_circle_even_through_imports_inside_functions() -> None:
    """An import placed inside a function still runs: a circle through one is a circle."""

    assert cycles(graph()) == []


def test_imports_inside_functions_only_for_heavy_libraries_or_commands() -> None:
    """A project import inside a function must not dodge a circle (the rooms would be
    wrong); it is there only to load a heavy library late, or a command's implementation
    when that command runs (``brakewear --help`` stays fast)."""

    by_reason = inner_imports_by_reason(graph())
    assert by_reason["circle"] == [] and by_reason["none"] == [], by_reason


def test_the_import_graph_finds_circles_and_reasons(tmp_path) -> None:
    """The counter on a made-up tree: a circle through a function-level import is found and
    named as such; a top-level chain is not a circle."""

    pkg = tmp_path / "agents"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("from agents.b import x\n")
    (pkg / "b.py").write_text("x = 1\ndef f():\n    from agents import a\n")
    (pkg / "c.py").write_text("import torch\n")
    (pkg / "d.py").write_text("def g():\n    import agents.c\n")
    mods = graph(tmp_path)
    assert cycles(mods) == [["agents.a", "agents.b"]]
    assert cycles(mods, with_inner=False) == []
    reasons = inner_imports_by_reason(mods)
    assert reasons["circle"] == ["agents.b -> agents.a"]
    assert reasons["heavy"] == ["agents.d -> agents.c"]


# agents' single-pad sub-packages in import order, each importing only the ones before it;
# the fleet's package (agents.fleet) has its own rooms in their order and shares none with
# them (what both need lives below, in brake_env: the registry, fit_predictors, the runner).
AGENTS_ORDER = ("policies", "study", "learning", "commands")
FLEET_ORDER = (
    "settings", "policies", "evaluation", "learning", "study", "benchmark", "operate", "commands",
)  # fmt: skip


def _room(module: str) -> tuple[str, int] | None:
    """(which order, rank in it) of an agents module below a sub-package."""
    parts = module.split(".")
    if parts[0] != "agents" or len(parts) < 2 or parts[1] == "__init__":
        return None
    if parts[1] == "fleet":
        return ("fleet", FLEET_ORDER.index(parts[2])) if len(parts) > 2 else None
    return "single", AGENTS_ORDER.index(parts[1])


def test_agents_sub_packages_import_one_way() -> None:
    bad = []
    for name, m in graph().items():
        here = _room(name)
        if here is None or len(name.split(".")) < 3:
            continue
        for t in m.top | m.inner:
            there = _room(t)
            if there is not None and (there[0] != here[0] or there[1] > here[1]):
                bad.append(f"{name} -> {t}")
    assert not bad, f"agents imports against {AGENTS_ORDER} or the fleet's {FLEET_ORDER}: {bad}"


MAX_POSITIONAL = 6


def test_no_function_takes_more_than_six_positional_parameters() -> None:
    """Beyond six, callers pass settings by position and mix them up: take a typed config
    or make the rest keyword-only."""
    long = []
    for path in sorted(p for pkg in PACKAGES for p in (ROOT / pkg).rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                args = [a.arg for a in (*node.args.posonlyargs, *node.args.args)]
                n = len([a for a in args if a not in ("self", "cls")])
                if n > MAX_POSITIONAL:
                    long.append(f"{path.relative_to(ROOT)}:{node.name} ({n})")
    assert not long, f"functions with more than {MAX_POSITIONAL} positional parameters: {long}"


def test_the_architecture_page_holds_today_s_counts() -> None:
    """docs/architecture.md's table of rooms, modules, lines and inner imports is the
    script's output, not typed by hand."""
    assert documented_counts() == counts(), (
        "docs/architecture.md is out of date: run"
        " `.venv/bin/python scripts/import_graph.py --counts --write`"
    )
