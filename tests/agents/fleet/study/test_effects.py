"""The fleet study on a fleet whose pads wear with an unmodelled effect (``fleet-study
--effect``): the env and the training pads on the effect's atlas (the truth), each predictor
made on the nominal atlas, ``NAME+effect`` on the truth's, the effects in the settings and
the unit keys; without effects, the study as it was."""

from __future__ import annotations

import dataclasses
import json

import pytest

from agents.fleet.settings import FED_BACK, FleetStudyConfig, study_predictor_names
from agents.fleet.study import fits as study_fits
from agents.fleet.study.build import rul_env, truth_atlas
from agents.fleet.study.run import report, run_fleet_study
from agents.fleet.study.summary import _config_dict
from agents.fleet.study.units import UNITS, fit_args, study_fit, study_keys
from brake_env.model.atlas import AtlasSpec
from brake_env.prognostics import registry
from brake_env.runner import Runner

EFFECT = "heat_partition:phi=0.25"
TINY = FleetStudyConfig(
    shifts=20, predictors=("twin", "twin+effect", "oracle"), heuristics=("threshold",),
    trials=2, trials_best=2, tune_episodes=1, eval_episodes=3, n_train_runs=2, agent_seeds=0,
    tail=20, effects=(EFFECT,),
)  # fmt: skip
NOMINAL = dataclasses.replace(TINY, predictors=("twin", "oracle"), effects=())


@pytest.fixture(scope="module")
def truth(atlas):
    return truth_atlas(TINY, atlas)


def test_the_effects_are_in_the_settings_and_change_every_unit_key():
    assert TINY.settings() == {**NOMINAL.settings(), "effects": [EFFECT]}
    assert "effects" not in NOMINAL.settings()  # a study without effects: the settings of before
    shared = dataclasses.replace(NOMINAL, bound_iterations=2, rollout_predictors=("oracle",))
    with_effect = dataclasses.replace(shared, effects=(EFFECT,))
    before, after = study_keys(shared), study_keys(with_effect)
    assert len(before) == len(after) and not set(before) & set(after)
    tag = with_effect.physics_tag()
    assert tag.startswith("-fx") and all(k.endswith(tag) for k in after)
    assert shared.physics_tag() == "" and before[0] == "heuristic-twin-threshold-t2"
    assert dataclasses.replace(with_effect, effects=("tc_bias:bias_c=5",)).physics_tag() != tag
    # the config a study writes (costs.json) reads back with its effects; without, as before
    assert FleetStudyConfig.from_dict(json.loads(json.dumps(_config_dict(TINY)))) == TINY
    assert "effects" not in _config_dict(NOMINAL)


def test_the_config_refuses_a_fed_back_predictor_without_effects():
    assert "twin+effect" in study_predictor_names()
    assert "oracle" + FED_BACK not in study_predictor_names()  # the oracle reads the truth
    with pytest.raises(ValueError, match=r"twin\+effect.*no(ne)? .*--effect"):
        FleetStudyConfig(predictors=("twin", "twin+effect"))
    with pytest.raises(ValueError, match="effects must be a tuple of effect texts"):
        FleetStudyConfig(effects=("",))


def test_the_env_wears_on_the_effect_s_atlas(atlas, truth):
    want = AtlasSpec(model=atlas.spec.model, effects=(EFFECT,))
    assert truth.content_hash == want.content_hash() != atlas.content_hash
    assert truth_atlas(NOMINAL, atlas) is atlas
    for p, fitted in (("oracle", None), ("twin", study_fit(TINY, "twin", atlas, truth))):
        env = rul_env(TINY, truth, p, fitted)
        assert env.unwrapped.atlas.content_hash == truth.content_hash


def test_the_nominal_twin_is_made_on_the_nominal_atlas_and_the_fed_back_on_the_truth(
    atlas, truth, monkeypatch
):
    """Both are fitted on pads simulated on the truth (as a real history would be); the
    nominal twin's physics (and the atlas its RUL is carried onto the routes with) is the
    nominal atlas, the fed-back twin's the truth's."""
    simulated_on = []

    def recording(make):
        def make_dataset(a, spec, seed):
            simulated_on.append(a.content_hash)
            return make(a, spec, seed)

        return make_dataset

    monkeypatch.setattr(study_fits, "make_dataset", recording(study_fits.make_dataset))
    monkeypatch.setattr(registry, "make_dataset", recording(registry.make_dataset))
    nominal = study_fit(TINY, "twin", atlas, truth)
    fed = study_fit(TINY, "twin+effect", atlas, truth)
    assert simulated_on == [truth.content_hash] * 2
    assert nominal.atlas is atlas and nominal.predictor.atlas.content_hash == atlas.content_hash
    assert fed.atlas is truth and fed.predictor.atlas.content_hash == truth.content_hash
    assert fit_args(TINY, "twin+effect", atlas, truth)[0] == "twin"
    assert rul_env(TINY, truth, "twin", nominal).atlas is atlas  # the route RUL's physics
    assert rul_env(TINY, truth, "twin+effect", fed).atlas is truth


def test_an_effect_an_atlas_cannot_hold_is_refused_by_name(atlas, tmp_path, capsys):
    from brake_env.cli.main import main

    cooling = "newton_cooling:tau_s=100"
    with pytest.raises(ValueError, match=r"newton_cooling.*between events"):
        truth_atlas(dataclasses.replace(TINY, effects=(cooling,)), atlas)
    code = main(["fleet-study", "--out", str(tmp_path / "a"), "--effect", cooling,
                 "--predictors", "twin,twin+effect", "--quiet"])  # fmt: skip
    err = capsys.readouterr().err
    assert code == 2 and err.count("error:") == 1
    assert "newton_cooling" in err and "between events" in err
    assert main(["fleet-study", "--out", str(tmp_path / "b"), "--predictors", "twin+effect",
                 "--quiet"]) == 2  # fmt: skip
    assert "--effect" in capsys.readouterr().err
    assert not (tmp_path / "a" / "costs.json").exists()


def test_a_tiny_study_with_an_effect_runs_and_names_it(atlas, truth, tmp_path):
    s = run_fleet_study(TINY, atlas, tmp_path, Runner(0), n_resamples=200, truth=truth)
    e = s["effect"]
    assert e["effects"] == [EFFECT] and list(s["config"]["effects"]) == [EFFECT]
    assert e["truth_atlas"] == truth.content_hash and e["atlas"] == atlas.content_hash
    # NAME minus NAME+effect; any other two, the one listed later minus the one before
    assert set(e["pairs"]) == {"twin minus twin+effect", "oracle minus twin",
                               "oracle minus twin+effect"}  # fmt: skip
    d = e["pairs"]["twin minus twin+effect"]["net"]
    assert d["low"] <= d["point"] <= d["high"]
    assert {r["predictor"] for r in s["rows"]} == {"twin", "twin+effect", "oracle"}
    stored = json.loads((tmp_path / UNITS / "settings.json").read_text())
    assert stored["effects"] == [EFFECT] and stored["truth_atlas"] == truth.content_hash
    assert json.loads((tmp_path / "costs.json").read_text())["effect"]["effects"] == [EFFECT]
    assert EFFECT in report(s) and "twin minus twin+effect" in report(s)
    with pytest.raises(ValueError, match="not the atlas with the effects"):
        run_fleet_study(TINY, atlas, tmp_path / "x", Runner(0), truth=atlas)
