"""RUL wrappers with a predictor's fleet: one estimate per step, reset at installation, the
same observations as feeding the predictor every event, and one fleet for a vector env."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from numpy.typing import ArrayLike, NDArray

from brake_env.env.brake_wear import BrakeWearEnv
from brake_env.env.vector import BrakeWearVectorEnv
from brake_env.env.wrappers import RULObservation, RULVectorObservation
from brake_env.model.atlas import Atlas
from brake_env.prognostics.fleet import Fleet, LoopFleet
from brake_env.prognostics.protocol import EventBatch, Oracle, Predictor, RULEstimate
from twin import DigitalTwin, TwinCalibration, TwinConfig

# Fast pads (life ~2.4e4 events): several installations in a couple of hundred steps.
FAST = {"k_mean": 1e-5, "k_std": 1e-6, "decision_interval": 500, "episode_events": 100_000}
FIELDS = ("rul_mean", "rul_lower", "rul_upper")


class SpyFleet(LoopFleet):
    """The reference fleet, recording what the wrapper asks of it."""

    def __init__(self, predictor: Predictor, n_pads: int) -> None:
        super().__init__(predictor, n_pads)
        self.calls: list[tuple[NDArray[np.intp], NDArray[np.bool_] | None]] = []
        self.resets: list[int] = []

    def reset(self, pads: ArrayLike) -> None:
        self.resets += [int(p) for p in np.atleast_1d(np.asarray(pads))]
        super().reset(pads)

    def update(
        self, pads: NDArray[np.intp], events: EventBatch, summarise: NDArray[np.bool_] | None = None
    ) -> RULEstimate:
        self.calls.append((pads.copy(), summarise))
        return super().update(pads, events, summarise)


class SpyOracle(Oracle):
    made: list[SpyFleet]

    def fleet(self, n_pads: int) -> Fleet:
        fleet = SpyFleet(Oracle(), n_pads)
        self.made.append(fleet)
        return fleet


class LoopedTwin(DigitalTwin):
    """The twin without its fleet: the wrapper falls back on ``update`` at every event."""

    fleet = Predictor.fleet  # type: ignore[assignment]


@pytest.fixture(scope="module")
def twin_cal() -> TwinCalibration:
    return TwinCalibration(k_log_mean=math.log(1e-5), k_log_scale=0.1, temp_sigma_c=5.0)


def _rollout(env: Any, seed: int, steps: int) -> list[tuple[NDArray[np.float32], dict[str, Any]]]:
    """(observation, info) after the reset and each of ``steps`` random steps."""
    rng = np.random.default_rng(seed)
    obs, info = env.reset(seed=seed)
    out = [(obs.copy(), info)]
    for _ in range(steps):
        obs, _, _, _, info = env.step(int(rng.random() < 0.03))
        out.append((obs.copy(), info))
    return out


def test_fleet_is_asked_for_the_last_event_of_each_step(atlas: Atlas) -> None:
    pred = SpyOracle()
    pred.made = []
    env = RULObservation(BrakeWearEnv(atlas=atlas, **FAST), pred)
    steps = _rollout(env, 3, 120)
    (fleet,) = pred.made  # made once, at the first reset
    assert len(fleet.calls) == len(steps)
    assert all(s is None and np.all(p == 0) for p, s in fleet.calls)  # default: last row
    installs = 1 + sum(int(i["replaced"]) + i["failures"] for _, i in steps[1:])
    assert len(fleet.resets) == installs >= 3
    for obs, info in steps:  # the oracle's true RUL after the step's last event
        assert (
            obs[-1]
            == np.float32(info["truth"]["rul_events"])
            == np.float32(info["rul_estimate"]["rul_mean"])
        )


def test_twin_fleet_gives_the_observations_of_every_event_updates(
    atlas: Atlas, twin_cal: TwinCalibration
) -> None:
    cfg = TwinConfig(n_grid=256)
    a = RULObservation(
        BrakeWearEnv(atlas=atlas, **FAST), DigitalTwin(atlas, cfg, calibration=twin_cal), FIELDS
    )
    b = RULObservation(
        BrakeWearEnv(atlas=atlas, **FAST), LoopedTwin(atlas, cfg, calibration=twin_cal), FIELDS
    )
    got, want = _rollout(a, 5, 100), _rollout(b, 5, 100)
    assert a._fleet is not None and b._fleet is None
    for (oa, ia), (ob, ib) in zip(got, want, strict=True):
        np.testing.assert_allclose(oa, ob, rtol=1e-6)  # float32 of estimates equal to 1e-9
        ea, eb = ia["rul_estimate"], ib["rul_estimate"]
        assert ea.keys() == eb.keys()
        np.testing.assert_allclose([ea[k] for k in ea], [eb[k] for k in ea], rtol=1e-9)


@pytest.mark.parametrize("make_pred", [Oracle, "twin"])
def test_vector_wrapper_equals_one_wrapper_per_env(
    atlas: Atlas, twin_cal: TwinCalibration, make_pred: Any
) -> None:
    n, seed = 3, 7

    def pred() -> Predictor:
        if make_pred == "twin":
            return DigitalTwin(atlas, TwinConfig(n_grid=256), calibration=twin_cal)
        return make_pred()

    fields = ("rul_mean",) if make_pred is Oracle else FIELDS
    venv = RULVectorObservation(BrakeWearVectorEnv(n, atlas=atlas, **FAST), pred(), fields)
    envs = [RULObservation(BrakeWearEnv(atlas=atlas, **FAST), pred(), fields) for _ in range(n)]
    assert venv.single_observation_space == envs[0].observation_space
    obs, infos = venv.reset(seed=seed)
    single = np.stack([e.reset(seed=seed + i)[0] for i, e in enumerate(envs)])
    np.testing.assert_allclose(obs, single, rtol=1e-6)
    rng = np.random.default_rng(0)
    for _ in range(60):  # under an episode: no autoreset
        act = (rng.random(n) < 0.03).astype(np.int64)
        obs, _, _, _, infos = venv.step(act)
        single = np.stack([e.step(int(a))[0] for e, a in zip(envs, act, strict=True)])
        np.testing.assert_allclose(obs, single, rtol=1e-6)
        assert venv.observation_space.contains(obs)
    assert infos["_rul_estimate"].all() and infos["rul_estimate"]["rul_mean"].shape == (n,)


def test_vector_wrapper_rejects_what_the_predictor_cannot_give(atlas: Atlas) -> None:
    venv = RULVectorObservation(BrakeWearVectorEnv(2, atlas=atlas, **FAST), Oracle(), FIELDS)
    with pytest.raises(ValueError, match="gives no rul_lower"):
        venv.reset(seed=0)
    with pytest.raises(ValueError, match="fields must be among"):
        RULVectorObservation(BrakeWearVectorEnv(2, atlas=atlas, **FAST), Oracle(), ("volume",))


def test_a_wrapper_made_for_one_env_names_the_other():
    import gymnasium as gym

    from brake_env.env.fleet.wrappers import ExpectedRULObservation, FleetRULObservation
    from brake_env.prognostics.protocol import Oracle

    with pytest.raises(TypeError, match=r"RULObservation wraps BrakeWear-v0.*got BrakeWearFleet"):
        RULObservation(
            gym.make("BrakeWearFleet-v0", n_vehicles=2, hot_need=1, mild_need=1), Oracle()
        )
    for wrapper in (lambda e: FleetRULObservation(e, Oracle()), ExpectedRULObservation):
        with pytest.raises(TypeError, match=r"wraps BrakeWearFleet-v0.*got BrakeWearEnv"):
            wrapper(gym.make("BrakeWear-v0"))
