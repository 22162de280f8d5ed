"""The cost study on the runner: pad sets saved as unit results exactly, the same costs in
this process and on a local Ray (a trained agent too), and ``brakewear compare`` resumed
after a SIGKILL to the same costs as a run never interrupted."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import torch

import agents.commands.units
from agents.commands.cli import compare_and_report
from agents.commands.units import UNITS, join_pads, pad_chunks, pad_key, pad_units, write_trained
from agents.learning.train import TrainedAgent
from agents.study.pads import PadDraws, PadSet, collect_pads
from brake_env.env.config import EnvConfig
from brake_env.prognostics.protocol import NoPrognostics, Oracle
from brake_env.runner import Runner, UnitStore
from tests.agents.budgets import FAST, TINY
from tests.agents.commands.test_train_compare import check_tiny_costs, tiny_config

ROOT = Path(__file__).resolve().parents[3]


def same_pad_sets(a: PadSet, b: PadSet) -> None:
    """Every field equal, arrays with their dtype and shape."""

    def arrays_equal(x: np.ndarray, y: np.ndarray) -> None:
        assert x.dtype == y.dtype and x.shape == y.shape
        assert np.array_equal(x, y)

    for name in ("wear_coeff", "label", "entropy"):
        arrays_equal(getattr(a.draws, name), getattr(b.draws, name))
    assert a.draws.weights == b.draws.weights
    for name in ("first", "life", "starts", "measured"):
        arrays_equal(getattr(a, name), getattr(b, name))
    assert a.estimates.keys() == b.estimates.keys()
    for n, est in a.estimates.items():
        assert est.keys() == b.estimates[n].keys()
        for f, v in est.items():
            arrays_equal(v, b.estimates[n][f])
    assert type(b.decision_interval) is int and a.decision_interval == b.decision_interval


@pytest.fixture(scope="module")
def pads(atlas) -> tuple[PadDraws, EnvConfig, dict]:
    config = EnvConfig.from_kwargs(**FAST, regime="mixed")
    draws = PadDraws.stratified(config.pad_regime, 2, [0, 9])
    return draws, config, {"none": NoPrognostics(2e4), "oracle": Oracle()}


def test_a_pad_set_comes_back_exactly_from_a_unit_store(atlas, pads, tmp_path):
    draws, config, predictors = pads
    whole = collect_pads(draws, atlas, config, predictors)
    part = collect_pads(draws.subset(np.array([0, 5])), atlas, config, predictors)  # 2 labels
    store = UnitStore(tmp_path, {})
    for key, p in (("whole", whole), ("part", part)):
        store.save(key, p.to_tree())
        back = PadSet.from_tree(store.load(key))
        same_pad_sets(p, back)
        assert back.seconds == p.seconds
    assert set(part.draws.weights) == {"id", "ood-slow", "ood-fast"}  # the study's weights


def test_pads_in_chunks_are_the_pads_in_one_go(atlas, pads, monkeypatch):
    draws, config, predictors = pads
    monkeypatch.setattr(agents.commands.units, "CHUNK_PADS", 4)
    units = pad_units("tune", draws, atlas, config, predictors)
    assert [u.key for u in units] == ["tune/pads-0000", "tune/pads-0001"]
    joined = join_pads("tune", draws, Runner(0).run(units))
    same_pad_sets(collect_pads(draws, atlas, config, predictors), joined)
    assert joined.draws is draws


def without_timing(costs: dict) -> dict:
    """``costs.json`` less what measures time: the stages' seconds, the curves' clock."""
    out = {k: v for k, v in costs.items() if k != "timing_s"}
    out["learning_curves"] = {
        name: [{k: v for k, v in p.items() if k != "seconds"} for p in points]
        for name, points in costs["learning_curves"].items()
    }
    return out


def test_costs_are_the_same_in_this_process_and_on_ray(atlas, tmp_path, local_ray):
    """The tiny comparison, well formed (:func:`check_tiny_costs`) and the same both ways."""
    config = tiny_config()  # an oracle agent trained for 256 steps, with a learning curve
    costs = {}
    for where, runner in (("here", Runner(0)), ("ray", Runner(workers=2))):
        with runner:
            assert runner.on_ray == (where == "ray")
            returned = compare_and_report(config, atlas, tmp_path / where, 0, runner,
                                          quiet=True, hyperparams={"oracle": TINY})  # fmt: skip
        costs[where] = json.loads((tmp_path / where / "costs.json").read_text())
        check_tiny_costs(costs[where], returned, tmp_path / where)
    assert without_timing(costs["here"]) == without_timing(costs["ray"])
    assert "oracle/ppo" in costs["ray"]["policies"] and costs["ray"]["learning_curves"]["oracle"]
    # The agent the driver wrote from the Ray task's result is the one trained here.
    agents_ = [TrainedAgent(tmp_path / w / "agents" / "oracle") for w in ("here", "ray")]
    state = [a.model.policy.state_dict() for a in agents_]
    assert all(torch.equal(v, state[1][k]) for k, v in state[0].items())
    np.testing.assert_array_equal(agents_[0].normalization.mean, agents_[1].normalization.mean)
    for f in ("model.zip", "vecnormalize.pkl", "learning_curve.json", "train.json"):
        assert (tmp_path / "ray" / "agents" / "oracle" / f).stat().st_size > 0
    meta = json.loads((tmp_path / "ray" / "agents" / "oracle" / "train.json").read_text())
    assert meta["out_dir"] == str(tmp_path / "ray" / "agents" / "oracle")
    keys = UnitStore(tmp_path / "ray" / UNITS, {**json.loads(
        (tmp_path / "ray" / UNITS / "settings.json").read_text())}).keys()  # fmt: skip
    assert keys == ["agent/oracle", "evaluate/pads-0000", "tune/pads-0000"]


def test_an_agent_unit_cannot_write_outside_its_folder(tmp_path):
    unit = {"files": {"../escape.bin": np.zeros(3, np.uint8)}}
    with pytest.raises(ValueError, match="outside"):
        write_trained(unit, tmp_path / "agent")
    assert not (tmp_path / "escape.bin").exists()


COMPARE = [
    "--quiet", "--workers", "0", "--predictors", "none,physics,oracle", "--agents", "oracle",
    "--timesteps", "1", "--n-train-runs", "2", "--tune-pads", "8", "--eval-pads", "16",
    "--resamples", "100", "--k-mean", "1e-5", "--episode-events", "30000",
]  # fmt: skip
# 3 labels x 8 tuning pads: 2 units; 3 x 16 held-out pads: 3 units
KEYS = [
    pad_key(w, i) for w, n in (("tune", 24), ("evaluate", 48)) for i in range(len(pad_chunks(n)))
]


def compare(out: Path, *extra: str) -> subprocess.Popen[str]:
    cmd = [sys.executable, "-m", "brake_env.cli.main", "compare", "--out", str(out), *COMPARE]
    env = {**os.environ, "MPLBACKEND": "Agg", "PYTHONPATH": str(ROOT)}
    return subprocess.Popen(
        [*cmd, *extra], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )


def test_a_killed_compare_resumes_to_the_same_costs(tmp_path, capsys):
    """SIGKILL once the first unit is saved; the rerun redoes only what was not, and writes
    what a run never interrupted writes."""
    whole = compare(tmp_path / "whole")  # meanwhile: the reference
    killed = compare(tmp_path / "run")
    units = tmp_path / "run" / UNITS
    deadline = time.monotonic() + 120
    saved = ("settings.json", ".")  # not units: the settings, a file still being written
    while not [p for p in units.glob("*.json") if not p.name.startswith(saved)]:
        assert killed.poll() is None, killed.communicate()
        assert time.monotonic() < deadline, "no unit was saved"
        time.sleep(0.01)
    killed.send_signal(signal.SIGKILL)
    killed.communicate()
    with UnitStore(units, json.loads((units / "settings.json").read_text())) as store:
        done = sum(k in store for k in KEYS)  # closed: the rerun takes the store's lock
    assert 1 <= done < len(KEYS) and not (tmp_path / "run" / "costs.json").exists()
    _, err = compare(tmp_path / "run").communicate()
    assert f"resuming: {done} of {len(KEYS)} units already done" in err, err
    assert whole.communicate()[0] and whole.returncode == 0
    costs = [json.loads((tmp_path / d / "costs.json").read_text()) for d in ("whole", "run")]
    assert without_timing(costs[0]) == without_timing(costs[1])
    # Another seed into the same folder is refused before any work, naming what differs
    # (in this process: the refusal needs no fifth interpreter).
    from brake_env.cli.main import main

    before = sorted(p.name for p in units.iterdir())
    assert main(["compare", "--out", str(tmp_path / "run"), *COMPARE, "--seed", "1"]) == 2
    assert "seed: 0 -> 1" in capsys.readouterr().err
    assert sorted(p.name for p in units.iterdir()) == before


def test_brakewear_train_writes_the_same_agent_from_ray(tmp_path, local_ray):
    """``brakewear train`` writes its curve, held-out table and figure, the same in this
    process and on Ray."""
    from brake_env.cli.main import main

    hp = tmp_path / "tiny.toml"
    hp.write_text("[ppo]\n" + "\n".join(f"{k} = {json.dumps(v)}" for k, v in TINY.items()))
    evaluations = []
    for workers in ("0", "2"):
        out = tmp_path / f"w{workers}"
        main(["train", "--out", str(out), "--quiet", "--predictor", "oracle", "--timesteps",
              "256", "--hyperparams", str(hp), "--n-train-runs", "2", "--curve-pads", "1",
              "--eval-pads", "2", "--k-mean", "1e-5", "--episode-events", "30000",
              "--workers", workers])  # fmt: skip
        ev = json.loads((out / "evaluation.json").read_text())
        assert ev["pads"] == {"curve": 3, "held_out": 6} and ev["learning_curve"]
        assert {"oracle/ppo", "oracle", "replace-on-failure"} <= set(ev["policies"])
        assert (out / "figures" / "learning_curve.png").stat().st_size > 0
        del ev["train_seconds"]
        ev["learning_curve"] = [{**p, "seconds": 0} for p in ev["learning_curve"]]
        evaluations.append(ev)
        assert (out / "agent.json").exists() and (out / UNITS / "settings.json").exists()
    assert evaluations[0] == evaluations[1]
    assert evaluations[0]["policies"]["oracle/ppo"]
