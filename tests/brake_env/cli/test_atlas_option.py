"""``--atlas`` given something that is not an atlas (issue 44, item 4): a folder, a text
file, an .npz without the atlas's metadata, one holding pickled objects, a missing file:
one ValueError naming the option and the file (never a pickle run)."""

from __future__ import annotations

import argparse
import pickle

import numpy as np
import pytest

from brake_env.cli.common import load_atlas, read_atlas
from brake_env.cli.main import main


def pickled_npz(path):
    np.savez(path, meta=np.array([{"format": 1}], dtype=object))  # a pickled object array
    return path


CASES = {
    "a folder": lambda d: (d / "atlas").mkdir() or d / "atlas",
    "a text file": lambda d: (d / "atlas.npz").write_text("not an atlas") and d / "atlas.npz",
    "an npz without metadata": lambda d: (np.savez(d / "a.npz", volumes=np.ones(3)), d / "a.npz")[
        1
    ],
    "a pickled npz": lambda d: pickled_npz(d / "p.npz"),
    "no file": lambda d: d / "missing.npz",
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_a_bad_atlas_is_one_error_naming_the_option_and_file(tmp_path, case):
    path = CASES[case](tmp_path)
    with pytest.raises(
        ValueError, match=rf"--atlas {path}: (is a folder|no such file|not an atlas)"
    ):
        load_atlas(argparse.Namespace(atlas=str(path), quiet=True))


def test_a_pickled_npz_is_never_unpickled(tmp_path, monkeypatch):
    ran = []
    monkeypatch.setattr(pickle, "loads", lambda *a, **k: ran.append(1))
    with pytest.raises(ValueError, match="not an atlas"):
        read_atlas(pickled_npz(tmp_path / "p.npz"))
    assert not ran


def test_the_command_says_it_in_one_line(tmp_path, capsys):
    (tmp_path / "atlas").mkdir()
    code = main(["fleet-study", "--out", str(tmp_path / "o"), "--atlas", str(tmp_path / "atlas"),
                 "--quiet"])  # fmt: skip
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and f"--atlas {tmp_path / 'atlas'}: is a folder" in err[0]


def test_a_real_atlas_still_loads(tmp_path, small_atlas):
    small_atlas.save(tmp_path / "a.npz")
    assert read_atlas(tmp_path / "a.npz").content_hash == small_atlas.content_hash
