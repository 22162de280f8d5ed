"""Every command written in README.md and docs/**/*.md is one that runs: each ``brakewear``
subcommand exists and accepts each ``--flag`` cited with it (read from the CLI's own parser,
built once, in this process), and each script cited (``benchmarks/...``, ``scripts/...``,
``examples/...``, or a bare ``name.py`` followed by flags) exists and declares each flag in
its argparse (read from its source: running twenty scripts' ``--help`` would take minutes).

Commands are read from fenced code blocks (a trailing ``\\`` joins lines) and from inline
code spans, which may wrap over lines."""

from __future__ import annotations

import argparse
import ast
import re
import shlex
from dataclasses import dataclass
from functools import cache
from pathlib import Path

from brake_env.cli.main import build_parser

ROOT = Path(__file__).resolve().parents[1]
SCRIPT_DIRS = ("benchmarks", "benchmarks/analysis", "scripts", "scripts/probes", "examples")
WRAPPERS = {"time", "/usr/bin/time", "-v", "nice", "exec"}  # may stand before the command
FENCE = re.compile(r"^[ \t]*```[^\n]*\n(.*?)^[ \t]*```", re.S | re.M)
INLINE = re.compile(r"`([^`]+)`")


@dataclass(frozen=True)
class Cited:
    """One command as written: where, the program (``brakewear`` or a script path), its
    subcommand (brakewear only) and the flags cited with it."""

    where: str
    program: str
    sub: str | None
    flags: tuple[str, ...]


def _tokens(text: str) -> list[str]:
    """Shell words, operators apart; a line shlex cannot read (a lone quote in prose) is
    split on spaces."""
    lexer = shlex.shlex(text, posix=True, punctuation_chars=True)
    lexer.whitespace_split = True
    try:
        return list(lexer)
    except ValueError:
        return text.split()


def _segments(text: str) -> list[list[str]]:
    """The simple commands of a line: words between shell operators (``&&``, ``|``, ``;``,
    redirections), brackets of optional arguments stripped (``[--seeds N]``)."""
    out: list[list[str]] = [[]]
    for tok in _tokens(text):
        if tok and set(tok) <= set("&|;<>()"):
            out.append([])
        else:
            out[-1].append(tok.strip("[]"))
    return [s for s in out if s]


def _flags(words: list[str]) -> tuple[str, ...]:
    return tuple(w.split("=")[0] for w in words if w.startswith("--") and len(w) > 2)


def _cited(words: list[str], where: str) -> Cited | None:
    """The command a segment runs, if it is brakewear or a project script."""
    i = 0
    while i < len(words) and (words[i] in WRAPPERS or re.match(r"^[A-Z_]+=", words[i])):
        i += 1
    if i == len(words):
        return None
    head = words[i]
    if head == "brakewear" or head.endswith("/brakewear"):
        rest = words[i + 1 :]
        sub = rest[0] if rest and not rest[0].startswith("-") else None
        if sub is not None and sub.endswith(":"):  # a message it prints, not a command
            return None
        return Cited(where, "brakewear", sub, _flags(rest))
    if re.search(r"(^|/)python3?$", head) and i + 1 < len(words):
        i += 1
        head = words[i]
    if head.endswith(".py"):
        rest = words[i + 1 :]
        # a bare name.py counts when run or followed by a flag (else it names a module)
        ran = i > 0 or head.startswith(("benchmarks/", "scripts/", "examples/"))
        if ran or (rest and rest[0].startswith("--")):
            return Cited(where, head, None, _flags(rest))
    return None


def commands_in(text: str, name: str) -> list[Cited]:
    """Every command of a markdown page, code blocks first, then inline code."""
    found: list[Cited] = []
    for block in FENCE.findall(text):
        for line in block.replace("\\\n", " ").splitlines():
            found += [c for s in _segments(line) if (c := _cited(s, f"{name}: {line.strip()}"))]
    prose = FENCE.sub("", text)
    for span in INLINE.findall(prose):
        span = " ".join(span.split())
        found += [c for s in _segments(span) if (c := _cited(s, f"{name}: `{span}`"))]
    return found


@cache
def _subcommands() -> dict[str, set[str]]:
    """Each brakewear subcommand's option strings ('' for the top-level parser's; 'COMMAND'
    for a placeholder: the options every subcommand has)."""
    parser = build_parser()
    out = {"": set(parser._option_string_actions)}
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            out |= {k: set(p._option_string_actions) for k, p in action.choices.items()}
    out["COMMAND"] = set.intersection(*(v for k, v in out.items() if k))
    return out


def _script(program: str, root: Path) -> Path | None:
    """The script a command names: its path from the root, else a bare name found in one
    of the script folders."""
    if "/" in program:
        path = root / program.removeprefix("./")
        return path if path.is_file() else None
    hits = [root / d / program for d in SCRIPT_DIRS if (root / d / program).is_file()]
    return hits[0] if hits else None


@cache
def _declared(path: Path) -> set[str]:
    """Option strings a script gives ``add_argument`` anywhere in its source."""
    found = {"-h", "--help"}
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Call) and getattr(node.func, "attr", "") == "add_argument":
            names = [a.value for a in node.args if isinstance(a, ast.Constant)]
            found |= {n for n in names if isinstance(n, str)}
    return found


def problems(cited: list[Cited], root: Path = ROOT) -> list[str]:
    """What is wrong with each cited command, one line each."""
    subs = _subcommands()
    out = []
    for c in cited:
        if c.program == "brakewear":
            known = subs.get(c.sub or "")
            if known is None:
                out.append(f"{c.where}: no subcommand brakewear {c.sub}")
                continue
        else:
            path = _script(c.program, root)
            if path is None:
                out.append(f"{c.where}: no script {c.program}")
                continue
            known = _declared(path)
        name = f"{c.program} {c.sub}" if c.sub else c.program
        out += [f"{c.where}: {name} has no {f}" for f in c.flags if f not in known]
    return out


def _pages(root: Path) -> list[Path]:
    return [root / "README.md", *sorted((root / "docs").rglob("*.md"))]


def test_every_command_and_flag_in_the_docs_is_accepted() -> None:
    cited = [c for p in _pages(ROOT) for c in commands_in(p.read_text(), str(p.relative_to(ROOT)))]
    assert len({c.sub for c in cited if c.program == "brakewear"}) >= 10  # the reader reads
    bad = problems(cited)
    assert not bad, "commands in the docs that would not run:\n" + "\n".join(bad)


def test_a_planted_bad_flag_subcommand_or_script_is_caught(tmp_path: Path) -> None:
    page = tmp_path / "docs" / "page.md"
    page.parent.mkdir()
    (tmp_path / "benchmarks").mkdir()
    (tmp_path / "benchmarks" / "bench_x.py").write_text(
        "import argparse\np = argparse.ArgumentParser()\np.add_argument('--repeats')\n"
    )
    page.write_text(
        "Run `brakewear simulate --seed 1 --no-such-flag`, then\n\n"
        "```bash\n.venv/bin/brakewear fleet-study --out o \\\n  --workers 2 --eval-seeds 20\n"
        "brakewear no-such-command --out o\n"
        ".venv/bin/python benchmarks/bench_x.py --repeats 3 --json x.json\n```\n\n"
        "and `fleet_room.py --eval-seeds 20` and `python scripts/gone.py`; not "
        "`brakewear simulate --seed 2` nor `python benchmarks/bench_x.py [--repeats N]`.\n"
    )
    bad = problems(commands_in(page.read_text(), "page.md"), root=tmp_path)
    assert len(bad) == 6, bad
    for expected in (
        "simulate has no --no-such-flag",
        "fleet-study has no --eval-seeds",
        "no subcommand brakewear no-such-command",
        "bench_x.py has no --json",
        "no script fleet_room.py",
        "no script scripts/gone.py",
    ):
        assert any(expected in b for b in bad), (expected, bad)
