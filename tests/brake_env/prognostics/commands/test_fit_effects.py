"""``fit --effect`` and ``fit --diagnosis``: the effect is built into the atlas, recorded in the
model and rebuilt by ``predict``; a model never meets another atlas without an error; the
twin's misfit warning is printed, recorded and, with ``--strict``, refused."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest

from brake_env.cli.main import main
from brake_env.data.datasets import Dataset, DatasetSpec, make_dataset
from brake_env.data.schema import write_event_log
from brake_env.model.atlas import Atlas, AtlasSpec
from brake_env.model.regime import WearRegime
from brake_env.prognostics.persist import load_predictor, read_header

SMALL = AtlasSpec(n_speed=6, n_mass=3, n_slope=5)
SPEC = DatasetSpec(n_train=4, n_id=2, n_ood_slow=0, n_ood_fast=0, wear=WearRegime(2e-5, 2e-6))
PHI = "heat_partition:phi=0.25"


@pytest.fixture(scope="module")
def logs(small_atlas: Atlas, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Dataset]:
    d = tmp_path_factory.mktemp("logs")
    data = make_dataset(small_atlas, SPEC, seed=5)
    write_event_log(data.logs["train"], d / "train.parquet")
    write_event_log(data.logs["id"].drop(columns=["rul_events"]), d / "id.parquet")
    return d, data


def _fit(tmp: Path, data: Path, *extra: str) -> list[str]:
    return ["fit", "--data", str(data / "train.parquet"), "--predictor", "twin", *extra, "--quiet"]


def test_fit_effect_is_recorded_and_predict_rebuilds_its_atlas(
    logs: tuple[Path, Dataset], tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    data, _ = logs
    model = tmp_path / "model"
    assert (
        main([*_fit(tmp_path, data, "--effect", "heat_partition:phi=0.250"), "--out", str(model)])
        == 0
    )
    assert f"on the physics with {PHI}" in capsys.readouterr().out
    header = read_header(model)
    assert header["atlas_spec"]["effects"] == [PHI]
    assert header["info"]["effects"] == [PHI]
    expected = AtlasSpec.from_dict(header["atlas_spec"]).content_hash()
    assert header["atlas_hash"] == expected != AtlasSpec().content_hash()
    twin = load_predictor(model)  # on its own atlas, rebuilt from the header
    assert twin.atlas.spec.effects == (PHI,) and twin.atlas.content_hash == expected
    out = tmp_path / "pred"
    argv = ["predict", "--model", str(model), "--log", str(data / "id.parquet"), "--quiet"]
    assert main([*argv, "--out", str(out)]) == 0
    fleet = json.loads((out / "fleet.json").read_text())
    assert fleet["effects"] == [PHI] and fleet["atlas_hash"] == expected
    nominal = Atlas.build(AtlasSpec(n_speed=4, n_mass=2, n_slope=3)).save(tmp_path / "n.npz")
    assert main([*argv, "--out", str(tmp_path / "p2"), "--atlas", str(nominal)]) == 2
    assert "was fitted with atlas" in capsys.readouterr().err


def test_a_model_fitted_on_an_effect_atlas_file_is_not_predicted_on_the_nominal_one(
    logs: tuple[Path, Dataset], tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    """The silent 3.9x over-estimate: fitted with an effect's atlas file, predicted without
    --atlas. The file's spec names the effect, so predict rebuilds that atlas, and the
    nominal atlas's file is refused naming both hashes."""
    data, _ = logs
    effect_file = Atlas.build(dataclasses.replace(SMALL, effects=(PHI,))).save(tmp_path / "e.npz")
    nominal_file = Atlas.build(SMALL).save(tmp_path / "n.npz")
    model = tmp_path / "model"
    fit = _fit(tmp_path, data, "--atlas", str(effect_file), "--out", str(model))
    assert main(fit) == 0
    argv = ["predict", "--model", str(model), "--log", str(data / "id.parquet"), "--quiet"]
    assert main([*argv, "--out", str(tmp_path / "a")]) == 0
    assert main([*argv, "--out", str(tmp_path / "b"), "--atlas", str(effect_file)]) == 0
    own = (tmp_path / "a" / "fleet.csv").read_text()
    assert own == (tmp_path / "b" / "fleet.csv").read_text()
    assert main([*argv, "--out", str(tmp_path / "c"), "--atlas", str(nominal_file)]) == 2
    err = capsys.readouterr().err
    assert Atlas.load(nominal_file).content_hash[:16] in err
    assert Atlas.load(effect_file).content_hash[:16] in err
    # --effect on an --atlas file: that file's physics with the effect, the same atlas.
    added = _fit(tmp_path, data, "--atlas", str(nominal_file), "--effect", PHI)
    assert main([*added, "--out", str(tmp_path / "m2")]) == 0
    assert read_header(tmp_path / "m2")["atlas_hash"] == Atlas.load(effect_file).content_hash


def test_fit_diagnosis_takes_the_named_effect_and_refuses_an_abstention(
    logs: tuple[Path, Dataset], tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    data, _ = logs
    diag = tmp_path / "diag"
    diag.mkdir()
    verdict = {"verdict": PHI, "reason": "clear win", "winner": PHI}
    (diag / "diagnosis.json").write_text(json.dumps({"attribution": verdict}))
    model = tmp_path / "model"
    assert main([*_fit(tmp_path, data, "--diagnosis", str(diag)), "--out", str(model)]) == 0
    assert read_header(model)["atlas_spec"]["effects"] == [PHI]
    abstained = {"verdict": "none of the candidates", "reason": "no gap", "winner": None}
    (diag / "diagnosis.json").write_text(json.dumps({"attribution": abstained}))
    assert (
        main([*_fit(tmp_path, data, "--diagnosis", str(diag)), "--out", str(tmp_path / "x")]) == 2
    )
    err = capsys.readouterr().err
    assert "named no effect (none of the candidates: no gap)" in err
    assert (
        main([*_fit(tmp_path, data, "--diagnosis", str(tmp_path)), "--out", str(tmp_path / "y")])
        == 2
    )
    assert "no diagnosis.json" in capsys.readouterr().err
    assert not (tmp_path / "x").exists() and not (tmp_path / "y").exists()


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--effect", "newton_cooling:tau_s=60"], "acts between events"),
        (["--effect", "heat_partition:phi=0.9"], "phi"),
        (["--effect", "glazing:g=1"], "unknown effect 'glazing'"),
        (["--effect", PHI, "--effect", "heat_partition:phi=0.1"], "more than once"),
    ],
)
def test_effects_it_cannot_take_are_refused_by_name(
    logs: tuple[Path, Dataset],
    tmp_path: Path,
    capsys: pytest.CaptureFixture,
    extra: list[str],
    message: str,
) -> None:
    data, _ = logs
    assert main([*_fit(tmp_path, data, *extra), "--out", str(tmp_path / "m")]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "m").exists()


def test_misfit_is_warned_recorded_and_refused_with_strict(
    logs: tuple[Path, Dataset], tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    data, ds = logs
    log = ds.logs["train"].copy()
    frac = log["event"] / log.groupby("run_id")["event"].transform("max")
    log["temp_c"] = log["temp_c"] + 15.0 * frac  # a temperature course the atlas lacks
    write_event_log(log, tmp_path / "steep.parquet")
    argv = ["fit", "--data", str(tmp_path / "steep.parquet"), "--predictor", "twin", "--quiet"]
    small = Atlas.build(SMALL).save(tmp_path / "small.npz")
    assert main([*argv, "--atlas", str(small), "--out", str(tmp_path / "m")]) == 0
    assert "warning: the twin's physics does not fit this log" in capsys.readouterr().err
    check = read_header(tmp_path / "m")["info"]["self_check"]
    assert check["warns"] is True and abs(check["t"]) > check["threshold"]
    assert main([*argv, "--atlas", str(small), "--out", str(tmp_path / "s"), "--strict"]) == 2
    assert "(--strict)" in capsys.readouterr().err
    assert not (tmp_path / "s").exists()
    assert (
        main(
            [
                "fit",
                "--data",
                str(data / "train.parquet"),
                "--predictor",
                "twin",
                "--quiet",
                "--atlas",
                str(small),
                "--out",
                str(tmp_path / "ok"),
            ]
        )
        == 0
    )
    assert read_header(tmp_path / "ok")["info"]["self_check"]["warns"] is False
