import agents.commands.cli as cli
from agents.study.config import StudyConfig


def test_the_demo_tunes_its_policies() -> None:
    """Fewer tuning pads than the study's minimum tune no threshold: the demo's comparison
    would rank the oracle and replace-on-failure alone."""
    assert StudyConfig().min_tune_pads <= 3 * cli.DEMO_TUNE_PADS
    assert cli.DEMO_EVAL_PADS >= 1
