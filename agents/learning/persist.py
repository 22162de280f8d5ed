"""Trained agents on disk without pickle.

SB3's ``model.zip`` is cloudpickle inside: loading it runs whatever code a crafted file
holds. A saved agent is instead a pair of files any reader can check before trusting:

- ``agent.npz``: the policy's ``state_dict`` (``policy.<name>``), the observation space's
  bounds and the VecNormalize observation statistics (``norm.mean``, ``norm.var``), plain
  numeric arrays read back with ``allow_pickle=False``;
- ``agent.json``: the header, written last: format version, algorithm, the policy class and
  its constructor settings (net_arch, activation, ...; classes by name from a fixed table,
  never imported by name), the spaces, the normalisation settings (clip, epsilon, on/off),
  what the caller adds (``info``, e.g. the predictor) and the SHA-256 of ``agent.npz``.

:func:`load_agent` builds the SB3 policy class from those settings, then
``load_state_dict`` from tensors made from the numpy arrays (no ``torch.load``).
Loading a ``model.zip`` is possible only through :func:`load_sb3_model_trusted`.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from agents.learning.normalization import ObsNormalization
from brake_env.output import read_arrays, write_arrays, write_text
from brake_env.saved import SavedFormat, read_saved_header

if TYPE_CHECKING:
    from stable_baselines3 import DQN, PPO
    from stable_baselines3.common.base_class import BaseAlgorithm
    from stable_baselines3.common.policies import BasePolicy
    from stable_baselines3.common.vec_env import VecNormalize

__all__ = [
    "ObsNormalization", "SavedAgent", "convert_trusted_model_zip", "load_agent",
    "load_sb3_model_trusted", "read_agent", "read_agent_header", "save_agent", "write_agent",
]  # fmt: skip

FORMAT = "brakewear-agent"
FORMAT_VERSION = 1
HEADER = "agent.json"
ARRAYS = "agent.npz"
SAVED = SavedFormat(
    "agent",
    "agent",
    HEADER,
    FORMAT,
    FORMAT_VERSION,
    ("algo", "policy", "observation_space", "action_space", "normalization", "arrays_sha256"),
    redo="train it again",
)
_STATE = "policy."
_CLASS = "$class"
# bool, ints, floats: what a policy's state and the statistics are made of.
_PLAIN_KINDS = frozenset("biuf")


def _classes() -> dict[str, type]:
    """The classes a header may name: SB3's MLP policies and their building blocks."""
    from stable_baselines3.common.policies import ActorCriticPolicy
    from stable_baselines3.common.torch_layers import FlattenExtractor
    from stable_baselines3.dqn.policies import DQNPolicy
    from torch import nn, optim

    allowed: list[type] = [ActorCriticPolicy, DQNPolicy, FlattenExtractor]
    allowed += [nn.Tanh, nn.ReLU, nn.LeakyReLU, nn.ELU, nn.GELU, nn.SiLU, nn.Sigmoid]
    allowed += [optim.Adam, optim.AdamW, optim.RMSprop, optim.SGD]
    return {c.__name__: c for c in allowed}


@dataclass
class SavedAgent:
    """An agent read by :func:`load_agent`.

    Attributes:
        algo: ``ppo`` or ``dqn`` (what trained it; the policy needs no algorithm).
        policy: The SB3 policy, in evaluation mode on the CPU.
        normalization: Its observation statistics.
        info: What the writer kept with it (``save_agent``'s ``info``).
    """

    algo: str
    policy: BasePolicy
    normalization: ObsNormalization
    info: dict[str, Any] = field(default_factory=dict)

    def predict(
        self,
        observation: NDArray[Any],
        state: tuple[NDArray[Any], ...] | None = None,
        episode_start: NDArray[np.bool_] | None = None,
        deterministic: bool = True,
    ) -> tuple[NDArray[Any], tuple[NDArray[Any], ...] | None]:
        """SB3's ``predict`` on an observation already normalised (as ``model.predict``)."""
        return self.policy.predict(observation, state, episode_start, deterministic)


# ---------------------------------------------------------------------- writing
def save_agent(
    model: BaseAlgorithm,
    path: str | os.PathLike[str],
    normalization: VecNormalize | ObsNormalization | None = None,
    *,
    info: Mapping[str, Any] | None = None,
) -> Path:
    """Write ``model``'s policy and observation statistics to directory ``path``.

    Args:
        model: A PPO or DQN model with an MLP policy.
        path: The agent's directory (created if needed); ``agent.json`` and ``agent.npz``.
        normalization: The VecNormalize it was trained in, or its statistics; None when
            observations were not normalised.
        info: Anything JSON-able to keep in the header.

    Returns:
        ``path``.

    Raises:
        ValueError: A policy, space or setting this format does not describe.
    """
    header, arrays = _describe(model.policy)
    norm = normalization
    if norm is None:
        norm = ObsNormalization.identity(arrays["space.low"].size)
    elif not isinstance(norm, ObsNormalization):
        norm = ObsNormalization.from_vec_normalize(norm)
    arrays["norm.mean"], arrays["norm.var"] = norm.mean, norm.var
    header = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "algo": type(model).__name__.lower(),
        **header,
        "normalization": {
            "clip_obs": norm.clip_obs,
            "epsilon": norm.epsilon,
            "enabled": norm.enabled,
        },
        "info": dict(info or {}),
    }
    return write_agent(header, arrays, path)


def write_agent(
    header: Mapping[str, Any], arrays: Mapping[str, NDArray[Any]], path: str | os.PathLike[str]
) -> Path:
    """Write a saved agent's header and arrays (as :func:`read_agent` gives them) to
    directory ``path``: ``agent.npz``, then ``agent.json`` with its SHA-256.

    Raises:
        ValueError: The header is not standard JSON.
    """
    path = Path(path)
    try:
        json.dumps(header, allow_nan=False)
    except (TypeError, ValueError) as e:
        raise ValueError(f"save_agent: the header is not standard JSON ({e})") from None
    path.mkdir(parents=True, exist_ok=True)
    head = {**header, "arrays_sha256": write_arrays(dict(arrays), path / ARRAYS)}
    write_text(json.dumps(head, indent=2) + "\n", path / HEADER)  # last: it vouches for them
    return path


def _describe(policy: BasePolicy) -> tuple[dict[str, Any], dict[str, NDArray[Any]]]:
    """The header's policy and spaces, and the arrays: state and observation bounds."""
    from gymnasium import spaces
    from stable_baselines3.common.policies import ActorCriticPolicy

    name = type(policy).__name__
    if _classes().get(name) is not type(policy):
        raise ValueError(f"save_agent: policy class {name} is not one this format describes")
    params = dict(policy._get_constructor_parameters())
    obs, act = params.pop("observation_space"), params.pop("action_space")
    params.pop("lr_schedule", None)
    if isinstance(policy, ActorCriticPolicy):  # not among SB3's constructor parameters
        params["share_features_extractor"] = policy.share_features_extractor
    if not isinstance(obs, spaces.Box) or not isinstance(act, spaces.Discrete):
        raise ValueError(f"save_agent: spaces {obs} -> {act}; only Box -> Discrete are saved")
    arrays: dict[str, NDArray[Any]] = {"space.low": obs.low, "space.high": obs.high}
    for k, v in policy.state_dict().items():
        arrays[_STATE + k] = v.detach().cpu().numpy()
    head = {
        "policy": {"class": name, "kwargs": {k: _encode(k, v) for k, v in params.items()}},
        "observation_space": {"shape": list(obs.shape), "dtype": str(obs.dtype)},
        "action_space": {"n": int(act.n), "start": int(act.start)},
    }
    return head, arrays


def _encode(key: str, value: Any) -> Any:
    if isinstance(value, type):
        if _classes().get(value.__name__) is not value:
            raise ValueError(f"save_agent: policy setting {key}={value!r} is not a known class")
        return {_CLASS: value.__name__}
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, dict):
        return {str(k): _encode(key, v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_encode(key, v) for v in value]
    return value


# ---------------------------------------------------------------------- reading
def read_agent_header(path: str | os.PathLike[str]) -> dict[str, Any]:
    """The checked header of a saved agent (reads no arrays).

    Raises:
        FileNotFoundError: No ``agent.json`` in ``path`` (an SB3-only folder says how to
            convert it).
        ValueError: Not a brakewear agent, or a format version this version does not read.
    """
    path = Path(path)
    hint = ""
    if not (path / HEADER).is_file() and (path / "model.zip").is_file():
        hint = (
            ": it holds only SB3's model.zip, which loads by unpickling (a crafted file runs"
            " code); if you trust it,"
            " agents.learning.persist.convert_trusted_model_zip converts it"
        )
    return read_saved_header(path, SAVED, hint)


def read_agent(path: str | os.PathLike[str]) -> tuple[dict[str, Any], dict[str, NDArray[Any]]]:
    """A saved agent's checked header and arrays, as :func:`write_agent` writes them
    (to carry an agent elsewhere without its files)."""
    header = read_agent_header(path)
    return header, _read_arrays(Path(path), header["arrays_sha256"])


def load_agent(path: str | os.PathLike[str]) -> SavedAgent:
    """The agent saved by :func:`save_agent` in directory ``path``; never opens model.zip.

    Raises:
        FileNotFoundError: No saved agent at ``path``.
        ValueError: A header or arrays that do not describe a policy this version builds:
            another format version, arrays that are not the ones the header was written with,
            a class outside the known table, or weights that do not fit the architecture.
    """
    path = Path(path)
    header, arrays = read_agent(path)
    try:
        policy = _build_policy(header, arrays)
        norm = header["normalization"]
        normalization = ObsNormalization(
            arrays["norm.mean"],
            arrays["norm.var"],
            float(norm["clip_obs"]),
            float(norm["epsilon"]),
            bool(norm["enabled"]),
        )
    except (KeyError, TypeError, RuntimeError, ValueError) as e:
        raise ValueError(f"agent {path}: cannot rebuild the policy ({e})") from None
    return SavedAgent(str(header["algo"]), policy, normalization, dict(header.get("info") or {}))


def _read_arrays(path: Path, sha256: str) -> dict[str, NDArray[Any]]:
    arrays = read_arrays(path / ARRAYS, sha256, f"agent {path}")
    bad = [k for k, a in arrays.items() if a.dtype.kind not in _PLAIN_KINDS]
    if bad:
        raise ValueError(f"agent {path}: {ARRAYS} arrays {bad} are not numeric")
    return arrays


def _build_policy(header: Mapping[str, Any], arrays: Mapping[str, NDArray[Any]]) -> BasePolicy:
    """The policy class of the header, built on its spaces, with the saved weights."""
    import torch
    from gymnasium import spaces
    from stable_baselines3.common.policies import BasePolicy

    spec, obs, act = header["policy"], header["observation_space"], header["action_space"]
    cls = _decode({_CLASS: spec["class"]})
    if not issubclass(cls, BasePolicy):
        raise ValueError(f"{spec['class']!r} is not a policy class")
    low, high = arrays["space.low"], arrays["space.high"]
    if list(low.shape) != list(obs["shape"]):
        raise ValueError(f"observation bounds of shape {low.shape}, header says {obs['shape']}")
    obs_space = spaces.Box(low, high, dtype=np.dtype(obs["dtype"]).type)
    act_space = spaces.Discrete(int(act["n"]), int(act["start"]))
    kwargs = _decode(dict(spec["kwargs"]))
    policy = cls(obs_space, act_space, BasePolicy._dummy_schedule, **kwargs)
    state = {
        k[len(_STATE) :]: torch.from_numpy(np.array(a, copy=True))
        for k, a in arrays.items()
        if k.startswith(_STATE)
    }
    policy.load_state_dict(state, strict=True)
    policy.set_training_mode(False)
    return policy


def _decode(value: Any) -> Any:
    if isinstance(value, dict):
        if set(value) == {_CLASS}:
            name = value[_CLASS]
            known = _classes()
            if name not in known:
                raise ValueError(f"class {name!r} is not one this version builds: {sorted(known)}")
            return known[name]
        return {k: _decode(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_decode(v) for v in value]
    return value


# ---------------------------------------------------------------------- trusted input only
def load_sb3_model_trusted(path: str | os.PathLike[str], algo: str) -> PPO | DQN:
    """SB3's own ``model.zip``, loaded by SB3 -- TRUSTED INPUT ONLY.

    SB3 unpickles parts of the file (cloudpickle): a crafted ``model.zip`` runs arbitrary
    code the moment it is loaded. Call this only on files you wrote yourself, e.g. to resume
    training; to act, use :func:`load_agent`.
    """
    from stable_baselines3 import DQN, PPO

    classes: dict[str, type[PPO] | type[DQN]] = {"ppo": PPO, "dqn": DQN}
    if algo not in classes:
        raise ValueError(f"unknown algorithm {algo!r}; valid are {sorted(classes)}")
    return classes[algo].load(Path(path), device="cpu")


def convert_trusted_model_zip(path: str | os.PathLike[str]) -> Path:
    """Write ``agent.json`` and ``agent.npz`` for an agent folder that has only SB3's
    ``model.zip`` -- TRUSTED INPUT ONLY (it is loaded by :func:`load_sb3_model_trusted`).

    The algorithm and ``info`` come from ``train.json``, the observation statistics from
    ``obs_normalization.npz`` (numbers only), both as ``brakewear train`` writes them.
    """
    path = Path(path)
    meta = json.loads((path / "train.json").read_text())
    model = load_sb3_model_trusted(path / "model.zip", str(meta["algo"]))
    norm = ObsNormalization.load(path / "obs_normalization.npz")
    return save_agent(model, path, norm, info=meta)
