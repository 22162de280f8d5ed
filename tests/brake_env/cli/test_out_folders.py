"""Each command marks its ``--out`` (``.brakewear.json``, naming the command) and refuses a
folder another command wrote, with one message and exit code 2, changing nothing."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from brake_env.cli.main import main
from brake_env.output import OUTPUT_MARK, output_owner


def written_by(directory: Path, command: str) -> Path:
    directory.mkdir()
    (directory / OUTPUT_MARK).write_text(json.dumps({"format": 1, "command": command}))
    costs = directory / "costs.json"
    costs.write_text('{"theirs": 1}\n')
    return costs


@pytest.mark.parametrize(
    ("command", "other"), [("compare", "fleet-study"), ("fleet-study", "compare")]
)
def test_a_folder_another_command_wrote_is_refused(
    command: str, other: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "study"
    costs = written_by(out, other)
    before = sorted(p.name for p in out.iterdir())
    assert main([command, "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert f"brakewear {command}: error: --out {out} holds the output of `brakewear {other}`" in err
    assert costs.read_text() == '{"theirs": 1}\n'
    assert sorted(p.name for p in out.iterdir()) == before
    assert output_owner(out) == other


def test_a_command_marks_its_folder_and_may_write_it_again(tmp_path: Path) -> None:
    out = tmp_path / "atlas"
    assert main(["atlas", "--out", str(out), "--quiet"]) == 0
    assert json.loads((out / OUTPUT_MARK).read_text()) == {"format": 1, "command": "atlas"}
    assert main(["atlas", "--out", str(out), "--quiet"]) == 0
    assert main(["simulate", "--out", str(out), "--quiet"]) == 2


def test_a_folder_of_the_users_own_is_not_marked_when_the_command_fails_early(
    tmp_path: Path,
) -> None:
    (tmp_path / "mine.txt").write_text("x")
    argv = ["predict", "--model", str(tmp_path / "no-model"), "--log", "l.csv"]
    assert main([*argv, "--out", str(tmp_path)]) == 2
    assert [p.name for p in tmp_path.iterdir()] == ["mine.txt"]
