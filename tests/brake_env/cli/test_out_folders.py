"""Each command marks its ``--out`` (``.brakewear.json``, naming the command) and refuses a
folder another command wrote, with one message and exit code 2, changing nothing."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path
from typing import Any

import pytest

from brake_env import run_lock
from brake_env.cli import main as cli_main
from brake_env.cli.main import main
from brake_env.output import OUTPUT_MARK
from brake_env.run_lock import output_owner


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
    mark = json.loads((out / OUTPUT_MARK).read_text())
    assert mark["format"] == 1 and mark["command"] == "atlas" and mark["pid"] == os.getpid()
    assert mark["args"] == ["atlas", "--out", str(out), "--quiet"]
    assert main(["atlas", "--out", str(out), "--quiet"]) == 0
    assert main(["simulate", "--out", str(out), "--quiet"]) == 2


def test_a_folder_of_the_users_own_is_not_marked_when_the_command_fails_early(
    tmp_path: Path,
) -> None:
    (tmp_path / "mine.txt").write_text("x")
    argv = ["predict", "--model", str(tmp_path / "no-model"), "--log", "l.csv"]
    assert main([*argv, "--out", str(tmp_path)]) == 2
    assert [p.name for p in tmp_path.iterdir()] == ["mine.txt"]


# ---------------------------------------------------------------------- marks that hold (issue 44)
def quick(monkeypatch: pytest.MonkeyPatch, body: Any = None) -> list[Path]:
    """Every command runs ``body(args)`` instead of its work (default: writes
    ``result.txt`` into ``--out``); returns the folders it ran on."""
    ran: list[Path] = []

    def run(args: Any) -> None:
        ran.append(Path(args.out))
        if body is not None:
            body(args)
        else:
            Path(args.out).mkdir(parents=True, exist_ok=True)
            (Path(args.out) / "result.txt").write_text("done")

    monkeypatch.setattr(cli_main, "command", lambda func: run)
    return ran


def test_the_mark_is_written_when_the_command_starts(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    out = tmp_path / "new" / "study"
    seen: list[Any] = []
    quick(monkeypatch, lambda args: seen.append(json.loads((out / OUTPUT_MARK).read_text())))
    argv = ["simulate", "--out", str(out), "--quiet"]
    assert main(argv) == 0
    assert seen[0]["command"] == "simulate" and seen[0]["args"] == argv
    assert seen[0]["pid"] == os.getpid() and seen[0]["format"] == 1
    assert json.loads((out / OUTPUT_MARK).read_text()) == seen[0]  # kept: the command ran
    assert sorted(p.name for p in out.iterdir()) == [OUTPUT_MARK]  # its lock is gone


RUNNING = textwrap.dedent(
    """
    import sys, time
    from brake_env.cli import main as m
    def run(args):
        print("running", flush=True)
        time.sleep(120)
    m.command = lambda func: run
    sys.exit(m.main(["simulate", "--out", sys.argv[1], "--quiet"]))
    """
)


def test_a_running_or_killed_command_keeps_its_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "study"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    proc = subprocess.Popen(
        [sys.executable, "-c", RUNNING, str(out)], stdout=subprocess.PIPE, text=True, env=env
    )
    ran = quick(monkeypatch)
    try:
        assert proc.stdout is not None and proc.stdout.readline().strip() == "running"
        mark = json.loads((out / OUTPUT_MARK).read_text())
        assert mark["command"] == "simulate" and mark["pid"] == proc.pid
        assert main(["fit", "--data", "x.csv", "--predictor", "none", "--out", str(out)]) == 2
        err = capsys.readouterr().err
        assert f"--out {out} holds the output of `brakewear simulate`" in err
        assert err.count("\n") == 1
        # the same command, while the first runs: refused naming its process
        assert main(["simulate", "--out", str(out), "--quiet"]) == 2
        err = capsys.readouterr().err
        assert f"{out} is in use by another run (simulate, pid {proc.pid} on" in err
        assert ran == []
    finally:
        proc.kill()
        proc.wait()
    # killed: still simulate's folder; its own rerun resumes, saying what it takes over
    assert main(["fit", "--data", "x.csv", "--predictor", "none", "--out", str(out)]) == 2
    assert "holds the output of `brakewear simulate`" in capsys.readouterr().err
    assert main(["simulate", "--out", str(out), "--quiet"]) == 0
    assert ran == [out] and (out / "result.txt").read_text() == "done"
    assert f"left by a run that is no longer running (simulate, pid {proc.pid}" in (
        capsys.readouterr().err
    )
    assert json.loads((out / OUTPUT_MARK).read_text())["pid"] == os.getpid()


UNREADABLE = {
    "garbage": b"{bad",
    "empty": b"",
    "binary": b"\x00\xff\xfe\x80",
    "a JSON list": b'["fleet-study"]',
    "a non-string command": b'{"format": 1, "command": 5}',
    "no command": b'{"format": 1}',
    "another format": b'{"format": 99, "command": "fit"}',
    "args not a list": b'{"format": 1, "command": "fit", "args": "x"}',
}


@pytest.mark.parametrize("what", UNREADABLE)
def test_an_unreadable_mark_is_refused_naming_it(
    what: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "study"
    out.mkdir()
    (out / OUTPUT_MARK).write_bytes(UNREADABLE[what])
    (out / "costs.json").write_text("{}")
    ran = quick(monkeypatch)
    assert main(["fit", "--data", "x.csv", "--predictor", "none", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert f"brakewear fit: error: --out {out}: {out / OUTPUT_MARK} is not a mark" in err
    assert ran == [] and (out / OUTPUT_MARK).read_bytes() == UNREADABLE[what]
    assert sorted(p.name for p in out.iterdir()) == [OUTPUT_MARK, "costs.json"]


def test_a_mark_that_is_a_folder_is_refused_naming_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / OUTPUT_MARK).mkdir()
    ran = quick(monkeypatch)
    assert main(["simulate", "--out", str(tmp_path), "--quiet"]) == 2
    assert f"{tmp_path / OUTPUT_MARK} is not a mark" in capsys.readouterr().err
    assert ran == [] and sorted(p.name for p in tmp_path.iterdir()) == [OUTPUT_MARK]


def test_a_mark_of_an_earlier_version_still_names_its_command(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    written_by(tmp_path / "old", "simulate")  # {"format": 1, "command": ...} only
    quick(monkeypatch)
    assert main(["simulate", "--out", str(tmp_path / "old"), "--quiet"]) == 0
    assert main(["atlas", "--out", str(tmp_path / "old"), "--quiet"]) == 2


def test_a_new_folder_is_removed_again_when_the_command_fails_before_writing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    def fail(args: Any) -> None:
        raise ValueError("no such model")

    quick(monkeypatch, fail)
    out = tmp_path / "a" / "b"
    assert main(["simulate", "--out", str(out), "--quiet"]) == 2
    assert list(tmp_path.iterdir()) == []
    # a folder the same command wrote before keeps its earlier mark
    out.parent.mkdir()
    written_by(out, "simulate")
    before = (out / OUTPUT_MARK).read_bytes()
    assert main(["simulate", "--out", str(out), "--quiet"]) == 2
    assert (out / OUTPUT_MARK).read_bytes() == before
    assert sorted(p.name for p in out.iterdir()) == [OUTPUT_MARK, "costs.json"]


def test_an_out_that_cannot_be_made_is_one_clear_error(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    quick(monkeypatch)
    out = tmp_path / "dangling"
    out.symlink_to(tmp_path / "nowhere")
    assert main(["simulate", "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert f"brakewear simulate: error: --out {out}: cannot write there" in err
    assert err.count("\n") == 1


def test_an_out_where_the_lock_cannot_be_written_is_one_clear_error(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    def read_only(path: Path, command: str) -> Path:
        raise PermissionError(13, "Permission denied")

    quick(monkeypatch)
    monkeypatch.setattr(run_lock, "acquire", read_only)
    out = tmp_path / "new"
    assert main(["simulate", "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert f"error: --out {out}: cannot write there (Permission denied)" in err
    assert not out.exists()
