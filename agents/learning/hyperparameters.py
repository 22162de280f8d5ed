"""The agents' hyperparameters: ``agents/learning/hyperparams/<predictor>.toml``, RL Zoo
style (one file per predictor, one table per algorithm), and the RL Zoo file
(``hyperparams/rl_zoo3/<algo>.yml``) for training with ``rl_zoo3.train`` itself.

Light on purpose (no torch, no SB3): the command line reads :data:`ALGOS` at parse time.
A table mixes the algorithm's keyword arguments with the keys of :class:`VecSettings`,
which configure the vector env around it.
"""

from __future__ import annotations

import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

ALGOS = ("ppo", "dqn")
HYPERPARAMS_DIR = Path(__file__).parent / "hyperparams"


def hyperparams_file(predictor: str) -> Path:
    """Where the installed package keeps ``predictor``'s hyperparameter file."""
    return HYPERPARAMS_DIR / f"{predictor}.toml"


def rl_zoo_file(algo: str = "ppo") -> Path:
    """Where the installed package keeps its RL Zoo hyperparameter file for ``algo``
    (``--conf-file`` of ``python -m rl_zoo3.train``)."""
    path = HYPERPARAMS_DIR / "rl_zoo3" / f"{algo}.yml"
    if not path.exists():
        have = sorted(p.stem for p in path.parent.glob("*.yml"))
        raise FileNotFoundError(f"no RL Zoo file for {algo!r}; the package has {have}")
    return path


def load_hyperparams(predictor: str, algo: str, path: str | Path | None = None) -> dict[str, Any]:
    """The ``[algo]`` table of ``path`` (default :func:`hyperparams_file`)."""
    check_algo(algo)
    file = Path(path) if path else hyperparams_file(predictor)
    if not file.exists():
        raise FileNotFoundError(f"hyperparameter file {file} does not exist")
    with open(file, "rb") as f:
        tables = tomllib.load(f)
    if algo not in tables:
        raise ValueError(f"{file}: no [{algo}] table")
    return dict(tables[algo])


def check_algo(algo: str) -> None:
    if algo not in ALGOS:
        raise ValueError(f"unknown algorithm {algo!r}; valid are {list(ALGOS)}")


@dataclass(frozen=True)
class VecSettings:
    """The keys of a hyperparameter table that configure the env, not the algorithm.

    Attributes:
        n_envs: Training envs in the SB3 vector env.
        norm_obs: Normalise observations (VecNormalize).
        norm_reward: Normalise rewards (VecNormalize).
        net_arch: Hidden layer widths of the policy's MLP.
        initial_replace_prob: P(replace) of the untrained PPO policy (None: SB3's 1/2).
        torch_threads: torch's threads (a tiny MLP gains nothing from more on 2 cores).
    """

    n_envs: int = 1
    norm_obs: bool = True
    norm_reward: bool = True
    net_arch: tuple[int, ...] = (64, 64)
    initial_replace_prob: float | None = None
    torch_threads: int = 1

    @classmethod
    def split(cls, table: Mapping[str, Any]) -> tuple[VecSettings, dict[str, Any]]:
        """A hyperparameter table as these settings and the algorithm's keyword arguments."""
        names = {f.name for f in fields(cls)}
        prob = table.get("initial_replace_prob")
        settings = cls(
            n_envs=int(table.get("n_envs", 1)),
            norm_obs=bool(table.get("norm_obs", True)),
            norm_reward=bool(table.get("norm_reward", True)),
            net_arch=tuple(table.get("net_arch", (64, 64))),
            initial_replace_prob=None if prob is None else float(prob),
            torch_threads=int(table.get("torch_threads", 1)),
        )
        return settings, {k: v for k, v in table.items() if k not in names}
