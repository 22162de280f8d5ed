"""The unit store's guards: a damaged unit file is named (file and unit) when the store
opens and its unit redone; a second run into the same store refuses while the first runs,
naming it; a lock left by a dead run is taken over, saying so."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from brake_env.runner import Runner, Unit
from brake_env.units import LOCK, StoreLocked, UnitStore, open_store


def draw(seed: int) -> dict:
    return {"x": np.random.default_rng(seed).normal(size=5), "seed": seed}


def units() -> list[Unit]:
    return [Unit(f"seed={s}", draw, (s,)) for s in range(3)]


KEYS = [u.key for u in units()]


def unit_file(store: UnitStore, key: str, suffix: str = ".json") -> Path:
    return store._stem(key).with_suffix(suffix)


def test_a_cut_unit_file_is_named_set_aside_and_redone(tmp_path, capsys):
    with open_store(tmp_path, {"seed": 0}, KEYS, "test") as store:
        reference = Runner(0).run(units(), store)
        cut = unit_file(store, "seed=1")
    cut.write_bytes(cut.read_bytes()[:40])  # a unit JSON cut to 40 bytes
    with open_store(tmp_path, {"seed": 0}, KEYS, "test") as store:
        err = capsys.readouterr().err
        assert f"test: unit seed=1: {cut} is damaged (not whole JSON" in err
        assert "will redo the unit" in err
        assert "test: resuming: 2 of 3 units already done" in err
        assert "seed=1" not in store and (tmp_path / "damaged" / f"{cut.stem}.1.json").is_file()
        ran: list[str] = []
        again = Runner(0).run(units(), store, lambda k, _: ran.append(k))
    assert sorted(ran) == KEYS  # each reported; only seed=1 was computed again
    for k in KEYS:
        np.testing.assert_array_equal(again[k]["x"], reference[k]["x"])


def test_a_cut_file_without_its_key_is_named_by_the_run_keys(tmp_path, capsys):
    with open_store(tmp_path, {}, KEYS, "test") as store:
        Runner(0).run(units(), store)
        cut = unit_file(store, "seed=2")
    cut.write_bytes(cut.read_bytes()[:5])  # too short to hold its key
    open_store(tmp_path, {}, KEYS, "test").close()
    assert f"unit seed=2: {cut} is damaged" in capsys.readouterr().err


def test_a_damaged_npz_is_named_at_opening_and_redone(tmp_path, capsys):
    with open_store(tmp_path, {}, KEYS, "test") as store:
        reference = Runner(0).run(units(), store)
        npz = unit_file(store, "seed=0", ".npz")
    blob = bytearray(npz.read_bytes())
    blob[len(blob) // 2] ^= 0xFF
    npz.write_bytes(bytes(blob))
    with open_store(tmp_path, {}, KEYS, "test") as store:
        err = capsys.readouterr().err
        assert f"unit seed=0: {unit_file(store, 'seed=0')} is damaged (its arrays" in err
        assert "seed=0" not in store and "seed=1" in store
        again = Runner(0).run(units(), store)
    np.testing.assert_array_equal(again["seed=0"]["x"], reference["seed=0"]["x"])


def test_a_missing_npz_and_a_misnamed_unit_are_damage_too(tmp_path, capsys):
    with open_store(tmp_path, {}, KEYS, "test") as store:
        Runner(0).run(units(), store)
        unit_file(store, "seed=0", ".npz").unlink()
        doc = json.loads(unit_file(store, "seed=1").read_text())
        unit_file(store, "seed=2").write_text(json.dumps(doc))  # seed=1's under seed=2's name
    with open_store(tmp_path, {}, KEYS, "test") as store:
        err = capsys.readouterr().err
        assert "unit seed=0:" in err and "are missing" in err
        assert "holds unit 'seed=1' under another unit's name" in err
        assert store.keys() == ["seed=1"]


def test_a_damaged_settings_file_says_what_to_delete(tmp_path):
    UnitStore(tmp_path, {"seed": 0}).close()
    (tmp_path / "settings.json").write_text('{"seed": ')
    with pytest.raises(ValueError, match=f"delete {tmp_path} to start the run afresh"):
        UnitStore(tmp_path, {"seed": 0})


HOLDER = textwrap.dedent(
    """
    import sys, time
    from brake_env.units import open_store
    store = open_store(sys.argv[1], {{"seed": 0}}, [], "{command}")
    print("locked", flush=True)
    {then}
    """
)


def holder(directory: Path, command: str, then: str) -> subprocess.Popen[str]:
    """A process that opens the store in ``directory`` and then runs ``then``."""
    code = HOLDER.format(command=command, then=then)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    proc = subprocess.Popen(
        [sys.executable, "-c", code, str(directory)], stdout=subprocess.PIPE, text=True, env=env
    )
    assert proc.stdout is not None and proc.stdout.readline().strip() == "locked"
    return proc


def test_a_second_process_refuses_a_store_in_use_naming_the_first(tmp_path):
    first = holder(tmp_path, "first", "time.sleep(60)")
    try:
        second = subprocess.run(
            [sys.executable, "-c", HOLDER.format(command="second", then=""), str(tmp_path)],
            capture_output=True,
            text=True,
            env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)},
            timeout=60,
        )
        assert second.returncode != 0 and "locked" not in second.stdout
        assert "StoreLocked" in second.stderr
        assert f"{tmp_path} is in use by another run (first, pid {first.pid} on" in second.stderr
        # and in this process too, with the start time
        with pytest.raises(StoreLocked, match=rf"pid {first.pid} on .*, started 20\d\d-"):
            UnitStore(tmp_path, {"seed": 0})
    finally:
        first.kill()
        first.wait()


def test_a_finished_run_releases_the_store(tmp_path, capsys):
    first = holder(tmp_path, "first", "store.close()")
    assert first.wait(timeout=60) == 0
    assert (tmp_path / LOCK).read_text() == ""  # released on purpose: nothing to take over
    UnitStore(tmp_path, {"seed": 0}, command="next").close()
    assert "taking over" not in capsys.readouterr().err


def test_the_lock_of_a_killed_run_is_taken_over_saying_so(tmp_path, capsys):
    first = holder(tmp_path, "first", "time.sleep(60)")
    first.send_signal(signal.SIGKILL)
    first.wait()
    time.sleep(0.05)
    with UnitStore(tmp_path, {"seed": 0}, command="next"):
        err = capsys.readouterr().err
        assert f"next: taking over the lock of {tmp_path.resolve()} left by a run" in err
        assert f"first, pid {first.pid}" in err
        held = json.loads((tmp_path / LOCK).read_text())
        assert held["pid"] == os.getpid() and held["command"] == "next"


def test_one_process_may_open_its_store_again(tmp_path):
    with UnitStore(tmp_path, {}) as a:
        a.save("k", 1)
        with UnitStore(tmp_path, {}) as b:  # e.g. to read it back
            assert b.load("k") == 1
        assert json.loads((tmp_path / LOCK).read_text())["pid"] == os.getpid()  # still held
    assert (tmp_path / LOCK).read_text() == ""


# ---------------------------------------------------------------------- trust at the boundaries
def test_a_unit_edited_by_hand_is_named_and_redone_as_a_clean_run_would(tmp_path, capsys):
    with open_store(tmp_path / "clean", {"seed": 0}, KEYS, "test") as store:
        clean = Runner(0).run(units(), store)
    with open_store(tmp_path / "run", {"seed": 0}, KEYS, "test") as store:
        Runner(0).run(units(), store)
        edited = unit_file(store, "seed=1")
    doc = json.loads(edited.read_text())
    doc["result"]["seed"] = 99  # a number changed; the file is still whole JSON
    edited.write_text(json.dumps(doc))
    with open_store(tmp_path / "run", {"seed": 0}, KEYS, "test") as store:
        err = capsys.readouterr().err
        assert f"test: unit seed=1: {edited} is damaged (its content is not what was" in err
        assert "seed=1" not in store
        again = Runner(0).run(units(), store)
    for k in KEYS:
        assert again[k]["seed"] == clean[k]["seed"]
        np.testing.assert_array_equal(again[k]["x"], clean[k]["x"])


def test_load_refuses_a_unit_changed_after_the_store_opened(tmp_path):
    with open_store(tmp_path, {}, KEYS, "test") as store:
        Runner(0).run(units(), store)
        path = unit_file(store, "seed=0")
        path.write_text(path.read_text().replace('"seed": 0', '"seed": 5'))
        with pytest.raises(ValueError, match="was changed since it was written"):
            store.load("seed=0")


def test_a_non_empty_folder_without_settings_is_refused_and_left_alone(tmp_path):
    units_dir = tmp_path / "units"
    units_dir.mkdir()
    (units_dir / "notes.json").write_text("{}\n")
    (units_dir / "a.txt").touch()
    with pytest.raises(ValueError, match=r"units is not empty \(a.txt, notes.json\) but has no"):
        open_store(units_dir, {"seed": 0}, KEYS, "test")
    assert sorted(p.name for p in units_dir.iterdir()) == ["a.txt", "notes.json"]  # no lock


def test_files_put_in_a_store_are_not_units_and_survive_its_discard(tmp_path, capsys):
    with open_store(tmp_path / "units", {"seed": 0}, KEYS, "test") as store:
        (tmp_path / "units" / "notes.json").write_text("{}\n")
        Runner(0).run(units(), store)
    with open_store(tmp_path / "units", {"seed": 0}, KEYS, "test") as store:
        assert "damaged" not in capsys.readouterr().err  # notes.json is not taken for a unit
        assert store.keys() == KEYS
        store.discard()
    assert [p.name for p in (tmp_path / "units").iterdir()] == ["notes.json"]
    assert "files this run did not write (notes.json)" in capsys.readouterr().err


def test_discard_removes_the_folder_when_only_its_files_are_there(tmp_path):
    with open_store(tmp_path / "units", {"seed": 0}, KEYS, "test") as store:
        Runner(0).run(units(), store)
        store.discard()
    assert not (tmp_path / "units").exists()


def test_discard_keeps_what_was_set_aside(tmp_path, capsys):
    with open_store(tmp_path / "units", {"seed": 0}, KEYS, "test") as store:
        Runner(0).run(units(), store)
        cut = unit_file(store, "seed=0")
    cut.write_bytes(cut.read_bytes()[:20])
    damaged = cut.read_bytes()
    with open_store(tmp_path / "units", {"seed": 0}, KEYS, "test") as store:
        Runner(0).run(units(), store)
        store.discard()
    assert [p.name for p in (tmp_path / "units").iterdir()] == ["damaged"]
    assert (tmp_path / "units" / "damaged" / f"{cut.stem}.1.json").read_bytes() == damaged
    err = capsys.readouterr().err
    assert "(1 damaged unit files set aside" in err and "did not write" not in err


# ---------------------------------------------------------------------- nothing lost (issue 44)
def test_a_users_file_named_like_a_unit_is_never_moved_or_deleted(tmp_path, capsys):
    """A killed run's store, then a file of the user's named like a unit: left in place by
    the reopened store and by its discard (it was taken for a damaged unit, moved to
    damaged/ and deleted with the store's files)."""
    store_dir = tmp_path / "units"
    with open_store(store_dir, {"seed": 0}, KEYS, "test") as store:
        Runner(0).run(units()[:2], store)  # killed before the last unit
    report = store_dir / "report-2026112801.json"  # ten hex digits, like a unit's name
    report.write_text("my notes\n")
    with open_store(store_dir, {"seed": 0}, KEYS, "test") as store:
        assert "damaged" not in capsys.readouterr().err
        assert report.read_text() == "my notes\n" and not (store_dir / "damaged").exists()
        assert store.keys() == KEYS[:2]
        Runner(0).run(units(), store)
        store.discard()
    assert report.read_text() == "my notes\n"
    assert [p.name for p in store_dir.iterdir()] == [report.name]
    assert f"files this run did not write ({report.name})" in capsys.readouterr().err


def test_a_users_unit_shaped_json_is_not_taken_for_a_unit(tmp_path, capsys):
    store_dir = tmp_path / "units"
    with open_store(store_dir, {"seed": 0}, KEYS, "test") as store:
        Runner(0).run(units(), store)
    mine = store_dir / "mine-0123456789.json"
    mine.write_text('{"key": "seed=0", "result": 1}')  # a key, but not under its own name
    with open_store(store_dir, {"seed": 0}, KEYS, "test") as store:
        assert "damaged" not in capsys.readouterr().err
        assert store.keys() == KEYS and mine.is_file()
        store.discard()
    assert [p.name for p in store_dir.iterdir()] == [mine.name]


def damage(store: UnitStore, key: str) -> bytes:
    """Cut ``key``'s unit file; its bytes after the cut."""
    path = unit_file(store, key)
    path.write_bytes(path.read_bytes()[: 30 + len(store.directory.name)])
    return path.read_bytes()


def test_set_aside_copies_are_numbered_and_outlive_the_stores_discard(tmp_path, capsys):
    store_dir = tmp_path / "units"
    with open_store(store_dir, {"seed": 0}, KEYS, "test") as store:
        Runner(0).run(units(), store)
        first = damage(store, "seed=1")
    with open_store(store_dir, {"seed": 0}, KEYS, "test") as store:
        Runner(0).run(units(), store)
        second = damage(store, "seed=1") + b"again"
        unit_file(store, "seed=1").write_bytes(second)
    with open_store(store_dir, {"seed": 0}, KEYS, "test") as store:
        Runner(0).run(units(), store)
        store.discard()
    stem = unit_file(store, "seed=1").stem
    aside = store_dir / "damaged"
    assert sorted(p.name for p in aside.iterdir()) == [
        f"{stem}.{n}{s}" for n in (1, 2) for s in (".json", ".npz")
    ]
    assert (aside / f"{stem}.1.json").read_bytes() == first
    assert (aside / f"{stem}.2.json").read_bytes() == second
    assert sorted(p.name for p in store_dir.iterdir()) == ["damaged"]
    err = capsys.readouterr().err
    assert f"moved it to {aside / stem}.2.json and will redo the unit" in err
    assert f"kept {aside}/ (2 damaged unit files set aside" in err
    # a later run into the same folder is not refused for the damaged/ kept there
    with open_store(store_dir, {"seed": 0}, KEYS, "test") as store:
        assert store.keys() == []


def test_a_damaged_unit_with_its_arrays_is_set_aside_as_one_numbered_pair(tmp_path):
    with open_store(tmp_path, {}, KEYS, "test") as store:
        Runner(0).run(units(), store)
        npz = unit_file(store, "seed=0", ".npz")
    (tmp_path / "damaged").mkdir()
    (tmp_path / "damaged" / f"{npz.stem}.1.npz").write_bytes(b"an earlier copy")
    npz.write_bytes(npz.read_bytes()[:-3] + b"xyz")
    UnitStore(tmp_path, {}, keys=KEYS).close()
    got = sorted(p.name for p in (tmp_path / "damaged").iterdir())
    assert got == [f"{npz.stem}.1.npz", f"{npz.stem}.2.json", f"{npz.stem}.2.npz"]
    assert (tmp_path / "damaged" / f"{npz.stem}.1.npz").read_bytes() == b"an earlier copy"


def test_a_file_where_the_set_aside_folder_goes_is_refused_naming_it(tmp_path):
    with open_store(tmp_path, {}, KEYS, "test") as store:
        Runner(0).run(units(), store)
        damage(store, "seed=0")
    (tmp_path / "damaged").write_text("mine")
    with pytest.raises(ValueError, match=f"{tmp_path / 'damaged'} is a file"):
        UnitStore(tmp_path, {}, keys=KEYS)
    assert (tmp_path / "damaged").read_text() == "mine"
