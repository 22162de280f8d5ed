"""Files as the project writes them (brake_env.output): atomic, standard JSON."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from brake_env.output import atomic_path, remove_stale_temps, write_json, write_text


def test_json_is_standard_nan_and_infinity_become_null(tmp_path) -> None:
    obj = {"a": float("nan"), "b": [np.float32(1.5), np.inf, -np.inf], "c": np.arange(2), 3: (1,)}
    path = write_json(obj, tmp_path / "x.json")
    text = path.read_text()
    assert "NaN" not in text and "Infinity" not in text
    strict = json.loads(text, parse_constant=lambda c: pytest.fail(f"bare {c} in JSON"))
    assert strict == {"a": None, "b": [1.5, None, None], "c": [0, 1], "3": [1]}
    with pytest.raises(TypeError):
        write_json({"x": object()}, tmp_path / "y.json")
    assert not (tmp_path / "y.json").exists()


def test_a_failed_write_keeps_the_old_file_and_leaves_no_temporary(tmp_path) -> None:
    path = write_text("old\n", tmp_path / "f.txt")
    with pytest.raises(RuntimeError), atomic_path(path) as tmp:
        tmp.write_text("half")
        raise RuntimeError("disk full")
    assert path.read_text() == "old\n"
    assert os.listdir(tmp_path) == ["f.txt"]


def test_a_killed_writer_leaves_no_partial_file_and_its_temporary_is_cleared(tmp_path) -> None:
    path = tmp_path / "big.txt"
    code = (
        "import os, sys; from brake_env.output import atomic_path\n"
        f"with atomic_path({str(path)!r}) as tmp:\n"
        "    tmp.write_text('x' * 1000)\n"
        "    os._exit(9)  # killed before the rename\n"
    )
    subprocess.run([sys.executable, "-c", code], check=False)
    assert not path.exists()
    left = [p.name for p in tmp_path.iterdir()]
    assert len(left) == 1 and left[0].startswith(".big.txt.") and left[0].endswith(".tmp.txt")
    assert [p.name for p in remove_stale_temps(tmp_path)] == left
    assert not list(tmp_path.iterdir())
