"""The fleet study end to end on tiny budgets (``brakewear fleet-study``, its units, its
summary and its figures), and the agents' aggregate over training seeds."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
from scipy.stats import trim_mean

from agents.fleet.evaluation.costs import iqm, run_episode, seeds_interval
from agents.fleet.settings import FleetStudyConfig, FleetTraining
from agents.fleet.study.build import rebuild_rule, rul_env
from agents.fleet.study.planners import PRICED
from agents.fleet.study.plots import SHOP, trace_episode
from agents.fleet.study.run import run_fleet_study
from agents.fleet.study.summary import REFERENCE
from brake_env.runner import Runner

TINY_TRAINING = FleetTraining(timesteps=64, n_envs=1, n_steps=64, batch_size=32, n_epochs=1,
                              net_arch=(16,), imitation_episodes=1, imitation_epochs=2)  # fmt: skip
TINY = FleetStudyConfig(
    shifts=30, predictors=("none", "oracle"), heuristics=("threshold", "(n, N)"), trials=2,
    trials_best=2, tune_episodes=1, eval_episodes=3, n_train_runs=2,
    agent_predictors=("oracle",), agent_seeds=2, shared_seeds=1, training=TINY_TRAINING,
    curve_episodes=1, curve_every=64, tail=20, rollout_predictors=("oracle",),
    rollout_horizon=3, rollout_samples=2, rollout_chunk=2, bound_iterations=3,
)  # fmt: skip


def test_iqm_is_the_mean_of_the_middle_half():
    x = np.array([1.0, 2, 3, 4, 5, 6, 7, 100])
    assert iqm(x) == pytest.approx(4.5) == pytest.approx(trim_mean(x, 0.25))


def test_seeds_interval_pairs_episodes_and_resamples_seeds():
    rng = np.random.default_rng(0)
    base = rng.uniform(10, 20, 40)
    # Every seed 2 above the baseline on every episode: the difference is exactly 2.
    same = seeds_interval(np.stack([base + 2] * 5), base, n_resamples=500)
    d = same["difference"]
    assert d.point == pytest.approx(2) and d.low == pytest.approx(2) and d.high == pytest.approx(2)
    assert same["ratio"].point == pytest.approx((base.mean() + 2) / base.mean())
    # Seeds that differ: the IQM drops the outlying seed, the interval has width.
    per_seed = np.stack([base * f for f in (0.8, 0.85, 0.9, 0.95, 3.0)])
    out = seeds_interval(per_seed, base, n_resamples=2000)
    assert out["iqm"].point == pytest.approx(iqm(per_seed.mean(axis=1)))
    assert out["iqm"].low < out["iqm"].point < out["iqm"].high
    assert out["ratio"].point < 1 < per_seed[-1].mean() / base.mean()
    with pytest.raises(ValueError, match="seeds, episodes"):
        seeds_interval(per_seed, base[:-1])


def test_the_config_names_what_is_wrong():
    with pytest.raises(ValueError, match="unknown heuristic"):
        FleetStudyConfig(heuristics=("threshold", "magic"))
    with pytest.raises(ValueError, match="not among the predictors"):
        FleetStudyConfig(predictors=("oracle",), agent_predictors=("twin",))
    with pytest.raises(ValueError, match="eval_episodes"):
        FleetStudyConfig(eval_episodes=1)
    with pytest.raises(ValueError, match="'huge': no such file, and not a shipped fleet"):
        FleetStudyConfig(size="huge")
    with pytest.raises(ValueError, match="episodes_from must be an integer"):
        FleetStudyConfig(episodes_from=-1)
    with pytest.raises(ValueError, match="agent_seeds, shared_seeds and bound_iterations"):
        FleetStudyConfig(agent_seeds=-1)
    with pytest.raises(ValueError, match="rollout predictor"):
        FleetStudyConfig(predictors=("oracle",), rollout_predictors=("twin",))
    with pytest.raises(ValueError, match="rollout_samples"):
        FleetStudyConfig(rollout_samples=0)
    chunks = FleetStudyConfig(eval_episodes=7, rollout_chunk=3).rollout_chunks()
    assert chunks == [[0, 1, 2], [3, 4, 5], [6]]
    only_shared = FleetStudyConfig(agent_predictors=("twin",), agent_seeds=0, shared_seeds=2)
    assert only_shared.agent_runs() == [("shared", "twin", 0), ("shared", "twin", 1)]
    with pytest.raises(ValueError, match="rollout_seed must be in"):
        FleetStudyConfig(rollout_seed=-1)


def test_the_planner_s_seed_is_set_apart_from_the_fits_only_when_asked():
    """Unset, the planner draws with the study's seed and its units keep their keys; set, a
    rollout unit of another planner seed has another key (its figures differ)."""
    base = FleetStudyConfig(seed=4)
    assert base.planner_seed == 4
    moved = dataclasses.replace(base, rollout_seed=2)
    assert moved.planner_seed == 2 and moved.seed == 4
    assert base.rollout_key("twin", 0) == dataclasses.replace(base, seed=9).rollout_key("twin", 0)
    assert "-p2-" in moved.rollout_key("twin", 0)
    assert moved.rollout_key("twin", 0) != base.rollout_key("twin", 0)


@pytest.fixture(scope="module")
def study(atlas, tmp_path_factory):
    out = tmp_path_factory.mktemp("fleet")
    return out, run_fleet_study(TINY, atlas, out, Runner(0), n_resamples=200)


def test_the_study_runs_every_policy_on_the_same_episodes(study):
    out, s = study
    policies = {(r["predictor"], r["policy"]) for r in s["rows"]}
    base = s["best_heuristic"]["oracle"]
    assert policies == {("oracle", REFERENCE), ("none", "threshold"), ("none", "(n, N)"),
                        ("oracle", "threshold"), ("oracle", "(n, N)"), ("oracle", PRICED),
                        ("oracle", f"rollout on {base}")}  # fmt: skip
    # the bound: one figure an episode, each row's gap to it paired over the episodes, on
    # the cost net of the pad life left at the end (less than the cost: some life is left)
    bound = np.array(s["bound"]["episodes"])
    assert len(bound) == TINY.eval_episodes and s["bound"]["iterations"] == 4
    for r in s["rows"]:
        assert r["net_cost"] < r["cost"]
        gap = r["gap_to_bound"]
        assert gap["point"] == pytest.approx(r["net_cost"] - bound.mean())
        assert gap["low"] <= gap["point"] <= gap["high"]
    # the rollout planner's episodes (two units) are the evaluation episodes, in order
    ro = next(r for r in s["rows"] if r["policy"].startswith("rollout"))
    assert ro["episodes"]["seed"] == TINY.eval_seeds()
    r = s["rollout"]["oracle"]
    assert r["base"] == base and r["seconds_per_shift"] > 0
    assert r["minus_base"]["point"] == pytest.approx(r["cost"] - r["base_cost"])
    for r in s["rows"]:
        assert r["cost"] > 0
        if r["policy"] != REFERENCE:
            ratio = r["ratio_to_reference"]
            assert ratio["low"] <= ratio["point"] <= ratio["high"]
    # The best heuristic is the one of least tuning cost, never chosen on evaluation.
    for p, h in s["best_heuristic"].items():
        tuned = {r["policy"]: r["tuning_cost"] for r in s["rows"] if r["predictor"] == p
                 and r["tuning_cost"] is not None}  # the tuned heuristics  # fmt: skip
        assert tuned[h] == min(tuned.values())
    a = s["agents"]["oracle"]
    assert (
        a["seeds"] == 2
        and len(a["seed_costs"]) == 2
        and a["teacher"] == s["best_heuristic"]["oracle"]
    )
    assert a["iqm"]["point"] == pytest.approx(np.mean(a["seed_costs"]))  # IQM of two: the mean
    assert all(c["timesteps"] for c in a["curves"])
    shared = s["agents"]["oracle, shared"]
    assert shared["kind"] == "shared" and shared["seeds"] == 1
    assert shared["teacher"] == s["best_heuristic"]["oracle"]  # cloned too
    assert all(c["timesteps"][0] == 0 for c in shared["curves"])  # the clone, before PPO
    assert s["ranking"]["head"] == s["ranking"]["order"][0]  # no twin here: the cheapest
    assert set(s["ranking"]["head_minus"]) == {"none", "oracle"} - {s["ranking"]["head"]}
    saved = json.loads((out / "costs.json").read_text())
    assert saved["rows"] == json.loads(json.dumps(s["rows"]))
    for f in s["figures"]:
        assert (out / f).stat().st_size > 0


def test_a_rerun_resumes_from_the_units_with_the_same_figures(study, atlas, capsys):
    out, s = study
    again = run_fleet_study(TINY, atlas, out, Runner(0), n_resamples=200)
    assert "resuming: 11 of 11 units" in capsys.readouterr().err
    assert again["rows"] == s["rows"] and again["agents"]["oracle"]["seed_costs"] == s["agents"][
        "oracle"]["seed_costs"]  # fmt: skip


def test_on_ray_the_graph_gives_the_same_figures(study, atlas, local_ray, tmp_path):
    _, s = study
    config = dataclasses.replace(TINY, shared_seeds=0, agent_seeds=1)  # the same units, fewer
    with Runner(workers=2) as r:
        on_ray = run_fleet_study(config, atlas, tmp_path, r, n_resamples=200)
    assert on_ray["rows"] == s["rows"]
    assert on_ray["agents"]["oracle"]["seed_costs"] == s["agents"]["oracle"]["seed_costs"][:1]


def test_the_episode_trace_matches_the_env_counts(study, atlas):
    _, s = study
    h = s["best_heuristic"]["oracle"]
    params = next(r["params"] for r in s["rows"] if r["predictor"] == "oracle" and r["policy"] == h)
    rule = rebuild_rule(TINY, h, params)
    env = rul_env(TINY, atlas, "oracle", None)
    trace = trace_episode(env, rule, 0)
    ep = run_episode(env, rule, 0)
    assert trace["duty"].shape == (TINY.shifts, 2)
    assert trace["replaced"].sum() == ep.fits
    assert trace["failed"].sum() == ep.counts["failures"]
    assert (trace["duty"][trace["replaced"]] == SHOP).all()
    assert trace["window"].sum() == TINY.shifts // TINY.fleet.window_period


def test_the_cli_names_a_bad_heuristic_and_the_settings_name_the_tuning_s(capsys, tmp_path):
    from agents.fleet import settings
    from agents.fleet.evaluation.tuning import SPACES
    from brake_env.cli.main import main
    from brake_env.prognostics.registry import predictor_names

    with pytest.raises(SystemExit) as e:
        main(["fleet-study", "--out", str(tmp_path), "--heuristics", "magic"])
    assert e.value.code == 2
    assert "--heuristics: invalid choice: 'magic'" in capsys.readouterr().err
    assert not (tmp_path / "costs.json").exists()
    # The settings' names (kept apart from the tuning so that --help loads no Optuna) are
    # the tuning's, and the predictors are the registry's.
    assert tuple(SPACES) == settings.HEURISTICS
    assert FleetStudyConfig().predictors == predictor_names()
    with pytest.raises(ValueError, match="predictors must be among"):
        FleetStudyConfig(predictors=())


def test_a_fit_starts_before_the_units_lighter_than_what_waits_on_it():
    """The graph starts the heaviest ready unit first, and a fit weighs what waits on it:
    at the default fleet's settings the twin's fit goes before the oracle's rollout units
    (which are ready as soon as the oracle's tuning is done)."""
    from agents.fleet.study.units import study_graph, weights

    config = dataclasses.replace(
        TINY, size="default", shifts=365, predictors=("twin", "oracle"),
        heuristics=("best combination",), trials_best=60, tune_episodes=6, eval_episodes=20,
        agent_predictors=(), shared_seeds=0, rollout_predictors=("oracle", "twin"),
    )  # fmt: skip
    w = weights(config)
    fit = next(n for n in study_graph(config, Runner(0), None) if n.key == "fit-twin")
    mine = [config.heuristic_key("twin", "best combination")]
    mine += [config.rollout_key("twin", i) for i in range(len(config.rollout_chunks()))]
    assert fit.weight == pytest.approx(sum(w[k] for k in mine))
    oracle_rollouts = [w[config.rollout_key("oracle", i)] for i in range(10)]
    assert fit.weight > max(oracle_rollouts) > 1.0


def test_the_ranking_is_on_the_study_s_objective():
    """With ``objective="net"`` the predictors are ranked by their best heuristics' net
    cost (less the life left), which here reverses the headline order."""
    from agents.fleet.evaluation.costs import EpisodeCost
    from agents.fleet.study.summary import _ranking

    def eps(cost: float, left: float) -> list[EpisodeCost]:  # one vehicle, one shift
        terms = {"pad": 0.0, "labour": cost}
        return [EpisodeCost(s, 1, 1, {**terms, "labour": cost + 0.1 * s}, {}, 0.0, left)
                for s in range(4)]  # fmt: skip

    got = {("twin", "threshold"): eps(10.0, 6.0), ("oracle", "threshold"): eps(8.0, 1.0)}
    best = {"twin": "threshold", "oracle": "threshold"}
    config = dataclasses.replace(TINY, predictors=("twin", "oracle"), agent_predictors=(),
                                 rollout_predictors=())  # fmt: skip
    gross = _ranking(config, got, best)
    assert gross["order"] == ["oracle", "twin"] and gross["objective"] == "cost"
    net = _ranking(dataclasses.replace(config, objective="net"), got, best)
    assert net["order"] == ["twin", "oracle"] and net["objective"] == "net"
    assert net["cost"]["twin"] == pytest.approx(10.15 - 6.0)
    assert net["head_minus"]["oracle"]["difference"]["point"] == pytest.approx(4.0 - 7.0)
    with pytest.raises(ValueError, match="objective must be one of"):
        FleetStudyConfig(objective="gross")  # type: ignore[arg-type]


def test_fleet_room_reads_the_study_s_episodes(study):
    """benchmarks/analysis/fleet_room.py pairs the rows' episodes itself: its gaps equal the
    study's, and the reference's forecast is there to check against its realised cost."""
    import importlib.util
    from pathlib import Path

    from agents.fleet.evaluation.costs import paired_interval

    script = Path(__file__).resolve().parents[4] / "benchmarks" / "analysis" / "fleet_room.py"
    spec = importlib.util.spec_from_file_location("fleet_room", script)
    assert spec is not None and spec.loader is not None
    room = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(room)
    out, _ = study
    s = json.loads((out / "costs.json").read_text())
    rows = room.room_rows(s, "oracle")
    base = s["best_heuristic"]["oracle"]
    assert [r["policy"] for r in rows] == [REFERENCE, "threshold", "(n, N)", f"rollout on {base}",
                                           PRICED]  # fmt: skip
    ref = next(r for r in s["rows"] if r["policy"] == REFERENCE)["episodes"]
    assert len(ref["predicted"]) == len(ref["cost"]) == TINY.eval_episodes
    for line in rows[1:]:
        row = next(
            r for r in s["rows"] if (r["predictor"], r["policy"]) == ("oracle", line["policy"])
        )
        x, r = np.array(row["episodes"]["cost"]), np.array(ref["cost"])
        assert row["cost"] == pytest.approx(x.mean())
        assert line["gap to ref"] == str(paired_interval(x, r, "difference"))
        assert row["ratio_to_reference"]["point"] == pytest.approx(x.mean() / r.mean())
    text = "\n".join(room.room(s, "oracle"))
    assert "Room to decide" in text and "realised - predicted" in text
    assert "reference" in room.terms_table(s, "oracle", markdown=True)
