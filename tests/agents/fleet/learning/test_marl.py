"""The shared policy through TorchRL (agents.fleet.learning.marl): masks kept in the
collection and in the policy's actions, a PPO update that moves the parameters with finite
losses, the clone's agreement with its teacher, determinism for a seed; on a tiny budget."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("torchrl")
pytest.importorskip("pettingzoo")
import torch

from agents.fleet.evaluation.costs import run_episodes
from agents.fleet.learning.dispatch import cover_needs
from agents.fleet.learning.marl import (
    MarlFleetPolicy,
    MarlTraining,
    shared_views,
    standardise_stats,
    train_marl,
)
from agents.fleet.learning.marl_torch import GROUP, make_networks, ppo, record, torchrl_env
from agents.fleet.policies.rules import opportunistic_rule, with_parts
from agents.fleet.policies.view import FleetLayout, FleetView
from brake_env.env.fleet.agent_view import vehicle_views
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.env import BrakeWearFleetEnv
from brake_env.env.fleet.parallel import BrakeWearFleetParallelEnv
from brake_env.env.fleet.shop import HOT, MILD, SERVICE
from brake_env.env.fleet.spares import SparesRule
from brake_env.env.fleet.wrappers import ExpectedRULObservation
from tests.brake_env.env.fleet.small import SMALL

pytestmark = pytest.mark.filterwarnings("ignore:PettingZoo in TorchRL is tested using version")
CFG = FleetConfig(**SMALL)
S_S = (1, 3)
TINY = MarlTraining(frames=120, frames_per_batch=60, minibatch=30, n_epochs=2, hidden=16,
                    imitation_episodes=2, imitation_epochs=20, seed=3)  # fmt: skip


def _teacher():
    rule = opportunistic_rule(
        FleetLayout.of(CFG, routes=("hot",)), n=12.0, N=3.0, s=S_S[0], S=S_S[1]
    )
    return with_parts(rule, "(n, N), healthiest on the ramp", duty="rul")


@pytest.fixture(scope="module")
def make_env(atlas):
    return lambda: BrakeWearFleetParallelEnv(
        CFG, atlas=atlas, predictor="oracle", spares=S_S, infos="none"
    )


@pytest.fixture(scope="module")
def trained(make_env):
    return train_marl(make_env, TINY, teacher=_teacher())


def test_the_collected_actions_respect_the_masks(make_env) -> None:
    par = make_env()
    st = TINY
    nets = make_networks(par, st, *standardise_stats(record(par, None, st, 30).views))
    env = torchrl_env(make_env(), st)
    with torch.no_grad():
        td = env.rollout(40, nets.policy)
    mask, action = td[GROUP, "action_mask"], td[GROUP, "action"]
    assert (~mask).any()  # some actions were masked on the way...
    assert mask.gather(-1, action.unsqueeze(-1)).all()  # ...and none of them was taken


def test_a_ppo_update_moves_the_parameters_with_finite_losses(make_env) -> None:
    par = make_env()
    nets = make_networks(par, TINY, *standardise_stats(record(par, None, TINY, 30).views))
    before = [p.detach().clone() for p in nets.actor_net.parameters()]
    history = ppo(nets, make_env, TINY)
    assert [h["frames"] for h in history] == [60, 120]
    for h in history:
        assert all(np.isfinite(v) for v in h.values())
    after = list(nets.actor_net.parameters())
    assert any(not torch.equal(a, b) for a, b in zip(before, after, strict=True))


def test_the_clone_follows_its_teacher_and_the_policy_keeps_the_masks(trained, atlas) -> None:
    assert trained.imitation_agreement is not None and trained.imitation_agreement > 0.9
    assert len(trained.history) == 2 and set(trained.seconds) == {"imitation", "ppo"}
    env = ExpectedRULObservation(BrakeWearFleetEnv(CFG, atlas=atlas), routes=("hot",))
    (ep,) = run_episodes(env, trained.policy, [7], check_masks=True)  # raises on a masked duty
    assert ep.shifts == CFG.episode_shifts and np.isfinite(ep.per_vehicle_shift)


def test_same_seed_same_policy(trained, make_env, atlas) -> None:
    again = train_marl(make_env, TINY, teacher=_teacher())
    env = ExpectedRULObservation(BrakeWearFleetEnv(CFG, atlas=atlas), routes=("hot",))
    obs, _ = env.reset(seed=11)
    for _ in range(5):
        a, _ = trained.policy.predict(obs)
        b, _ = again.policy.predict(obs)
        np.testing.assert_array_equal(trained.policy.logits(obs)[0], again.policy.logits(obs)[0])
        np.testing.assert_array_equal(a, b)
        obs, *_ = env.step(a)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [({"minibatch": 0}, "minibatch"), ({"frames_per_batch": 10, "minibatch": 20}, "minibatch"),
     ({"gamma": 1.5}, "gamma"), ({"frames": 0}, "nothing to train"), ({"clip": 0.0}, "clip")],
)  # fmt: skip
def test_bad_settings_are_named(kwargs, name) -> None:
    with pytest.raises(ValueError, match=name):
        MarlTraining(**kwargs)


def test_the_env_must_show_the_rul_and_leave_the_spares_to_a_rule(atlas) -> None:
    with pytest.raises(ValueError, match="predictor="):
        train_marl(lambda: BrakeWearFleetParallelEnv(CFG, atlas=atlas, spares=S_S),
                   MarlTraining(frames=60, frames_per_batch=60, minibatch=30))  # fmt: skip
    with pytest.raises(ValueError, match="teacher"):
        train_marl(lambda: BrakeWearFleetParallelEnv(CFG, atlas=atlas), TINY)


def test_the_needs_are_covered_when_the_vehicles_all_choose_the_drifts(atlas) -> None:
    """A shared policy whose every vehicle picks the mild route: alone it leaves the ramp
    empty; with ``cover`` the dispatch repair sends the healthiest able ones to it."""

    def to_the_drifts(views: torch.Tensor) -> torch.Tensor:
        logits = torch.zeros((*views.shape[:-1], 4))
        logits[..., MILD] = 5.0
        return logits

    env = ExpectedRULObservation(BrakeWearFleetEnv(CFG, atlas=atlas), routes=("hot",))
    obs, _ = env.reset(seed=2)
    spares = SparesRule(*S_S)
    alone = MarlFleetPolicy(to_the_drifts, CFG, spares).predict(obs)[0]
    covered = MarlFleetPolicy(to_the_drifts, CFG, spares, cover=True).predict(obs)[0]
    n = CFG.n_vehicles
    assert (alone[:n] == MILD).all()
    assert (covered[:n] == HOT).sum() == CFG.hot_need
    view = FleetView.read(obs, FleetLayout.of(CFG, routes=("hot",)))
    np.testing.assert_array_equal(covered[:n], cover_needs(CFG, alone[:n], view))
    assert covered[n] == alone[n]  # the spares' order is the rule's either way


def test_with_a_base_rule_each_view_ends_with_its_duty_and_a_copying_policy_acts_as_it(
    atlas,
) -> None:
    """The base rule's duty for each vehicle is the view's last four values (one-hot); a
    network that copies them acts exactly as the rule, on an observation with more RUL
    fields (both routes, mean and bounds) than the views read (the hot mean)."""
    fields = ("rul_mean", "rul_lower", "rul_upper")
    env = ExpectedRULObservation(BrakeWearFleetEnv(CFG, atlas=atlas), fields=fields)
    layout = FleetLayout.of(CFG, fields=fields, routes=("hot", "mild"))
    hot_only = ExpectedRULObservation(BrakeWearFleetEnv(CFG, atlas=atlas), routes=("hot",))
    # pads of ~240 hot shifts: a can-do limit of 200 has the rule service at windows
    rule = opportunistic_rule(FleetLayout.of(CFG, routes=("hot",)), n=200.0, N=3.0, s=1, S=3)

    def copy_the_base(views: torch.Tensor) -> torch.Tensor:
        return 10.0 * views[..., -4:]

    policy = MarlFleetPolicy(copy_the_base, CFG, SparesRule(*S_S), base=rule, layout=layout)
    (obs, _), (obs_hot, _) = env.reset(seed=4), hot_only.reset(seed=4)
    n, services, done = CFG.n_vehicles, 0, False
    while not done:  # a whole episode
        views = shared_views(obs, CFG, layout, rule)
        expected = rule.predict(obs_hot)[0]
        np.testing.assert_array_equal(views[:, -4:].argmax(1), expected[:n])
        np.testing.assert_array_equal(views[:, :-4], vehicle_views(obs_hot, CFG, True))
        action = policy.predict(obs)[0]
        np.testing.assert_array_equal(action, expected)
        services += int((action[:n] == SERVICE).sum())
        (obs, _, end, cut, _), (obs_hot, *_) = env.step(action), hot_only.step(action)
        done = end or cut
    assert services > 0  # the rule's services were copied too, not only its routes
