from agents.fleet.commands.cli import _separated


def _rk(**diffs: tuple[float, float]) -> dict:
    """A ranking whose head is the twin, with the twin-minus-predictor intervals given."""
    head_minus = {p: {"difference": {"point": (lo + hi) / 2, "low": lo, "high": hi}}
                  for p, (lo, hi) in diffs.items()}  # fmt: skip
    return {"head": "twin", "head_minus": head_minus}


def test_only_intervals_that_exclude_zero_rank() -> None:
    text = _separated(_rk(none=(-0.9, -0.2), oracle=(0.1, 0.3), physics=(-0.4, 0.5)))
    assert "twin below none" in text and "twin above oracle" in text
    assert "Not ranked against the twin at this budget: physics." in text
    assert "physics" not in text.split("Not ranked")[0]


def test_a_budget_that_separates_nothing_says_so() -> None:
    text = _separated(_rk(none=(-0.9, 0.2), data=(-0.1, 0.0)))  # 0 on an end: not apart
    assert text.startswith("No predictor is separated from the twin at this budget")
    assert _separated({"head": "twin", "head_minus": {}}) == ""
