"""scripts/probes/probe_trust.py: each kind of check can fail. A few cases of each kind are run on
a tiny world; each passing answer's deliberately wrong version is rejected, and a case whose
run returns that wrong answer comes out a "silent wrong answer"."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

from scripts.probes import probe_trust as pt


@pytest.fixture(scope="module")
def world(tmp_path_factory: pytest.TempPathFactory) -> pt.World:
    return pt.build_world(tmp_path_factory.mktemp("probe"), seed=0)


def _pick(cases: list[pt.Case], *names: str) -> list[pt.Case]:
    got = [c for c in cases if c.name in names]
    assert len(got) == len(names), [c.name for c in got]
    return got


def _each_check_fails(cases: list[pt.Case]) -> None:
    for case in cases:
        res, detail, answer = pt.outcome(case)
        assert res in ("correct", "warning"), (case.name, res, detail)
        assert pt.shown_to_fail(case, answer), case.name
        wrong = case.check.wrong(answer)  # type: ignore[union-attr]
        bad = pt.Case(case.area, case.name, case.expect, lambda w=wrong: w, case.check)
        assert pt.outcome(bad)[0] == "silent wrong answer", case.name


def test_log_gap_and_fit_checks_can_fail(world: pt.World) -> None:
    cases = pt.log_cases(world) + pt.gap_cases(world)
    _each_check_fails(_pick(
        cases,
        "temperatures in kelvin (twin)",  # a warning, and the estimates after it
        "clean training log (physics)",  # fitted K near the truth
        "clean training log (none)",  # the mean life
        "2,000 runs of 3 events as lives (twin)",  # a second fit of the same log
        "50% of events dropped (twin)",  # within GAP_TOL of the full log
        "every other event (physics)",  # equal at the same events
        "a gap of 1e8 events (window)",  # worn out after the gap
    ))  # fmt: skip


def test_env_and_fleet_checks_can_fail(world: pt.World) -> None:
    env = pt.env_cases(world)
    fleet = pt.fleet_cases(world)
    _each_check_fails(_pick(env, "step(np.int64(1))", "RULObservation (physics)"))
    _each_check_fails(_pick(
        fleet, "actions as lists", "dict of ints", "FleetRULObservation (none)",
        "ExpectedRULObservation",
    ))  # fmt: skip


def test_saved_model_check_can_fail(world: pt.World) -> None:
    _each_check_fails(_pick(pt.model_cases(world), "physics: untouched"))


def test_error_cases_need_the_names() -> None:
    def raise_vague() -> Any:
        raise ValueError("action must be integers")

    case = pt.Case("fleet env", "duty 0.7", "error", raise_vague, names=("vehicle 0", r"0\.7"))
    assert pt.outcome(case)[0] == "other exception"
    ran = pt.Case("fleet env", "duty 0.7", "error", lambda: np.zeros(3))
    assert pt.outcome(ran)[0] == "silent wrong answer"


def test_perturb_changes_every_answer_shape() -> None:
    frame = pd.DataFrame({"run_id": ["a"], "event": [0], "rul_mean": [5.0]})
    for x in (frame, np.arange(3), [np.zeros(2), 1.0], {"k": 2.0}, ["a", "b"], pt.Ran(0, "", 1.0)):
        assert not pt.same(pt.perturb(x), x)


def test_cli_check_can_fail(world: pt.World, tmp_path: Path) -> None:
    train = pt.write_event_log(world.data.logs["train"], tmp_path / "train.csv")
    out = tmp_path / "model"
    argv = ["fit", "--data", str(train), "--predictor", "none", "--out", str(out)]
    run = pt.cli(*argv, "--atlas", str(world.atlas_file),
                 read=lambda: pt.load_predictor(out, world.atlas).mean_life_events)  # fmt: skip
    life = float(world.fitted["none"].mean_life_events)  # type: ignore[attr-defined]
    case = pt.Case(
        "fit", "CLI none", "correct", run, pt.ran_check("= library", lambda g: g == life)
    )
    _each_check_fails([case])


def test_set_aside_and_hostile_id_checks_can_fail(world: pt.World) -> None:
    _each_check_fails(_pick(
        pt.set_aside_cases(world),
        "a user's file named like a unit: reopened, discarded",
        "a unit damaged twice: two numbered copies",
    ))  # fmt: skip
    _each_check_fails(_pick(
        pt.hostile_id_cases(world),
        "CSV cell \"=cmd|' /C calc'!A0\"", "CSV cell '-2+3'",
        "CSV: a carriage return in a pad id", "figure label '$\\\\x$'",
    ))  # fmt: skip


def test_mark_cases_are_clear_errors_keeping_the_files(world: pt.World) -> None:
    cases = _pick(
        pt.mark_cases(world),
        "fit --out on a killed fleet study's folder",
        "fleet-study --out on a running one's folder",
        "fit --out with a mark garbage",
        "fit --out with a mark a non-string command",
    )
    for case in cases:
        assert pt.outcome(case)[0] == "clear error", case.name


def test_a_lost_file_is_a_data_loss_whatever_the_answer(tmp_path: Path) -> None:
    files: dict[Path, bytes] = {}
    mine = pt.keep(files, tmp_path / "units" / "report-2026112801.json", b"mine")

    def deletes() -> int:
        mine.unlink()
        return 1

    ok = pt.Check("one", lambda got: got == 1)
    case = pt.Case("set aside", "deletes", "correct", deletes, ok, lost=pt.unchanged(files))
    assert pt.outcome(case)[0] == "data loss"
    files[mine] = b"mine"
    mine.write_bytes(b"changed")
    refused = pt.Case("set aside", "e", "error", lambda: (_ for _ in ()).throw(ValueError("x")),
                      lost=pt.unchanged(files))  # fmt: skip
    assert pt.outcome(refused)[0] == "data loss"
    mine.write_bytes(b"mine")
    assert pt.outcome(replace(refused))[0] == "clear error"
