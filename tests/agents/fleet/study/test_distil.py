"""``brakewear fleet-distil`` end to end on a tiny study: the planner's labels are its own
decisions, a DAgger round is driven by the clone, every seed runs the study's evaluation
episodes, the figures are the IQM and the study's rows, a rerun reads the units, and bad
input gets one error naming it."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
from scipy.stats import trim_mean

from agents.fleet.evaluation.costs import gap_closed
from agents.fleet.settings import DistilConfig, FleetStudyConfig, FleetTraining
from agents.fleet.study import distil as distil_module
from agents.fleet.study.distil_job import Job, demo_of
from agents.fleet.study.run import run_fleet_study
from brake_env.cli.main import main
from brake_env.runner import Runner

pytest.importorskip("sb3_contrib")

STUDY = FleetStudyConfig(
    shifts=24, predictors=("oracle",), heuristics=("threshold",), trials=2, tune_episodes=1,
    eval_episodes=3, n_train_runs=2, rollout_predictors=("oracle",), rollout_horizon=3,
    rollout_samples=2, rollout_chunk=3, bound_iterations=2,
)  # fmt: skip
ARGS = ["--predictor", "oracle", "--seeds", "2", "--shared-seeds", "1", "--label-episodes", "2",
        "--label-rounds", "1", "--label-chunk", "1", "--imitation-epochs", "2", "--workers", "0",
        "--quiet"]  # fmt: skip


def distil(study: object, out: object, args: list[str] = ARGS) -> int:
    return main(["fleet-distil", "--study", str(study), "--out", str(out), *args])


@pytest.fixture(scope="module")
def distilled(atlas, tmp_path_factory):
    root = tmp_path_factory.mktemp("distil")
    study = run_fleet_study(STUDY, atlas, root / "study", Runner(0), n_resamples=200)
    assert (
        main(["fleet-distil", "--study", str(root / "study"), "--out", str(root / "d"), *ARGS]) == 0
    )
    return root, study, json.loads((root / "d" / "distil.json").read_text())


def test_the_config_reads_back_from_the_study_s_costs_json(distilled) -> None:
    _, study, _ = distilled
    assert FleetStudyConfig.from_dict(study["config"]) == STUDY


def test_the_labels_are_the_planner_s_own_decisions_and_dagger_is_driven_by_the_clone(
    distilled, atlas
) -> None:
    _, _, d = distilled
    job = Job(STUDY, DistilConfig(predictor="oracle", seeds=2, label_episodes=1,
                                  training=_training(d)), (d["base"], d["params"]))  # fmt: skip
    r0 = distil_module.label_unit(job, atlas, None, 0, job.distil.label_seeds(0), [])
    r1 = distil_module.label_unit(job, atlas, None, 1, job.distil.label_seeds(1), [r0])
    assert r0["agreement"] == 1.0  # round 0: the planner drives
    demo = demo_of(r0)
    assert demo.actions.shape == (STUDY.shifts, 2) and (demo.actions < 4).all()  # duties only
    planner = job.planner(atlas)
    again = np.stack([planner.predict(o)[0][:-1] for o in demo.obs])
    assert np.array_equal(again, demo.actions)  # the same decisions on the stored states
    assert r1["round"] == 1 and not np.array_equal(demo_of(r1).taken, demo_of(r1).actions)
    assert r0["decisions"] == STUDY.shifts and r0["planner_seconds"] > 0


def test_every_seed_runs_the_study_s_episodes_and_the_figures_are_its_iqm(distilled) -> None:
    root, study, d = distilled
    assert [s["seed"] for s in d["central"]["seeds"]] == [0, 1]
    assert [s["seed"] for s in d["shared"]["seeds"]] == [0]
    seed_means = np.array([s["figure"] for s in d["central"]["seeds"]])
    c = d["central"]["compared"]
    assert c["base"]["iqm"]["point"] == pytest.approx(trim_mean(seed_means, 0.25))
    base = next(r for r in study["rows"] if r["policy"] == d["base"])
    assert c["base"]["cost"] == pytest.approx(np.mean(base["episodes"]["cost"]))
    assert c["base"]["difference"]["point"] == pytest.approx(
        c["base"]["iqm"]["point"] - c["base"]["cost"]
    )
    assert c["bound"]["cost"] == pytest.approx(np.mean(study["bound"]["episodes"]))
    assert d["central"]["speed"]["times_faster"] > 0
    assert d["labels"]["rounds"][0]["driver_agreement"] == 1.0
    shared = d["shared"]["compared"]["base"]
    assert shared["iqm"]["point"] == pytest.approx(d["shared"]["seeds"][0]["figure"])
    assert (root / "d" / "figures" / "distil.png").stat().st_size > 0
    report = (root / "d" / "report.md").read_text()
    assert (
        "Central policy, 2 seeds" in report
        and "shared by the vehicles (TorchRL), 1 seeds" in report
    )


def test_a_rerun_reads_every_unit(distilled, monkeypatch) -> None:
    root, _, d = distilled

    def refuse(*args: object) -> None:
        raise AssertionError("a unit ran again")

    monkeypatch.setattr(distil_module, "label_unit", refuse)
    monkeypatch.setattr(distil_module, "seed_unit", refuse)
    monkeypatch.setattr(distil_module, "shared_seed_unit", refuse)
    assert (
        main(["fleet-distil", "--study", str(root / "study"), "--out", str(root / "d"), *ARGS]) == 0
    )
    again = json.loads((root / "d" / "distil.json").read_text())
    assert again["central"] == d["central"] and again["shared"] == d["shared"]


def test_bad_input_gets_one_error_naming_it(distilled, tmp_path, capsys) -> None:
    root, _, _ = distilled
    assert (
        main(["fleet-distil", "--study", str(tmp_path), "--out", str(tmp_path / "o"), *ARGS]) != 0
    )
    assert "no costs.json there" in capsys.readouterr().err
    args = [*ARGS]
    args[args.index("oracle")] = "twin"
    assert (
        main(["fleet-distil", "--study", str(root / "study"), "--out", str(tmp_path / "p"), *args])
        != 0
    )
    assert "tuned no heuristic with it (its predictors: oracle)" in capsys.readouterr().err


def test_gap_closed_is_zero_at_the_base_one_at_the_better_policy_and_nan_without_a_gap() -> None:
    base, better = np.array([3.0, 4.0, 5.0]), np.array([2.0, 3.0, 3.0])
    assert gap_closed(np.array([base, base]), base, better, n_resamples=50).point == 0.0
    assert gap_closed(np.array([better]), base, better, n_resamples=50).point == 1.0
    assert np.isnan(gap_closed(np.array([base]), base, base, n_resamples=50).point)


def _training(d: dict) -> FleetTraining:
    t = dict(d["distil"]["training"])
    t["net_arch"] = tuple(t["net_arch"])
    return FleetTraining(**t)


def test_another_ppo_budget_keeps_the_labels_and_not_the_seeds() -> None:
    a = Job(STUDY, DistilConfig(predictor="oracle"), ("threshold", {}))
    t = DistilConfig().training
    b = Job(STUDY, DistilConfig(predictor="oracle", training=dataclasses.replace(
        t, timesteps=5000, learning_rate=3e-4)), ("threshold", {}))  # fmt: skip
    c = Job(STUDY, DistilConfig(predictor="oracle", training=dataclasses.replace(
        t, imitation_epochs=7)), ("threshold", {}))  # fmt: skip
    assert a.label_keys(3) == b.label_keys(3) and a.seed_key(0) != b.seed_key(0)
    assert a.label_key(1, 0) != c.label_key(1, 0)  # the labelling clone's training changed


def test_the_shared_policy_reads_a_label_as_the_pettingzoo_env_s_observation(atlas) -> None:
    from agents.fleet.learning.marl import hot_rul_observation
    from agents.fleet.study.build import rul_env

    job = Job(STUDY, DistilConfig(predictor="oracle"), ("threshold", {"threshold": 3.0}))
    full = rul_env(STUDY, atlas, "oracle", None, job.fields)
    hot = rul_env(STUDY, atlas, "oracle", None, ("rul_mean",), ("hot",))
    rule = job.rule()
    (a, _), (b, _) = full.reset(seed=3), hot.reset(seed=3)
    for _ in range(STUDY.shifts):
        assert np.array_equal(hot_rul_observation(a, job.layout()), b)
        action, _ = rule.predict(a)
        a, *_ = full.step(action)
        b, *_ = hot.step(action)


def test_the_shipped_agents_rebuild_every_seed_s_episodes_exactly(distilled, atlas, tmp_path):
    """The run's nets.npz, shipped beside a baselines file, rebuilds each central seed's
    agent: the seeds' mean on every evaluation episode equals the shipped figure, bit for
    bit; an altered nets file or a baseline without one is refused, named."""
    from types import SimpleNamespace

    from agents.fleet.benchmark.distilled import distilled_baseline, rebuild_distilled, ship_nets

    root, _, d = distilled
    assert (root / "d" / d["nets"]["file"]).is_file()
    made = distilled_baseline(SimpleNamespace(name="tiny", digest="x"), d)
    entry = made["baselines"]["oracle-distilled"]
    ship_nets(entry, root / "d", d, tmp_path / "b.json", "oracle-distilled")
    assert entry["nets"]["file"] == "b.oracle-distilled.npz" and entry["training_seeds"] == [0, 1]
    with pytest.raises(ValueError, match="holds no agent of seed 7"):
        ship_nets({**entry, "training_seeds": [0, 7]}, root / "d", d, tmp_path / "c.json", "x")
    assert not (tmp_path / "c.x.npz").exists()
    env, seeds = rebuild_distilled(STUDY, entry, atlas, tmp_path)
    assert seeds.env is env and len(seeds.agents) == 2
    got = [seeds.run(s) for s in STUDY.eval_seeds()]
    assert [g.net for g in got] == entry["episodes"]["net"]
    assert [g.per_vehicle_shift for g in got] == entry["episodes"]["cost"]
    per_seed = [r["episodes"]["net"] for r in d["central"]["seeds"]]
    assert len({tuple(x) for x in per_seed}) == 2  # the seeds' agents differ: a mean, not one
    nets = tmp_path / entry["nets"]["file"]
    blob = bytearray(nets.read_bytes())
    blob[len(blob) // 2] ^= 0xFF
    nets.write_bytes(bytes(blob))
    with pytest.raises(ValueError, match="not the file its header was written with"):
        rebuild_distilled(STUDY, entry, atlas, tmp_path)
    with pytest.raises(ValueError, match="made before its agents were shipped"):
        rebuild_distilled(STUDY, {k: v for k, v in entry.items() if k != "nets"}, atlas, tmp_path)


def test_a_saved_agent_of_another_network_is_refused_naming_the_weights(distilled, atlas):
    from agents.fleet.benchmark.distilled import rebuild_distilled  # noqa: F401  # loads torch
    from agents.fleet.learning.agent_arrays import agent_from_arrays
    from brake_env.output import read_arrays

    root, _, d = distilled
    arrays = read_arrays(root / "d" / "nets.npz", d["nets"]["sha256"], "test")
    mine = {k.split("/", 1)[1]: v for k, v in arrays.items() if k.startswith("seed0/")}
    job = Job(STUDY, DistilConfig.from_dict(d["distil"]), (d["base"], d["params"]))
    args = (lambda: job.env(atlas, None), job.training(0), job.layout(), job.base_input())
    assert agent_from_arrays(mine, *args).mean.shape == mine["obs_mean"].shape
    first = next(k for k in mine if k.startswith("w:"))
    with pytest.raises(ValueError, match=f"weights \\['{first.removeprefix('w:')}'\\] missing"):
        agent_from_arrays({k: v for k, v in mine.items() if k != first}, *args)
    with pytest.raises(ValueError, match="of another shape"):
        agent_from_arrays({**mine, first: np.zeros(3, dtype=np.float32)}, *args)
    with pytest.raises(ValueError, match="no obs_var"):
        agent_from_arrays({k: v for k, v in mine.items() if k != "obs_var"}, *args)
