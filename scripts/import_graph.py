"""The project's import graph, read from the source (no import runs): which module imports
which, at module level or inside a function (``TYPE_CHECKING`` blocks left out: they never
run); for tests/test_architecture.py and the counts in docs/architecture.md.

    .venv/bin/python scripts/import_graph.py [ROOT] [PREFIX]
    .venv/bin/python scripts/import_graph.py --counts [--write]

prints the circles and each import inside a function by its reason, for the modules whose
name starts with PREFIX (default: all five packages) of the checkout at ROOT (default: here).
``--counts`` prints the table of docs/architecture.md (modules per package and room,
circles, imports inside functions by reason); ``--write`` puts it there between the
GENERATED markers (tests/test_architecture.py checks that the page holds today's table).
"""

from __future__ import annotations

import ast
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("brake_env", "twin", "baselines", "agents", "sim2real")
# Libraries whose import takes long or pulls a large runtime: importing them inside the
# function that needs them keeps `brakewear --help` and light commands fast.
HEAVY = frozenset(
    {"torch", "stable_baselines3", "sb3_contrib", "ray", "matplotlib", "scipy", "pyarrow",
     "optuna", "pettingzoo", "tensorboard", "progpy", "rl_zoo3", "supersuit", "torchrl"}
)  # fmt: skip


@dataclass
class Module:
    name: str
    path: Path
    top: set[str] = field(default_factory=set)  # project modules imported at module level
    inner: set[str] = field(default_factory=set)  # project modules imported inside functions
    heavy_top: set[str] = field(default_factory=set)  # heavy libraries at module level


def _module_name(path: Path, root: Path = ROOT) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _type_checking(node: ast.If) -> bool:
    t = node.test
    return (isinstance(t, ast.Name) and t.id == "TYPE_CHECKING") or (
        isinstance(t, ast.Attribute) and t.attr == "TYPE_CHECKING"
    )


def _targets(node: ast.Import | ast.ImportFrom, known: set[str], here: str) -> set[str]:
    """The project modules an import statement loads (a package's submodules named in a
    ``from pkg import sub`` included)."""
    if isinstance(node, ast.Import):
        names = [a.name for a in node.names]
    else:
        base = node.module or ""
        if node.level:
            pkg = here.split(".")[: -node.level] if node.level else []
            base = ".".join([*pkg, base] if base else pkg)
        names = [base] + [f"{base}.{a.name}" for a in node.names]
    out = set()
    for n in names:
        while n and n not in known:
            n = n.rpartition(".")[0]
        if n:
            out.add(n)
    return out


def _walk(body: list[ast.stmt], inside: bool, found: list[tuple[ast.AST, bool]]) -> None:
    for node in body:
        if isinstance(node, ast.If) and _type_checking(node):
            continue  # never executed
        if isinstance(node, ast.Import | ast.ImportFrom):
            found.append((node, inside))
        nested = isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda)
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.stmt):
                _walk([child], inside or nested, found)
            elif hasattr(child, "body") and isinstance(child.body, list):
                _walk(child.body, inside or nested, found)  # type: ignore[attr-defined]


def graph(root: Path = ROOT) -> dict[str, Module]:
    """Every module of the project's packages and what it imports."""
    paths = [p for pkg in PACKAGES for p in sorted((root / pkg).rglob("*.py"))]
    mods = {_module_name(p, root): Module(_module_name(p, root), p) for p in paths}
    known = set(mods)
    for m in mods.values():
        found: list[tuple[ast.AST, bool]] = []
        _walk(ast.parse(m.path.read_text()).body, False, found)
        for node, inside in found:
            assert isinstance(node, ast.Import | ast.ImportFrom)
            targets = _targets(node, known, m.name) - {m.name}
            (m.inner if inside else m.top).update(targets)
            if not inside:
                libs = (
                    {a.name.split(".")[0] for a in node.names}
                    if isinstance(node, ast.Import)
                    else {(node.module or "").split(".")[0]}
                    if not node.level
                    else set()
                )
                m.heavy_top |= libs & HEAVY
    return mods


def cycles(mods: dict[str, Module], with_inner: bool = True) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    edges = {n: (m.top | m.inner) if with_inner else set(m.top) for n, m in mods.items()}
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(edges[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return out


def pulls_heavy(mods: dict[str, Module], name: str) -> bool:
    """``name`` imports a heavy library at module level, itself or through the project
    modules it imports at module level."""
    seen, todo = set(), [name]
    while todo:
        n = todo.pop()
        if n in seen:
            continue
        seen.add(n)
        if mods[n].heavy_top:
            return True
        todo.extend(mods[n].top)
    return False


def reaches(mods: dict[str, Module], start: str, goal: str) -> bool:
    """``start`` imports ``goal``, directly or through other modules (any import)."""
    seen, todo = set(), [start]
    while todo:
        n = todo.pop()
        if n == goal:
            return True
        if n not in seen:
            seen.add(n)
            todo.extend(mods[n].top | mods[n].inner)
    return False


def inner_imports_by_reason(mods: dict[str, Module]) -> dict[str, list[str]]:
    """Each project import placed inside a function, by why it is there: ``circle`` (at
    module level it would close an import circle: the rooms are wrong), ``heavy`` (the
    module it loads pulls a heavy library), ``command`` (a command module loading a
    command's implementation only when that command runs) or ``none``."""
    out: dict[str, list[str]] = {"circle": [], "heavy": [], "command": [], "none": []}
    for m in mods.values():
        for t in sorted(m.inner):
            if reaches(mods, t, m.name):
                reason = "circle"
            elif pulls_heavy(mods, t):
                reason = "heavy"
            elif _is_command(m.name) and _is_command(t):
                reason = "command"
            else:
                reason = "none"
            out[reason].append(f"{m.name} -> {t}")
    return out


def _is_command(name: str) -> bool:
    parts = name.split(".")
    return "commands" in parts or "cli" in parts or parts[-1].endswith("_cli")


def main(argv: list[str]) -> None:
    root = Path(argv[0]).resolve() if argv else ROOT
    prefix = argv[1].replace("/", ".") if len(argv) > 1 else ""
    mods = graph(root)
    mine = {n for n in mods if n.startswith(prefix)}
    circles = [c for c in cycles(mods) if set(c) & mine]
    print(f"modules: {len(mine)}; import circles: {len(circles)}")
    for c in circles:
        print("  ", " ".join(c))
    for reason, items in inner_imports_by_reason(mods).items():
        items = [i for i in items if i.split(" -> ")[0] in mine]
        print(f"imports inside functions, {reason}: {len(items)}")
        for i in items:
            print("   ", i)


DOC = ROOT / "docs" / "architecture.md"
BEGIN = "<!-- BEGIN GENERATED: scripts/import_graph.py (do not edit by hand) -->"
END = "<!-- END GENERATED: scripts/import_graph.py -->"


def _rooms(root: Path) -> list[str]:
    """The packages and their sub-packages (a folder with an ``__init__.py``), in order."""
    out = []
    for pkg in PACKAGES:
        out.append(pkg)
        subs = sorted(p.parent for p in (root / pkg).rglob("__init__.py") if p.parent != root / pkg)
        out += [str(s.relative_to(root)).replace("/", ".") for s in subs]
    return out


def counts(root: Path = ROOT) -> str:
    """The Markdown table of docs/architecture.md: each room's modules (its own files, not
    its sub-packages'), then the graph's circles and inner imports by reason. (No line
    counts: they would change with every edit; ``wc -l`` gives them.)"""
    mods = graph(root)
    rows = ["| package | modules |", "|---|---:|"]
    for room in _rooms(root):
        files = sorted((root / room.replace(".", "/")).glob("*.py"))
        rows.append(f"| `{room}` | {len(files)} |")
    reasons = inner_imports_by_reason(mods)
    rows += [
        "",
        f"Import circles (imports inside functions counted): {len(cycles(mods))}. Imports"
        " inside functions: " + ", ".join(f"{len(v)} {k}" for k, v in reasons.items()) + ".",
    ]
    return "\n".join(rows)


def write_counts(doc: Path = DOC, root: Path = ROOT) -> None:
    text = doc.read_text()
    head, _, rest = text.partition(BEGIN)
    _, _, tail = rest.partition(END)
    doc.write_text(f"{head}{BEGIN}\n{counts(root)}\n{END}{tail}")


def documented_counts(doc: Path = DOC) -> str:
    """The table as the page holds it."""
    return doc.read_text().partition(BEGIN)[2].partition(END)[0].strip("\n")


if __name__ == "__main__":
    import sys

    if sys.argv[1:2] == ["--counts"]:
        if sys.argv[2:3] == ["--write"]:
            write_counts()
        print(counts())
    else:
        main(sys.argv[1:])
