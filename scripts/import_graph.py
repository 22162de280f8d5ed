"""Import circles and imports inside functions, for the modules under a folder.

    .venv/bin/python scripts/import_graph.py . brake_env/prognostics

Circles are the strongly connected components of more than one module in the graph of
imports between the folder's modules, imports inside functions and under
``TYPE_CHECKING`` included. Each import inside a function is listed with its line (its
comment says why).
"""

from __future__ import annotations

import argparse
import ast
from pathlib import Path


def modules(root: Path, folder: str) -> dict[str, Path]:
    """Dotted module name -> file, for every module under ``root / folder``."""
    out = {}
    for p in sorted((root / folder).rglob("*.py")):
        out[".".join(p.relative_to(root).with_suffix("").parts).removesuffix(".__init__")] = p
    return out


def imported(node: ast.AST, module: str) -> list[str]:
    """What ``node`` imports: the module and each name as a possible submodule."""
    if isinstance(node, ast.Import):
        return [a.name for a in node.names]
    if isinstance(node, ast.ImportFrom) and node.module:
        base = node.module
        if node.level:
            base = ".".join([*module.split(".")[: -node.level], node.module])
        return [base, *(f"{base}.{a.name}" for a in node.names)]
    return []


def graph(mods: dict[str, Path]) -> tuple[dict[str, set[str]], list[tuple[str, str]]]:
    """(module -> the folder's modules it imports, [(module, line) of each import inside a
    function])."""
    edges: dict[str, set[str]] = {m: set() for m in mods}
    inside = []
    for m, path in mods.items():
        text = path.read_text()
        tree, lines = ast.parse(text), text.splitlines()
        funcs = [n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef | ast.AsyncFunctionDef)]
        in_func = {id(x) for f in funcs for x in ast.walk(f) if x is not f}
        for node in ast.walk(tree):
            names = imported(node, m)
            edges[m] |= {t for t in names if t in mods and t != m}
            if names and id(node) in in_func:
                inside.append((m, lines[node.lineno - 1].strip()))  # type: ignore[attr-defined]
    return edges, inside


def circles(edges: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    out = []
    for start in edges:
        if start in index:
            continue
        work = [(start, iter(sorted(edges[start])))]
        index[start] = low[start] = len(index)
        stack.append(start)
        while work:
            v, children = work[-1]
            w = next(children, None)
            if w is None:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    comp = stack[stack.index(v) :]
                    del stack[stack.index(v) :]
                    if len(comp) > 1:
                        out.append(sorted(comp))
            elif w not in index:
                index[w] = low[w] = len(index)
                stack.append(w)
                work.append((w, iter(sorted(edges[w]))))
            elif w in stack:
                low[v] = min(low[v], index[w])
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("root", type=Path, help="the project's root (imports are named from it)")
    ap.add_argument("folder", help="the folder to count, relative to the root")
    args = ap.parse_args()
    mods = modules(args.root, args.folder)
    edges, inside = graph(mods)
    found = circles(edges)
    print(f"modules: {len(mods)}; import circles: {len(found)}")
    for c in found:
        print("  circle: " + ", ".join(c))
    print(f"imports inside functions: {len(inside)}")
    for m, line in inside:
        print(f"  {m}: {line}")


if __name__ == "__main__":
    main()
