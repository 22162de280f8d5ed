"""Results as people and programs read them: terminal or Markdown tables, and JSON files."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any


def table(rows: list[list[str]], markdown: bool = False) -> str:
    """Rows (the first is the header) as right-aligned columns, or as a Markdown table."""
    if markdown:
        head = "| " + " | ".join(rows[0]) + " |"
        rule = "|" + "|".join("---" for _ in rows[0]) + "|"
        return "\n".join([head, rule, *("| " + " | ".join(r) + " |" for r in rows[1:])])
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    lines = ["  ".join(c.rjust(w) for c, w in zip(r, widths, strict=True)) for r in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def write_json(obj: Any, path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(obj, indent=2, sort_keys=False) + "\n")
    return path
