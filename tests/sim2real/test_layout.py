"""sim2real's rooms (docs/architecture.md): effects <- diagnosis <- validation <- commands,
each group importing only the groups before it; imports at module level except matplotlib;
no function with more than six positional parameters; no argparse below the commands."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2] / "sim2real"
GROUPS = ("effects", "diagnosis", "validation", "commands")
LAZY_ALLOWED = {"matplotlib"}


def _modules() -> dict[str, ast.Module]:
    return {str(p.relative_to(ROOT)): ast.parse(p.read_text()) for p in sorted(ROOT.rglob("*.py"))}


def _group(rel: str) -> str | None:
    parts = Path(rel).parts
    return parts[0] if len(parts) > 1 else None


def test_every_module_is_in_a_group() -> None:
    loose = [rel for rel in _modules() if _group(rel) is None and rel != "__init__.py"]
    assert not loose, f"sim2real modules outside {GROUPS}: {loose}"
    assert {g for rel in _modules() if (g := _group(rel))} == set(GROUPS)


def test_groups_import_only_earlier_groups() -> None:
    bad = []
    for rel, tree in _modules().items():
        group = _group(rel)
        if group is None:
            continue
        allowed = set(GROUPS[: GROUPS.index(group) + 1])
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("sim2real."):
                target = node.module.split(".")[1]  # type: ignore[union-attr]
                if target not in allowed:
                    bad.append(f"{rel} imports sim2real.{target}")
            elif isinstance(node, ast.Import):
                bad += [f"{rel} imports {a.name}" for a in node.names if a.name == "sim2real"]
    assert not bad, bad


def test_imports_inside_functions_are_only_matplotlib() -> None:
    lazy = []
    for rel, tree in _modules().items():
        for fn in ast.walk(tree):
            if not isinstance(fn, ast.FunctionDef | ast.AsyncFunctionDef):
                continue
            for node in ast.walk(fn):
                names = []
                if isinstance(node, ast.Import):
                    names = [a.name for a in node.names]
                elif isinstance(node, ast.ImportFrom):
                    names = [node.module or "."]
                lazy += [
                    f"{rel}:{fn.name} {n}" for n in names if n.split(".")[0] not in LAZY_ALLOWED
                ]
    assert not lazy, f"imports inside functions (only {LAZY_ALLOWED} may be lazy): {lazy}"


def test_at_most_six_positional_parameters_and_no_namespace_below_commands() -> None:
    wide, namespaces = [], []
    for rel, tree in _modules().items():
        methods = {id(f) for c in ast.walk(tree) if isinstance(c, ast.ClassDef) for f in c.body}
        for fn in ast.walk(tree):
            if not isinstance(fn, ast.FunctionDef | ast.AsyncFunctionDef):
                continue
            pos = [*fn.args.posonlyargs, *fn.args.args]
            if id(fn) in methods and "staticmethod" not in ast.unparse(fn).split("def ")[0]:
                pos = pos[1:]  # self or cls
            if len(pos) > 6:
                wide.append(f"{rel}:{fn.name} ({len(pos)})")
            if _group(rel) != "commands" and "argparse" in ast.unparse(fn.args):
                namespaces.append(f"{rel}:{fn.name}")
        if _group(rel) != "commands" and "argparse" in ast.unparse(tree):
            namespaces.append(rel)
    assert not wide, f"functions with more than 6 positional parameters: {wide}"
    assert not namespaces, f"argparse below the command modules: {namespaces}"


def _edges() -> dict[str, set[str]]:
    """Module -> the sim2real modules it imports (anywhere in it, functions included)."""
    mods = {
        rel[:-3].replace("/", ".").removesuffix(".__init__"): t for rel, t in _modules().items()
    }
    mods = {f"sim2real.{m}" if m != "__init__" else "sim2real": t for m, t in mods.items()}
    edges: dict[str, set[str]] = {m: set() for m in mods}
    for m, tree in mods.items():
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module:
                for a in node.names:
                    full = f"{node.module}.{a.name}"
                    target = full if full in mods else node.module
                    if target in mods and target != m:
                        edges[m].add(target)
    return edges


def test_no_import_circle() -> None:
    edges = _edges()
    done: set[str] = set()

    def visit(m: str, path: tuple[str, ...]) -> None:
        assert m not in path, f"import circle: {' -> '.join((*path, m))}"
        if m not in done:
            for t in sorted(edges[m]):
                visit(t, (*path, m))
            done.add(m)

    for m in sorted(edges):
        visit(m, ())
