"""The distilled policy's parts (agents.fleet.learning.vehicle_net, cover_needs,
train_on_labels): the shared per-vehicle network is permutation-equivariant, the pooled
statistics compare vehicles, the needs are covered from idle vehicles only, and cloning
from recorded labels is deterministic for a seed."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from agents.fleet.learning.agent import ReorderBy, oracle_fleet_env, train_on_labels
from agents.fleet.learning.dispatch import cover_needs
from agents.fleet.learning.imitation import record
from agents.fleet.policies.rules import FleetRule, FleetRuleParams
from agents.fleet.policies.view import FleetLayout, FleetView
from agents.fleet.settings import FleetTraining
from brake_env.env.fleet.config import FleetConfig
from brake_env.env.fleet.shop import HOT, MILD, PARK, SERVICE
from brake_env.env.fleet.spaces import FLEET_FEATURES, N_VF
from tests.agents.fleet.learning.small_fleet import CFG

pytest.importorskip("sb3_contrib")
torch = pytest.importorskip("torch")

DEFAULT = FleetConfig()  # 12 vehicles: 6 on the ramp, 4 in the drifts


def _view(rul: list[float], down: list[bool] | None = None, to_window: int = 5) -> FleetView:
    n = len(rul)
    r = np.array(rul, dtype=float)
    return FleetView(rul=r, age=np.zeros(n), down=np.array(down or [False] * n), shift=3,
                     to_window=to_window, stock=2, transit=0, free_bays=1)  # fmt: skip


def test_cover_needs_sends_the_healthiest_idle_vehicles_to_the_short_routes() -> None:
    rul = [float(v) for v in range(10, 130, 10)]  # vehicle i has 10 (i + 1) shifts
    duty = np.full(12, PARK)
    duty[[0, 1, 2, 3]] = HOT  # 2 short of the ramp's 6
    duty[4] = MILD  # 3 short of the drifts' 4
    duty[5] = SERVICE
    got = cover_needs(DEFAULT, duty, _view(rul))
    assert list(np.flatnonzero(got == HOT)) == [0, 1, 2, 3, 10, 11]  # the two healthiest idle
    assert list(np.flatnonzero(got == MILD)) == [4, 7, 8, 9]  # then the next three
    assert got[5] == SERVICE and list(np.flatnonzero(got == PARK)) == [6]


def test_cover_needs_moves_drift_trucks_to_a_short_ramp_spare_drifts_first() -> None:
    """The distilled policy's failure seen at the default fleet: 2 on the ramp, 8 in the
    drifts (the needs 6 and 4), nobody idle to send."""
    rul = [float(v) for v in range(10, 130, 10)]
    duty = np.array([HOT, HOT] + [MILD] * 8 + [PARK, PARK])
    got = cover_needs(DEFAULT, duty, _view(rul, down=[False] * 10 + [True, True]))
    assert list(np.flatnonzero(got == HOT)) == [0, 1, 6, 7, 8, 9]  # the 4 healthiest drifts
    assert list(np.flatnonzero(got == MILD)) == [2, 3, 4, 5]  # the drifts stay covered
    # Drifts only at their need, one idle truck: it goes first, then the healthiest drift
    # (a drift short costs half a ramp shift), and nobody is left for the drifts.
    duty = np.array([HOT] * 4 + [MILD] * 4 + [PARK] * 4)
    got = cover_needs(DEFAULT, duty, _view(rul, down=[False] * 8 + [True, True, True, False]))
    assert list(np.flatnonzero(got == HOT)) == [0, 1, 2, 3, 7, 11]
    assert list(np.flatnonzero(got == MILD)) == [4, 5, 6]
    # A drift truck without a shift of hot-route life never takes the ramp.
    low = [50.0] * 5 + [0.5] * 7
    got = cover_needs(DEFAULT, np.array([HOT] * 5 + [MILD] * 7), _view(low))
    assert np.array_equal(got, [HOT] * 5 + [MILD] * 7)


def test_cover_needs_leaves_covered_shifts_windows_and_unable_vehicles_alone() -> None:
    rul = [50.0] * 12
    covered = np.array([HOT] * 7 + [MILD] * 3 + [PARK] * 2)  # the 7th ramp truck covers a drift
    assert np.array_equal(cover_needs(DEFAULT, covered, _view(rul)), covered)
    idle = np.full(12, PARK)
    assert np.array_equal(cover_needs(DEFAULT, idle, _view(rul, to_window=0)), idle)
    down = [True] * 11 + [False]
    got = cover_needs(DEFAULT, idle, _view([50.0] * 11 + [0.5], down=down))
    assert np.array_equal(got, idle)  # the one able vehicle has half a shift of life left


def test_cover_needs_parks_the_services_beyond_capacity_least_urgent_first() -> None:
    rul = [5.0, 1.0, 9.0, 3.0, 7.0] + [50.0] * 7
    duty = np.array([SERVICE] * 5 + [PARK] * 7)
    window = dataclasses.replace(_view(rul, to_window=0), stock=4)  # 3 crew slots, 4 spares
    assert np.array_equal(cover_needs(DEFAULT, duty, window), duty)  # the workshop picks
    between = dataclasses.replace(_view(rul, down=[False, False, True] + [False] * 9), stock=3)
    got = cover_needs(DEFAULT, np.array([SERVICE] * 3 + [PARK] * 9), between)
    assert list(np.flatnonzero(got == SERVICE)) == [1, 2]  # the one down needs no bay
    short = dataclasses.replace(between, stock=1)  # one spare: the most urgent gets it
    assert list(np.flatnonzero(cover_needs(DEFAULT, duty[:12].copy(), short) == SERVICE)) == [1]
    assert got[0] == MILD  # parked, then it covers a drift (the healthiest six take the ramp)


def test_cover_needs_is_the_identity_on_a_rule_along_an_episode(atlas) -> None:
    env = oracle_fleet_env(CFG, atlas)
    rule = FleetRule(FleetLayout.of(CFG), FleetRuleParams())
    obs, _ = env.reset(seed=4)
    for _ in range(CFG.episode_shifts):
        action, _ = rule.predict(obs)
        view = FleetView.read(obs, rule.layout)
        assert np.array_equal(cover_needs(CFG, action[:-1], view), action[:-1])
        obs, *_ = env.step(action)


def _lay() -> FleetLayout:
    return FleetLayout.of(DEFAULT, fields=("rul_mean", "rul_lower", "rul_upper"))


def test_pooled_statistics_are_one_per_feature_and_pool_the_spread() -> None:
    from agents.fleet.learning.vehicle_net import VehicleLayout, pool_vehicle_stats

    lay = VehicleLayout.of(_lay())
    size = lay.n * (N_VF + lay.k) + lay.nf
    rng = np.random.default_rng(0)
    mean, var = rng.normal(size=size), rng.uniform(1, 2, size=size)
    fleet = slice(lay.n * N_VF, lay.n * N_VF + lay.nf)
    fleet_before = mean[fleet].copy(), var[fleet].copy()
    m0 = mean[: lay.n * N_VF].reshape(lay.n, N_VF)[:, 0].copy()
    v0 = var[: lay.n * N_VF].reshape(lay.n, N_VF)[:, 0].copy()
    pool_vehicle_stats(mean, var, lay)
    per = mean[: lay.n * N_VF].reshape(lay.n, N_VF)
    assert np.allclose(per, per[0]) and per[0, 0] == pytest.approx(m0.mean())
    assert var[0] == pytest.approx(v0.mean() + m0.var())  # within plus between vehicles
    assert np.array_equal(mean[fleet], fleet_before[0]) and np.array_equal(
        var[fleet], fleet_before[1]
    )


def test_the_vehicle_network_is_permutation_equivariant() -> None:
    from agents.fleet.learning.vehicle_net import VehicleExtractor, VehicleHead, VehicleLayout

    lay = VehicleLayout.of(_lay(), extra=4)
    torch.manual_seed(0)
    net, head = VehicleExtractor(lay, 16), VehicleHead(lay.n, 16, 4)
    rng = np.random.default_rng(1)
    own, fleet = rng.normal(size=(lay.n, N_VF)), rng.normal(size=len(FLEET_FEATURES))
    app, extra = rng.normal(size=(lay.n, lay.k)), np.eye(4)[rng.integers(0, 4, lay.n)]
    perm = rng.permutation(lay.n)

    def flat(o: np.ndarray, a: np.ndarray, e: np.ndarray) -> torch.Tensor:
        x = np.concatenate([o.ravel(), fleet, a.ravel(), e.ravel()])
        return torch.as_tensor(x[None], dtype=torch.float32)

    x, y = flat(own, app, extra), flat(own[perm], app[perm], extra[perm])
    with torch.no_grad():
        lx, ly = (
            head(net.forward_actor(x)).reshape(lay.n, 4),
            head(net.forward_actor(y)).reshape(lay.n, 4),
        )
        vx, vy = net.forward_critic(x), net.forward_critic(y)
    assert torch.allclose(lx[perm], ly, atol=1e-6)  # each vehicle's logits follow it
    assert torch.allclose(vx, vy, atol=1e-6)  # the critic does not care about the order
    assert not torch.allclose(lx[0], lx[1])  # and vehicles with other values differ


SETTINGS = FleetTraining(timesteps=0, n_envs=1, batch_size=32, imitation_episodes=1,
                         imitation_epochs=3, reorder=(1, 2), cover_needs=True,
                         vehicle_net=True, net_arch=(16, 16), seed=5)  # fmt: skip


@pytest.fixture(scope="module")
def labels(atlas):
    rule = FleetRule(FleetLayout.of(CFG), FleetRuleParams(s=1, S=2))
    env = ReorderBy(oracle_fleet_env(CFG, atlas), 1, 2)
    return record(env, rule, [11, 12], drop_order=True)


def test_cloning_from_labels_is_deterministic_for_a_seed_and_differs_across_seeds(atlas, labels):
    def clone(seed: int):
        st = dataclasses.replace(SETTINGS, seed=seed)
        return train_on_labels(
            lambda: oracle_fleet_env(CFG, atlas), FleetLayout.of(CFG), st, labels
        )

    a, b, c = clone(5), clone(5), clone(6)
    obs = labels.obs[:8]
    pa = [a.model.policy.state_dict()[k] for k in sorted(a.model.policy.state_dict())]
    pb = [b.model.policy.state_dict()[k] for k in sorted(b.model.policy.state_dict())]
    pc = [c.model.policy.state_dict()[k] for k in sorted(c.model.policy.state_dict())]
    assert all(torch.equal(x, y) for x, y in zip(pa, pb, strict=True))
    assert not all(torch.equal(x, y) for x, y in zip(pa, pc, strict=True))
    assert np.array_equal(a.normalize(obs), b.normalize(obs))
    assert a.imitation is not None and a.imitation.samples == len(labels.rewards) == 2 * 20
    # the statistics were pooled over vehicles: both vehicles' RUL share one scale
    k = FleetLayout.of(CFG).per_vehicle
    assert a.mean[-k] == a.mean[-2 * k] and a.std[-k] == a.std[-2 * k]


def test_the_vehicle_network_refuses_an_order_in_its_action(atlas, labels) -> None:
    st = dataclasses.replace(SETTINGS, reorder=None)
    with pytest.raises(ValueError, match="set reorder"):
        train_on_labels(lambda: oracle_fleet_env(CFG, atlas), FleetLayout.of(CFG), st, labels)


def test_the_fast_deterministic_action_is_sb3_s(atlas, labels) -> None:
    for vehicle_net in (True, False):
        st = dataclasses.replace(SETTINGS, vehicle_net=vehicle_net, cover_needs=False)
        lay = FleetLayout.of(CFG)  # the flat MLP clones through train_on_labels too
        agent = train_on_labels(lambda: oracle_fleet_env(CFG, atlas), lay, st, labels)
        for obs, m in zip(labels.obs, labels.masks, strict=True):
            want, _ = agent.model.predict(agent.normalize(obs), action_masks=m, deterministic=True)
            assert np.array_equal(agent.mode(agent.normalize(obs), m), want)
            got, _ = agent.predict(obs)
            assert np.array_equal(got[:-1], want)  # predict takes the fast path


def test_the_numpy_actor_gives_the_torch_logits() -> None:
    from agents.fleet.learning.vehicle_net import (
        VehicleExtractor,
        VehicleHead,
        VehicleLayout,
        numpy_actor,
    )

    lay = VehicleLayout.of(_lay(), extra=4)

    class Policy:  # the two modules numpy_actor reads
        mlp_extractor = VehicleExtractor(lay, 16)
        action_net = VehicleHead(lay.n, 16, 4)

    rng = np.random.default_rng(2)
    z = rng.normal(size=lay.n * (N_VF + lay.k + lay.extra) + lay.nf).astype(np.float32)
    z[-lay.k :: -lay.k] = z[-lay.k]  # ties in a RUL column: ranks of equals
    with torch.no_grad():
        x = torch.as_tensor(z[None])
        want = Policy.action_net(Policy.mlp_extractor.forward_actor(x))[0].numpy()
    got = numpy_actor(Policy)(z)  # type: ignore[arg-type]
    assert np.allclose(got, want, atol=1e-5)


def test_the_vehicle_policy_s_fast_evaluation_is_sb3_s(atlas, labels) -> None:
    agent = train_on_labels(
        lambda: oracle_fleet_env(CFG, atlas), FleetLayout.of(CFG), SETTINGS, labels
    )
    policy = agent.model.policy
    obs = torch.as_tensor(agent.normalize(labels.obs))
    acts, masks = torch.as_tensor(labels.actions), torch.as_tensor(labels.masks)
    with torch.no_grad():
        want_v, want_lp, _ = policy.evaluate_actions(obs, acts, action_masks=masks)
        got_v, got_lp = policy.evaluate_labels(obs, acts, masks)
    assert torch.allclose(got_v, want_v) and torch.allclose(got_lp, want_lp, atol=1e-5)


def test_the_base_rule_s_duties_are_appended_one_hot_by_the_wrapper_and_the_agent(atlas) -> None:
    from agents.fleet.learning.dispatch import BaseDuties, with_base_duties

    rule = FleetRule(FleetLayout.of(CFG), FleetRuleParams(s=1, S=2))
    env = BaseDuties(oracle_fleet_env(CFG, atlas), rule)
    plain = oracle_fleet_env(CFG, atlas)
    (got, _), (obs, _) = env.reset(seed=9), plain.reset(seed=9)
    for _ in range(5):
        duty = rule.predict(obs)[0][: CFG.n_vehicles]
        assert np.array_equal(got[: len(obs)], obs.astype(np.float32))
        assert np.array_equal(got[len(obs) :].reshape(-1, 4).argmax(1), duty)
        assert np.allclose(with_base_duties(obs, rule, CFG.n_vehicles), got)
        view = FleetView.read(obs, rule.layout)  # the agent's path: the view read once
        assert np.allclose(with_base_duties(obs, rule, CFG.n_vehicles, view), got)
        assert env.observation_space.contains(got)
        action = rule.predict(obs)[0]
        got, *_ = env.step(action)
        obs, *_ = plain.step(action)


def test_a_policy_reading_the_base_duties_clones_and_acts_on_the_plain_observation(atlas, labels):
    rule = FleetRule(FleetLayout.of(CFG), FleetRuleParams(s=1, S=2))
    st = dataclasses.replace(SETTINGS, imitation_epochs=100)
    agent = train_on_labels(lambda: oracle_fleet_env(CFG, atlas), FleetLayout.of(CFG), st, labels,
                            base=rule)  # fmt: skip
    assert agent.mean.shape == (len(labels.obs[0]) + 4 * CFG.n_vehicles,)
    same = [np.array_equal(agent.predict(o)[0], rule.predict(o)[0]) for o in labels.obs]
    assert np.mean(same) > 0.9  # the labels are the rule's own: it learns to copy its input
