"""Saved agents load without unpickling: same actions after a round trip, and a crafted
pickle (in ``model.zip`` or ``agent.npz``) never runs on the default load path."""

from __future__ import annotations

import base64
import contextlib
import hashlib
import io
import json
import pickle
import shutil
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import torch

from agents.learning.persist import (
    ARRAYS,
    HEADER,
    convert_trusted_model_zip,
    load_agent,
    load_sb3_model_trusted,
    save_agent,
)
from agents.learning.train import TrainedAgent, agent_env, train_agent
from brake_env.env.config import EnvConfig
from brake_env.model.atlas import Atlas
from brake_env.prognostics.protocol import Oracle

FAST = {"k_mean": 1e-5, "k_std": 1e-6, "decision_interval": 500, "episode_events": 30_000}
TINY = {"n_envs": 2, "n_steps": 32, "batch_size": 32, "n_epochs": 1, "net_arch": [16]}


class _Payload:
    """Unpickling it creates ``sentinel``: proof that code ran."""

    def __init__(self, sentinel: Path) -> None:
        self.sentinel = str(sentinel)

    def __reduce__(self) -> tuple[Any, ...]:
        return (open, (self.sentinel, "w"))


def _crafted_model_zip(path: Path, sentinel: Path) -> None:
    """A model.zip as SB3 reads it, whose ``data`` holds a cloudpickled payload."""
    blob = base64.b64encode(pickle.dumps(_Payload(sentinel))).decode()
    data = {"policy_class": {":type:": "<class 'type'>", ":serialized:": blob}}
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("data", json.dumps(data))
        z.writestr("_stable_baselines3_version", "2.9.2")


def _tiny_model(algo: str, atlas: Atlas) -> tuple[Any, Any]:
    """A PPO or DQN agent trained for 64 steps on BrakeWear-v0, and its VecNormalize."""
    from stable_baselines3 import DQN, PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    venv = VecNormalize(
        DummyVecEnv([lambda: agent_env(Oracle(), atlas, EnvConfig.from_kwargs(**FAST))] * 2)
    )
    venv.seed(0)
    kw: dict[str, Any] = {"seed": 0, "device": "cpu", "policy_kwargs": {"net_arch": [16]}}
    model: PPO | DQN
    if algo == "ppo":
        model = PPO("MlpPolicy", venv, n_steps=32, batch_size=32, n_epochs=1, **kw)
    else:
        model = DQN("MlpPolicy", venv, learning_starts=0, train_freq=4, batch_size=16, **kw)
    model.learn(64)
    return model, venv


def _observations(atlas: Atlas, n: int = 200) -> np.ndarray:
    """Observations the agent meets (a rollout) and far-off ones (noise), normalised."""
    env = agent_env(Oracle(), atlas, EnvConfig.from_kwargs(**FAST))
    obs, _ = env.reset(seed=1)
    seen = []
    for i in range(n // 2):
        seen.append(obs)
        obs, _, terminated, truncated, _ = env.step(int(i % 17 == 0))
        if terminated or truncated:
            obs, _ = env.reset()
    noise = np.random.default_rng(2).normal(0.0, 3.0, (n - len(seen), obs.size))
    return np.concatenate([np.asarray(seen), noise]).astype(np.float32)


def _outputs(policy: Any, obs: np.ndarray) -> torch.Tensor:
    """What the policy computes before choosing: Q-values (DQN) or action logits (PPO)."""
    with torch.no_grad():
        x = torch.as_tensor(obs)
        if hasattr(policy, "q_net"):
            return policy.q_net(x)
        return policy.get_distribution(x).distribution.logits


@pytest.fixture(scope="module", params=["ppo", "dqn"])
def tiny(request, atlas) -> tuple[str, Any, Any]:
    return (request.param, *_tiny_model(request.param, atlas))


@pytest.fixture(scope="module")
def observations(atlas) -> np.ndarray:
    return _observations(atlas)


def test_a_saved_agent_acts_exactly_as_the_trained_one(tiny, observations, tmp_path):
    algo, model, venv = tiny
    save_agent(model, tmp_path, venv, info={"predictor": "oracle"})
    saved = load_agent(tmp_path)
    assert saved.algo == algo and saved.info == {"predictor": "oracle"}
    want = model.policy.state_dict()
    got = saved.policy.state_dict()
    assert list(got) == list(want)
    assert all(torch.equal(got[k], want[k]) for k in want)
    norm = saved.normalization
    np.testing.assert_array_equal(norm.mean, venv.obs_rms.mean)
    np.testing.assert_array_equal(norm.var, venv.obs_rms.var)
    assert (norm.clip_obs, norm.epsilon, norm.enabled) == (venv.clip_obs, venv.epsilon, True)
    z = venv.normalize_obs(observations).astype(np.float32)
    torch.testing.assert_close(_outputs(saved.policy, z), _outputs(model.policy, z), rtol=0, atol=0)
    actions = saved.predict(z)[0]
    np.testing.assert_array_equal(actions, model.predict(z, deterministic=True)[0])
    assert algo == "dqn" or len(set(actions.tolist())) == 2  # the set tells the actions apart
    with np.load(tmp_path / ARRAYS, allow_pickle=False) as arrays:  # numbers only
        assert all(arrays[k].dtype.kind in "biuf" for k in arrays.files)


@pytest.fixture(scope="module")
def trained(atlas, tmp_path_factory) -> Path:
    """A folder as ``brakewear train`` writes it (tiny budget)."""
    out = tmp_path_factory.mktemp("agent")
    train_agent(
        Oracle(),
        atlas,
        out,
        timesteps=64,
        seed=0,
        env=EnvConfig.from_kwargs(**FAST),
        hyperparams=TINY,
    )
    return out


def test_train_writes_the_agent_that_trained_agent_loads(trained, observations):
    assert (trained / HEADER).is_file() and (trained / ARRAYS).is_file()
    agent = TrainedAgent(trained)
    model = load_sb3_model_trusted(trained / "model.zip", "ppo")  # we wrote it: trusted
    obs = observations
    np.testing.assert_array_equal(
        agent.predict(obs)[0], model.predict(agent.normalize(obs), deterministic=True)[0]
    )


def test_a_crafted_model_zip_is_never_opened_by_the_default_load(trained, observations, tmp_path):
    sentinel = tmp_path / "pwned"
    # The payload is live: the trusted path runs it.
    _crafted_model_zip(tmp_path / "evil.zip", sentinel)
    with contextlib.suppress(Exception):
        load_sb3_model_trusted(tmp_path / "evil.zip", "ppo")
    assert sentinel.exists()
    sentinel.unlink()
    # A folder with only the crafted model.zip: refused, naming the way out.
    only_zip = tmp_path / "only_zip"
    only_zip.mkdir()
    shutil.copy(trained / "train.json", only_zip)
    shutil.copy(trained / "obs_normalization.npz", only_zip)
    _crafted_model_zip(only_zip / "model.zip", sentinel)
    with pytest.raises(FileNotFoundError, match="convert_trusted_model_zip"):
        TrainedAgent(only_zip)
    # A saved agent beside a crafted model.zip: it loads and acts; the zip is not read.
    beside = tmp_path / "beside"
    shutil.copytree(trained, beside)
    _crafted_model_zip(beside / "model.zip", sentinel)
    obs = observations
    np.testing.assert_array_equal(
        TrainedAgent(beside).predict(obs)[0], TrainedAgent(trained).predict(obs)[0]
    )
    assert not sentinel.exists()


def _rewrite(folder: Path, arrays: dict[str, Any], **header: Any) -> None:
    """Replace a saved agent's arrays and header fields, with a matching checksum."""
    buf = io.BytesIO()
    np.savez(buf, **arrays)  # allow_pickle: object arrays are pickled in
    (folder / ARRAYS).write_bytes(buf.getvalue())
    head = json.loads((folder / HEADER).read_text())
    head.update(header, arrays_sha256=hashlib.sha256(buf.getvalue()).hexdigest())
    (folder / HEADER).write_text(json.dumps(head))


def _arrays(folder: Path) -> dict[str, Any]:
    with np.load(folder / ARRAYS, allow_pickle=False) as z:
        return {k: z[k] for k in z.files}


def test_a_pickle_inside_agent_npz_is_refused_unrun(trained, tmp_path):
    sentinel = tmp_path / "pwned"
    folder = tmp_path / "agent"
    shutil.copytree(trained, folder)
    arrays = _arrays(folder)
    arrays["norm.mean"] = np.array([_Payload(sentinel)], dtype=object)
    _rewrite(folder, arrays)
    with pytest.raises(ValueError, match=f"unreadable {ARRAYS}"):
        load_agent(folder)
    assert not sentinel.exists()


def test_bad_headers_and_arrays_are_refused_clearly(trained, tmp_path):
    def copy(name: str) -> Path:
        return Path(shutil.copytree(trained, tmp_path / name))

    head = json.loads((trained / HEADER).read_text())
    f = copy("version")
    _rewrite(f, _arrays(f), format_version=2)
    with pytest.raises(ValueError, match="format version 2"):
        load_agent(f)
    f = copy("class")
    policy = {**head["policy"], "class": "os.system"}
    _rewrite(f, _arrays(f), policy=policy)
    with pytest.raises(ValueError, match=r"'os\.system' is not one this version builds"):
        load_agent(f)
    f = copy("activation")
    kwargs = {**head["policy"]["kwargs"], "activation_fn": {"$class": "eval"}}
    _rewrite(f, _arrays(f), policy={**head["policy"], "kwargs": kwargs})
    with pytest.raises(ValueError, match="'eval' is not one"):
        load_agent(f)
    f = copy("arch")
    kwargs = {**head["policy"]["kwargs"], "net_arch": [32]}
    _rewrite(f, _arrays(f), policy={**head["policy"], "kwargs": kwargs})
    with pytest.raises(ValueError, match="cannot rebuild the policy"):
        load_agent(f)
    f = copy("checksum")
    arrays = _arrays(f)
    np.savez(f / ARRAYS, **{**arrays, "norm.mean": arrays["norm.mean"] + 1})
    with pytest.raises(ValueError, match=r"agent\.npz is not the file its header was written with"):
        load_agent(f)
    with pytest.raises(FileNotFoundError, match=r"no agent\.json"):
        load_agent(tmp_path / "nothing")


def test_an_old_folder_converts_once_trusted(trained, observations, tmp_path):
    folder = Path(shutil.copytree(trained, tmp_path / "old"))
    (folder / HEADER).unlink()
    (folder / ARRAYS).unlink()
    convert_trusted_model_zip(folder)
    obs = observations
    np.testing.assert_array_equal(
        TrainedAgent(folder).predict(obs)[0], TrainedAgent(trained).predict(obs)[0]
    )
    assert load_agent(folder).info["predictor"] == "oracle"


def test_without_normalisation_the_statistics_are_the_identity(tiny, tmp_path):
    save_agent(tiny[1], tmp_path)
    norm = load_agent(tmp_path).normalization
    assert not norm.enabled
    np.testing.assert_array_equal(norm.mean, np.zeros(norm.mean.size))
    np.testing.assert_array_equal(norm.var, np.ones(norm.var.size))
