"""Units keyed to the settings that made them (issue 44, item 2): a unit's digest covers the
store's settings hash and its content, so a unit copied from a run with other settings, or
kept under a hand-edited ``settings.json``, is named, set aside (never deleted) and redone
rather than used; one of the older, unkeyed format too."""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from brake_env.runner import Runner, Unit
from brake_env.units import SETTINGS, UnitStore, open_store


def draw(seed: int, shift: int) -> dict:
    return {"x": np.random.default_rng(seed + shift).normal(size=3), "seed": seed + shift}


def units(shift: int) -> list[Unit]:
    return [Unit(f"seed={s}", draw, (s, shift)) for s in range(3)]


KEYS = [u.key for u in units(0)]


def run(directory: Path, shift: int) -> dict:
    """Every unit of a run whose settings are ``{"shift": shift}`` (its results depend on it)."""
    with open_store(directory, {"shift": shift}, KEYS, "test") as store:
        return Runner(0).run(units(shift), store)


def same(a: dict, b: dict) -> bool:
    return all(a[k]["seed"] == b[k]["seed"] and np.array_equal(a[k]["x"], b[k]["x"]) for k in KEYS)


def unit_files(directory: Path) -> list[Path]:
    return sorted(p for p in directory.glob("seed=*.json"))


def test_units_copied_from_a_run_with_other_settings_are_named_set_aside_and_redone(
    tmp_path, capsys
):
    clean = run(tmp_path / "clean", 0)
    other = run(tmp_path / "other", 1)
    assert not same(clean, other)  # the copy would change the answer
    run(tmp_path / "run", 0)
    copied = {}
    for f in unit_files(tmp_path / "other"):  # the other run's units over this run's
        shutil.copy(f, tmp_path / "run" / f.name)
        shutil.copy(f.with_suffix(".npz"), tmp_path / "run" / f.with_suffix(".npz").name)
        copied[f.stem] = f.read_bytes()
    capsys.readouterr()
    again = run(tmp_path / "run", 0)
    err = capsys.readouterr().err
    assert same(again, clean)
    for k in KEYS:
        assert f"test: unit {k}: " in err
    assert err.count("was made under other settings") == 3
    aside = tmp_path / "run" / "damaged"
    assert {p.name for p in aside.glob("*.json")} == {f"{s}.1.json" for s in copied}
    for stem, data in copied.items():  # set aside as they were, not deleted
        assert (aside / f"{stem}.1.json").read_bytes() == data


def test_units_under_a_hand_edited_settings_file_are_named_and_redone(tmp_path, capsys):
    clean = run(tmp_path / "clean", 0)
    run(tmp_path / "run", 1)
    path = tmp_path / "run" / SETTINGS
    settings = json.loads(path.read_text())
    path.write_text(json.dumps({**settings, "shift": 0}))  # now claims this run's settings
    capsys.readouterr()
    again = run(tmp_path / "run", 0)
    assert same(again, clean)
    assert capsys.readouterr().err.count("was made under other settings") == 3


def test_an_edit_with_its_plain_checksum_recomputed_is_still_named(tmp_path, capsys):
    clean = run(tmp_path / "clean", 0)
    run(tmp_path / "run", 0)
    f = unit_files(tmp_path / "run")[1]
    doc = json.loads(f.read_text())
    doc["result"]["seed"] = 99
    body = {k: doc[k] for k in ("key", "arrays_sha256", "result")}
    text = json.dumps(body, sort_keys=True, separators=(",", ":"))
    doc["sha256"] = hashlib.sha256(text.encode()).hexdigest()  # what the unkeyed digest was
    f.write_text(json.dumps(doc))
    capsys.readouterr()
    again = run(tmp_path / "run", 0)
    assert same(again, clean)
    assert f"{f} is damaged (its content is not what was written" in capsys.readouterr().err


def test_a_unit_of_the_older_unkeyed_format_is_named_and_redone(tmp_path, capsys):
    clean = run(tmp_path / "clean", 0)
    run(tmp_path / "run", 0)
    f = unit_files(tmp_path / "run")[0]
    doc = json.loads(f.read_text())
    doc["result"]["seed"] = 7  # what an unkeyed unit from anywhere could hold
    body = {k: doc[k] for k in ("key", "arrays_sha256", "result")}
    text = json.dumps(body, sort_keys=True, separators=(",", ":"))
    old = {**body, "sha256": hashlib.sha256(text.encode()).hexdigest()}
    f.write_text(json.dumps(old))
    capsys.readouterr()
    again = run(tmp_path / "run", 0)
    assert same(again, clean)
    err = capsys.readouterr().err
    assert f"{f} is damaged (it carries no digest keyed to the settings" in err
    assert json.loads((tmp_path / "run" / "damaged" / f"{f.stem}.1.json").read_text()) == old


def test_load_refuses_a_unit_copied_in_after_the_store_opened(tmp_path):
    run(tmp_path / "other", 1)
    with open_store(tmp_path / "run", {"shift": 0}, KEYS, "test") as store:
        Runner(0).run(units(0), store)
        f = unit_files(tmp_path / "other")[0]
        shutil.copy(f, tmp_path / "run" / f.name)
        shutil.copy(f.with_suffix(".npz"), tmp_path / "run" / f.with_suffix(".npz").name)
        with pytest.raises(ValueError, match="seed=0: it was made under other settings"):
            store.load("seed=0")


def test_a_unit_file_names_the_settings_hash_it_was_made_under(tmp_path):
    run(tmp_path / "a", 0)
    run(tmp_path / "b", 1)
    a, b = (json.loads(unit_files(tmp_path / d)[0].read_text()) for d in "ab")
    assert a["settings_sha256"] != b["settings_sha256"]
    assert a["settings_sha256"] == UnitStore(tmp_path / "a", {"shift": 0}).settings_hash
