"""BrakeWear-v0 through TorchRL (issue 22 item 6): ``GymEnv`` passes ``frameskip`` and
retries without it on the ``TypeError`` of an unknown keyword; its spec checker passes."""

from __future__ import annotations

import pytest

import brake_env  # noqa: F401  # registers BrakeWear-v0

pytest.importorskip("torchrl")


def test_torchrl_gym_env_and_spec_check() -> None:
    from torchrl.envs import GymEnv
    from torchrl.envs.utils import check_env_specs

    env = GymEnv("BrakeWear-v0", decision_interval=500, k_mean=1e-5)
    check_env_specs(env, seed=0)
    td = env.rollout(5)
    assert td["next", "observation"].shape == (5, 7)
    assert td["next", "reward"].shape == (5, 1)
    assert not td["next", "done"].any()
