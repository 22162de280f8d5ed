"""``fleet-study --fleet FILE --model NAME=DIR`` (issue 42, item 4): a user's saved model
ranked beside the registered predictors, money in the fleet file's currency per vehicle-shift
and per year, the value of each predictor against the fixed interval and the oracle; the
bad inputs refused before ``--out`` is made."""

from __future__ import annotations

import dataclasses
import json
import re
from pathlib import Path

import numpy as np
import pytest

from agents.fleet.evaluation.costs import paired_interval
from agents.fleet.settings import FleetStudyConfig
from agents.fleet.study.build import rul_env
from agents.fleet.study.fits import check_models, fit_unit
from agents.fleet.study.interval import AGE, AgeRULObservation
from brake_env.cli.main import main
from brake_env.env.fleet.route_rul import duty_clocks
from brake_env.env.fleet.spaces import N_VF
from brake_env.prognostics.commands.predict_units import model_checksum
from brake_env.prognostics.persist import save_predictor

FLEET = """name = "three"
n_vehicles = 3
hot_need = 1
mild_need = 1
window_slots = 1
bays = 1
shifts_per_year = 700

[costs]
currency = "EUR"
"""
SHIFTS, TRAIN_RUNS = 40, 2
# The smallest budget of tests/agents/fleet/study: 1 trial, 1 tuning and 2 evaluation episodes
BUDGET = ["--shifts", str(SHIFTS), "--heuristics", "threshold", "--trials", "1",
          "--trials-best", "1", "--tune-episodes", "1", "--eval-episodes", "2",
          "--n-train-runs", str(TRAIN_RUNS), "--workers", "0", "--quiet"]  # fmt: skip


@pytest.fixture(scope="module")
def files(tmp_path_factory, atlas, small_atlas) -> dict[str, Path]:
    """The fleet file, the atlas, the study's own twin fit saved as a user's model, and a
    model of other physics."""
    d = tmp_path_factory.mktemp("money")
    (d / "three.toml").write_text(FLEET)
    atlas.save(d / "atlas.npz")
    twin = fit_unit("twin", atlas, 0, TRAIN_RUNS)  # the study's fit of twin, seed 0
    save_predictor(twin.predictor, d / "mine", atlas)
    save_predictor(twin.predictor, d / "other", small_atlas)
    return {"fleet": d / "three.toml", "atlas": d / "atlas.npz", "mine": d / "mine",
            "other": d / "other"}  # fmt: skip


def test_the_fixed_interval_s_rul_counts_a_nominal_pad_s_use_by_route(atlas):
    """Use alone: the first pads from their age on the base mix; a new pad at a nominal
    pad's life on each route; a ramp shift uses a ramp shift of it (and the same share of
    its drift life), whatever the pad's own wear."""
    config = FleetStudyConfig(size="small", shifts=30, predictors=("fixed-interval",))
    env = rul_env(config, atlas, "fixed-interval", None)
    assert isinstance(env, AgeRULObservation)
    c = config.fleet
    clocks = duty_clocks(atlas, ("hot", "mild"))
    hot, mild = (r.life(c.k_mean) / c.events_per_shift for r in clocks.routes)
    assert 150 < hot < 170 and 750 < mild < 900  # ~158 and ~820 shifts (FleetConfig's)

    def rul(obs):
        return obs[-2 * c.n_vehicles :].reshape(c.n_vehicles, 2).astype(float)

    obs, _ = env.reset(seed=3)
    age = obs[: c.n_vehicles * N_VF].reshape(c.n_vehicles, N_VF)[:, AGE].astype(float)
    np.testing.assert_allclose(rul(obs)[:, 0], (1 - age / clocks.base.life(c.k_mean)) * hot,
                               rtol=1e-5)  # fmt: skip
    obs, *_, info = env.step(np.array([3, 1, 0]))  # vehicle 0 to the shop for new pads
    assert info["vehicles"]["replaced"][0]
    np.testing.assert_allclose(rul(obs)[0], [hot, mild], rtol=1e-5)
    done = 0
    for _ in range(3):
        obs, *_, info = env.step(np.array([0, 1, 0]))
        done += info["vehicles"]["events"][0]
    assert done > 0
    used = done / c.events_per_shift / hot
    np.testing.assert_allclose(rul(obs)[0], [hot * (1 - used), mild * (1 - used)], rtol=1e-5)


def test_a_model_is_refused_by_name_clash_directory_and_name(files):
    mine = str(files["mine"])
    with pytest.raises(ValueError, match="the name of a registered predictor"):
        FleetStudyConfig(models=(("twin", mine),))
    with pytest.raises(ValueError, match="the name of a registered predictor"):
        FleetStudyConfig(models=(("fixed-interval", mine),))
    with pytest.raises(ValueError, match="no such directory"):
        FleetStudyConfig(models=(("mine", str(files["mine"] / "nowhere")),))
    with pytest.raises(ValueError, match="not a model"):
        FleetStudyConfig(models=(("mine", str(files["fleet"].parent)),))
    with pytest.raises(ValueError, match="a name is a letter"):
        FleetStudyConfig(models=(("my twin", mine),))
    with pytest.raises(ValueError, match="given twice"):
        FleetStudyConfig(models=(("mine", mine), ("mine", mine)))


def test_a_model_joins_the_predictors_and_keys_the_settings_to_its_checksum(files):
    c = FleetStudyConfig(predictors=("oracle",), models=(("mine", str(files["mine"])),))
    assert c.predictors == ("oracle", "mine")
    assert c.settings()["models"] == {"mine": model_checksum(files["mine"])}
    assert "models" not in FleetStudyConfig(predictors=("oracle",)).settings()
    back = FleetStudyConfig.from_dict(json.loads(json.dumps(dataclasses.asdict(c))))
    assert back == c


def test_a_model_is_taken_on_the_study_s_atlas_or_the_truth_s_and_no_other(
    files, atlas, small_atlas
):
    """A model fitted with the effects (on the truth's atlas) is the diagnosis fed back: taken;
    on any other atlas it is refused naming both hashes."""
    c = FleetStudyConfig(predictors=("oracle",), models=(("other", str(files["other"])),))
    check_models(c, atlas, small_atlas)  # small_atlas standing for the truth's
    with pytest.raises(ValueError, match=f"fitted with atlas {small_atlas.content_hash[:16]}"):
        check_models(c, atlas, atlas)


@pytest.mark.parametrize(
    ("model", "says"),
    [
        ("twin={mine}", "the name of a registered predictor"),
        ("mine={mine}/nowhere", "no such directory"),
        ("mine", "give NAME=DIR"),
        ("mine={other}", "was fitted with atlas"),
    ],
)
def test_bad_models_are_refused_before_out_is_made(tmp_path, capsys, files, model, says):
    out = tmp_path / "out"
    arg = model.format(mine=files["mine"], other=files["other"])
    code = _exit(["fleet-study", "--fleet", str(files["fleet"]), "--model", arg, "--atlas",
                  str(files["atlas"]), *BUDGET, "--out", str(out)])  # fmt: skip
    assert code == 2
    err = capsys.readouterr().err
    assert says in err
    if "usage" not in err:  # refused by the command (the atlas is loaded there): one line
        assert len(err.strip().splitlines()) == 1
    assert not out.exists()


def _exit(argv: list[str]) -> int:
    try:
        return main(argv)
    except SystemExit as e:  # the parser's refusals
        return int(e.code or 0)


def test_a_user_s_model_is_ranked_and_the_money_adds_up(tmp_path, capsys, files):
    """The study's own twin fit, saved and given back as a user's model, ranks exactly as the
    registered twin; every figure a year is per vehicle-shift x vehicles x shifts a year;
    the values are the paired differences a year."""
    out = tmp_path / "study"
    code = main(["fleet-study", "--fleet", str(files["fleet"]), "--model",
                 f"mine={files['mine']}", "--predictors", "fixed-interval,twin,oracle",
                 "--atlas", str(files["atlas"]), *BUDGET, "--out", str(out)])  # fmt: skip
    assert code == 0
    text = capsys.readouterr().out
    s = json.loads((out / "costs.json").read_text())
    rows = {r["predictor"]: r for r in s["rows"]}
    assert set(rows) == {"fixed-interval", "twin", "oracle", "mine"}
    assert rows["mine"]["episodes"] == rows["twin"]["episodes"]  # the same fit, loaded
    m = s["money"]
    assert (m["currency"], m["vehicles"], m["shifts_per_year"]) == ("EUR", 3, 700)
    for r in s["rows"]:
        assert r["cost_per_year"] == pytest.approx(r["cost"] * 3 * 700, rel=1e-12)
        assert r["net_cost_per_year"] == pytest.approx(r["net_cost"] * 3 * 700, rel=1e-12)
    fixed = np.array(rows["fixed-interval"]["episodes"]["cost"]) * 2100
    for p, d in m["predictors"].items():
        x = np.array(rows[p]["episodes"]["cost"]) * 2100
        assert d["per_year"] == pytest.approx(x.mean()) == pytest.approx(rows[p]["cost_per_year"])
        assert d["per_year"] == pytest.approx(d["per_vehicle_shift"] * 3 * 700)
        if p != "fixed-interval":
            want = paired_interval(fixed, x, "difference")
            assert d["value_vs_fixed-interval"]["point"] == pytest.approx(want.point)
            assert d["value_vs_fixed-interval"]["low"] == pytest.approx(want.low)
    assert "value_vs_oracle" not in m["predictors"]["oracle"]
    assert "EUR / year" in text and "Cost in EUR per vehicle-shift" in text
    settings = json.loads((out / "units" / "settings.json").read_text())
    assert re.search(model_checksum(files["mine"]), json.dumps(settings))


def test_a_16_vehicle_fleet_file_with_a_user_s_model_completes(tmp_path, files):
    """Issue 42's case: 16 trucks of a user's file, the user's model, a small budget."""
    fleet = tmp_path / "sixteen.toml"
    fleet.write_text(FLEET.replace("n_vehicles = 3", "n_vehicles = 16")
                     .replace("hot_need = 1", "hot_need = 8").replace("mild_need = 1",
                                                                      "mild_need = 5"))  # fmt: skip
    out = tmp_path / "study"
    budget = [*BUDGET[2:], "--shifts", "20"]  # BUDGET less its own --shifts
    code = main(["fleet-study", "--fleet", str(fleet), "--model", f"mine={files['mine']}",
                 "--predictors", "oracle", "--atlas", str(files["atlas"]), *budget,
                 "--out", str(out)])  # fmt: skip
    assert code == 0
    s = json.loads((out / "costs.json").read_text())
    assert s["config"]["fleet"]["n_vehicles"] == 16
    assert [r["predictor"] for r in s["rows"]] == ["oracle", "mine"]
    for r in s["rows"]:
        assert r["cost_per_year"] == pytest.approx(r["cost"] * 16 * 700, rel=1e-12)
