from sim2real.commands.demo import _against_truth
from sim2real.effects.library import parse_effect

TRUTH = parse_effect("speed_friction:a=0.2")


def _summary(winner: str | None, lo: float, hi: float) -> dict:
    fit = {"name": "a", "value": (lo + hi) / 2, "interval": [lo, hi], "level": 0.9,
           "calibration_runs": 3}  # fmt: skip
    return {"attribution": {"winner": winner, "parameter": fit if winner else None}}


def test_an_interval_that_misses_the_truth_is_said_to() -> None:
    text = _against_truth(_summary("speed_friction:a=0.158", 0.1441, 0.1722), TRUTH)
    assert "[0.1441, 0.1722]" in text and "the truth is 0.2" in text
    assert "does not include the truth" in text and "3 calibration runs" in text


def test_an_interval_that_covers_it_or_no_winner() -> None:
    text = _against_truth(_summary("speed_friction:a=0.19", 0.15, 0.25), TRUTH)
    assert text.endswith("the truth is 0.2, inside it.")
    assert "does not include" not in text
    assert _against_truth(_summary(None, 0, 0), TRUTH) == ""
    other = _against_truth(_summary("tc_bias:b=3", 1, 4), TRUTH)
    assert "the winner is another" in other
