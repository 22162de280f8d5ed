"""``brakewear plan``: the fleet's state from a log and a saved model, the decision, its
route RULs and risks, and its futures; bad inputs refused naming the option."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from agents.fleet.operate.belief import BeliefRULObservation
from agents.fleet.operate.estimates import (
    VehicleEstimates,
    from_log,
    of_estimate,
    p_fail_within,
    rul_quantiles,
)
from agents.fleet.operate.plan import route_shifts
from brake_env.cli.main import main
from brake_env.data.datasets import DatasetSpec, make_dataset
from brake_env.data.schema import GROUND_TRUTH, write_event_log
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.fleet_file import read_fleet
from brake_env.env.fleet.route_rul import ROUTE_NAMES, duty_clocks
from brake_env.model.atlas import Atlas
from brake_env.model.regime import WearRegime
from brake_env.prognostics.events import RULEstimate

SPEC = DatasetSpec(n_train=4, n_id=5, n_ood_slow=0, n_ood_fast=0, wear=WearRegime(2e-5, 2e-6))
FLEET = """name = "pit"
n_vehicles = 5
hot_need = 2
mild_need = 1
window_slots = 1
bays = 1
events_per_shift = 100
initial_stock = 2
k_mean = 2e-5
k_std = 2e-6
[costs]
currency = "AUD"
"""


@pytest.fixture(scope="module")
def inputs(small_atlas: Atlas, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A twin fitted through the CLI, the log of 5 pads in service (cut mid-life, one near
    its end) and a 5-vehicle fleet file."""
    d = tmp_path_factory.mktemp("plan")
    ds = make_dataset(small_atlas, SPEC, seed=5)
    write_event_log(ds.logs["train"], d / "train.parquet")
    log = ds.logs["id"]
    life = log.groupby("run_id", observed=True)["event"].transform("max")
    keep = np.where(log["run_id"] == log["run_id"].iloc[0], 0.97, 0.5)
    log = log[log["event"] < keep * life]
    write_event_log(log.drop(columns=list(GROUND_TRUTH)), d / "log.parquet")
    atlas = small_atlas.save(d / "atlas.npz")
    argv = ["fit", "--data", str(d / "train.parquet"), "--predictor", "twin", "--quiet"]
    assert main([*argv, "--out", str(d / "model"), "--atlas", str(atlas)]) == 0
    (d / "pit.toml").write_text(FLEET)
    return {"model": d / "model", "atlas": atlas, "log": d / "log.parquet", "fleet": d / "pit.toml",
            "dir": d}  # fmt: skip


def plan_argv(inputs: dict[str, Path], out: Path, *extra: str) -> list[str]:
    return ["plan", "--model", str(inputs["model"]), "--log", str(inputs["log"]),
            "--atlas", str(inputs["atlas"]), "--fleet", str(inputs["fleet"]), "--out", str(out),
            "--futures", "12", "--quiet", *extra]  # fmt: skip


def test_plan_writes_one_row_per_vehicle_and_is_deterministic(inputs, tmp_path) -> None:
    a, b = tmp_path / "a", tmp_path / "b"
    extra = ("--shifts-to-window", "3", "--stock", "1", "--on-order", "2@2")
    assert main(plan_argv(inputs, a, *extra)) == 0
    assert main(plan_argv(inputs, b, *extra)) == 0
    plan = pd.read_csv(a / "plan.csv")
    assert len(plan) == 5 and plan["vehicle"].is_unique
    assert set(plan["duty"]) <= {"hot", "mild", "park", "service"}
    for route in ROUTE_NAMES:
        lo, mid, hi = (plan[f"rul_{route}_shifts{s}"] for s in ("_lo", "", "_hi"))
        assert (lo <= mid).all() and (mid <= hi).all()
    assert (plan["rul_hot_shifts"] < plan["rul_mild_shifts"]).all()  # the ramp wears faster
    assert plan["p_fail_before_window"].between(0, 1).all()
    ja, jb = (json.loads((p / "plan.json").read_text()) for p in (a, b))
    for j in (ja, jb):
        j.pop("seconds"), j.pop("command", None)
    assert ja == jb  # same seed, same plan
    assert ja["currency"] == "AUD" and ja["horizon_shifts"] == 4 and ja["stock"] == 1
    assert ja["on_order"][:2] == [0, 2]
    lo, hi = ja["cost_interval"]
    assert lo <= hi and ja["expected_cost"] >= 0
    assert (a / "plan.png").stat().st_size > 10_000
    # the coming shift's decision fits the fleet: nothing refused or deferred, the needs met
    coming = ja["coming_shift"]
    assert coming["refused"] == 0 and coming["deferred"] == 0
    assert coming["on_hot"] == (plan["duty"] == "hot").sum()
    assert coming["shortfall"] == max(0, 2 - coming["on_hot"])


def test_the_worn_pad_is_not_sent_to_brake_past_its_life(inputs, tmp_path) -> None:
    """The pad cut at 97% of its life has a hot RUL of about a shift: the rule does not
    send it up the ramp until the window; it is serviced or parked now or gets pads by the
    window."""
    assert main(plan_argv(inputs, tmp_path, "--shifts-to-window", "6")) == 0
    plan = pd.read_csv(tmp_path / "plan.csv").set_index("vehicle")
    worn = plan["rul_hot_shifts"].idxmin()
    assert plan.loc[worn, "rul_hot_shifts"] < 6
    row = plan.loc[worn]
    assert row["duty"] in ("service", "park") or row["p_new_pads_by_window"] >= 0.5


def test_route_rul_is_the_route_clock_at_the_pad_s_volume_and_k(small_atlas) -> None:
    clocks = duty_clocks(small_atlas, ROUTE_NAMES)
    vol, k = np.array([0.9, 0.6, 0.3]), np.array([2e-5, 1.5e-5, 3e-5])
    base = clocks.base.rul(vol, k)
    est = of_estimate(RULEstimate(base, 0.9 * base, 1.2 * base, volume_frac=vol),
                      np.array([1e3, 5e3, 9e3]), clocks.base, ["a", "b", "c"])  # fmt: skip
    np.testing.assert_allclose(est.wear_coeff, k, rtol=1e-12)
    got = route_shifts(est, clocks, per_shift=100.0)
    for j, r in enumerate(ROUTE_NAMES):
        np.testing.assert_allclose(got[f"rul_{r}_shifts"] * 100.0, clocks.routes[j].rul(vol, k),
                                   rtol=1e-9)  # fmt: skip


def _est(mean: float, lower: float, upper: float) -> VehicleEstimates:
    one = np.ones(1)
    return VehicleEstimates(("v",), one, mean * one, lower * one, upper * one, 0.5 * one, one,
                            (None,), "twin")  # fmt: skip


def test_failure_probability_follows_the_interval() -> None:
    e = _est(1000.0, 800.0, 1300.0)
    at = np.array([0.0, 400.0, 800.0, 1000.0, 1300.0, 5000.0])
    p = np.array([p_fail_within(e, np.array([x]))[0] for x in at])
    assert p[0] == 0.0 and np.all(np.diff(p) > 0) and p[-1] > 0.999
    np.testing.assert_allclose(p[[2, 4]], [0.05, 0.95], atol=1e-9)  # the 90% interval's ends
    q = rul_quantiles(e, np.array([[0.05, 0.5, 0.95]]))[0]
    np.testing.assert_allclose(q, [800.0, np.sqrt(800.0 * 1300.0), 1300.0], rtol=1e-9)
    point = _est(1000.0, 1000.0, 1000.0)  # no interval: a step at the RUL
    assert p_fail_within(point, np.array([999.0]))[0] == 0.0
    assert p_fail_within(point, np.array([1000.0]))[0] == 1.0


def test_the_belief_follows_the_duties_and_restarts_on_new_pads(small_atlas) -> None:
    env = BrakeWearFleetEnv(atlas=small_atlas, n_vehicles=2, hot_need=1, mild_need=1,
                            events_per_shift=100, k_mean=2e-5, k_std=2e-6)  # fmt: skip
    clocks = duty_clocks(small_atlas, ROUTE_NAMES)
    vol, k = np.array([0.8, 0.7]), np.array([2e-5, 2.5e-5])
    est = VehicleEstimates(("a", "b"), np.array([1e3, 2e3]), clocks.base.rul(vol, k),
                           clocks.base.rul(vol, k), clocks.base.rul(vol, k), vol, k,
                           (None, None), "twin")  # fmt: skip
    w = BeliefRULObservation(env, est)
    obs, _ = w.reset(seed=0)
    np.testing.assert_allclose(obs[-4:], (clocks.routes[0].rul(vol, k)[:, None] * [1, 0]
                               + clocks.routes[1].rul(vol, k)[:, None] * [0, 1]).ravel() / 100,
                               rtol=1e-6)  # fmt: skip
    _, _, _, _, info = w.step(np.array([0, 1, 0]))  # a hot, b mild
    hot, mild = clocks.routes
    want = [hot.volume_at_work(hot.work_at_volume(0.8) + 2e-5 * 100),
            mild.volume_at_work(mild.work_at_volume(0.7) + 2.5e-5 * 100)]  # fmt: skip
    np.testing.assert_allclose(w.volume, np.ravel(want), rtol=1e-12)
    assert (info["vehicles"]["events"] == 100).all()
    w.step(np.array([3, 0, 0]))  # a serviced: a new pad at the fleet's mean K
    assert w.volume[0] == 1.0 and w.k[0] == 2e-5


@pytest.mark.parametrize(
    ("extra", "named"),
    [
        (("--shifts-to-window", "14"), "--shifts-to-window 14"),
        (("--shifts-to-window", "2", "--on-order", "3@0"), "--on-order '3@0'"),
        (("--shifts-to-window", "2", "--on-order", "x@2"), "--on-order 'x@2'"),
        (("--shifts-to-window", "2", "--down", "nobody:2"), "--down 'nobody:2'"),
        (("--shifts-to-window", "2", "--policy", "no_such_module:f"), "no_such_module"),
        (("--shifts-to-window", "2", "--suite", "small", "--stock", "0"), None),
    ],
)
def test_bad_options_are_refused_naming_them(inputs, tmp_path, capsys, extra, named) -> None:
    code = main(plan_argv(inputs, tmp_path / "o", *extra))
    err = capsys.readouterr().err
    if named is None:  # a valid suite whose rule exists: it plans
        assert code == 0
        return
    assert code == 2 and named in err
    assert not (tmp_path / "o" / "plan.csv").exists()


def test_a_log_of_another_fleet_size_is_refused(inputs, tmp_path, capsys) -> None:
    fleet = tmp_path / "six.toml"
    fleet.write_text(FLEET.replace("n_vehicles = 5", "n_vehicles = 6"))
    argv = plan_argv(inputs, tmp_path / "o", "--shifts-to-window", "2")
    argv[argv.index("--fleet") + 1] = str(fleet)
    assert main(argv) == 2
    assert "5 pads in service and the fleet 6 vehicles" in capsys.readouterr().err


def test_estimates_from_the_log_name_each_pad(inputs, small_atlas) -> None:
    est, atlas = from_log(inputs["model"], inputs["log"], str(inputs["atlas"]), None)
    assert atlas.content_hash == small_atlas.content_hash
    assert est.n == 5 and est.predictor == "twin"
    assert (est.lower <= est.mean).all() and (est.mean <= est.upper).all()
    assert read_fleet(inputs["fleet"]).config.n_vehicles == est.n
