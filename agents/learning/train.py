"""Train a Stable-Baselines3 agent to time pad replacement, on BrakeWear-v0 wrapped with a
predictor's RUL estimates; save it with its observation normalisation and load it back.

The agent's env is ``AgentFeatures(RULObservation(BrakeWear-v0, predictor))`` (age and RUL
estimates in log units of the decision interval), its reward the step's cost in planned
replacements, in SB3 vector envs under ``VecNormalize``. Training pads stream: each is
simulated only as far as it is used, fresh pads every time (no pool). Hyperparameters come
from ``agents/learning/hyperparams/<predictor>.toml`` (:mod:`agents.learning.hyperparameters`).
A learning curve (cost ratio to the oracle on a fixed set of pads against training steps) is
measured as training goes (:class:`agents.learning.curve.LearningCurve`); the agent kept is
the best one it saw. torch and SB3 are imported by the functions that use them.
"""

from __future__ import annotations

import copy
import json
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

from agents.learning.features import AgentFeatures, CostInPlanned, rul_fields
from agents.learning.hyperparameters import VecSettings, check_algo, load_hyperparams
from agents.learning.normalization import ObsNormalization
from agents.learning.persist import load_agent, save_agent
from agents.study.pads import PadSet
from brake_env.env.brake_wear import BrakeWearEnv
from brake_env.env.config import EnvConfig
from brake_env.env.wrappers import RULObservation
from brake_env.model.atlas import Atlas
from brake_env.output import write_json
from brake_env.prognostics.protocol import Oracle, RULPredictor

if TYPE_CHECKING:
    from stable_baselines3 import DQN, PPO
    from stable_baselines3.common.vec_env import VecNormalize

    from agents.learning.curve import LearningCurve

__all__ = ["TrainResult", "TrainedAgent", "agent_env", "agent_fields", "train_agent"]


def agent_fields(predictor: RULPredictor) -> tuple[str, ...]:
    """The estimate fields an agent on ``predictor`` sees."""
    return rul_fields(getattr(predictor, "interval_level", None) is not None)


def agent_env(
    predictor: RULPredictor, atlas: Atlas, env: EnvConfig | None = None
) -> gym.Env[NDArray[np.float32], Any]:
    """One BrakeWear-v0 as a learned agent sees it, with its own copy of the fitted
    predictor. Only the oracle needs the true RUL (``truth``); every other predictor's env
    simulates a pad only as far as it is used."""
    base = BrakeWearEnv(env or EnvConfig(), atlas=atlas, truth=isinstance(predictor, Oracle))
    wrapped = RULObservation(base, copy.deepcopy(predictor), fields=agent_fields(predictor))
    return CostInPlanned(AgentFeatures(wrapped))


@dataclass(frozen=True)
class TrainResult:
    """Where a trained agent is and what training cost.

    Attributes:
        out_dir: Folder with ``model.zip``, ``vecnormalize.pkl``, ``obs_normalization.npz``,
            ``train.json``, ``learning_curve.json`` and TensorBoard logs in ``tb/``.
        predictor, algo, timesteps, seed: What was trained.
        seconds: Wall time of ``learn`` (with the learning curve's evaluations).
        hyperparams: The hyperparameters used.
        best_step: Training step of the agent kept (the best on the curve's pads; the last
            one without a curve).
        curve: The learning curve's points (empty without curve pads).
    """

    out_dir: str
    predictor: str
    algo: str
    timesteps: int
    seed: int
    seconds: float
    hyperparams: dict[str, Any]
    best_step: int
    curve: list[dict[str, float]]


def train_agent(
    predictor: RULPredictor,
    atlas: Atlas,
    out_dir: str | Path,
    *,
    algo: str = "ppo",
    timesteps: int = 100_000,
    seed: int = 0,
    env: EnvConfig | None = None,
    hyperparams: dict[str, Any] | None = None,
    curve_pads: PadSet | None = None,
    n_evals: int = 20,
    progress_bar: bool = False,
    verbose: int = 0,
) -> TrainResult:
    """Train an SB3 agent against ``predictor``'s estimates and save it in ``out_dir``.

    Args:
        predictor: A fitted predictor; every env gets its own copy.
        atlas: The atlas of the env.
        out_dir: Where the model, its normalisation, the learning curve and logs go.
        algo: ``ppo`` or ``dqn``.
        timesteps: Environment steps of training (all envs together).
        seed: Seeds the algorithm and the training envs (env i gets seed + i).
        env: BrakeWear-v0's settings (default: its defaults).
        hyperparams: The algorithm's table; default the predictor's hyperparameter file.
        curve_pads: Pads (with this predictor's and the oracle's estimates) for the
            learning curve and the choice of the best agent; None: the last agent is kept.
        n_evals: Points of the learning curve.
        progress_bar: Show SB3's progress bar.
        verbose: SB3 verbosity.
    """
    import torch

    check_algo(algo)
    if timesteps < 1:
        raise ValueError(f"timesteps must be >= 1, got {timesteps}")
    hp = dict(hyperparams if hyperparams is not None else load_hyperparams(predictor.name, algo))
    settings, algo_kwargs = VecSettings.split(hp)
    torch.set_num_threads(settings.torch_threads)  # a tiny MLP gains nothing from more
    out, env = Path(out_dir), env or EnvConfig()
    out.mkdir(parents=True, exist_ok=True)
    venv = _vec_env(predictor, atlas, env, settings, seed, float(algo_kwargs.get("gamma", 0.99)))
    model = _model(algo, venv, seed, settings, algo_kwargs=algo_kwargs, out=out, verbose=verbose)
    every = max(timesteps // (settings.n_envs * max(n_evals, 1)), 1)
    curve = _curve(curve_pads, predictor, env, every)
    t0 = time.perf_counter()
    model.learn(total_timesteps=timesteps, callback=curve, progress_bar=progress_bar)
    seconds = time.perf_counter() - t0
    best_step, points = model.num_timesteps, []
    if curve is not None:
        best_step, points = curve.restore_best(model, venv), curve.points
        curve.save(out / "learning_curve.json")
    result = TrainResult(
        str(out), predictor.name, algo, timesteps, seed, seconds, hp, best_step, points
    )
    _save(model, venv, out)
    write_json({**asdict(result), "env_kwargs": env.to_kwargs()}, out / "train.json")
    venv.close()
    return result


def _curve(
    pads: PadSet | None, predictor: RULPredictor, env: EnvConfig, every: int
) -> LearningCurve | None:
    from agents.learning.curve import LearningCurve  # an SB3 callback: SB3 on use only

    if pads is None:
        return None
    return LearningCurve(pads, predictor.name, agent_fields(predictor), env, every)


def _vec_env(
    predictor: RULPredictor,
    atlas: Atlas,
    env: EnvConfig,
    settings: VecSettings,
    seed: int,
    gamma: float,
) -> VecNormalize:
    """The training vector env under VecNormalize: fresh streaming pads in every env."""
    from stable_baselines3.common.monitor import Monitor
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    def maker() -> gym.Env[Any, Any]:
        return Monitor(agent_env(predictor, atlas, env))

    venv = VecNormalize(
        DummyVecEnv([maker] * settings.n_envs),
        norm_obs=settings.norm_obs,
        norm_reward=settings.norm_reward,
        gamma=gamma,
    )
    venv.seed(seed)
    return venv


def _model(
    algo: str,
    venv: VecNormalize,
    seed: int,
    settings: VecSettings,
    *,
    algo_kwargs: dict[str, Any],
    out: Path,
    verbose: int,
) -> PPO | DQN:
    """The untrained SB3 model, logging to ``out/tb``."""
    from stable_baselines3 import DQN, PPO

    cls = {"ppo": PPO, "dqn": DQN}[algo]
    model = cls(
        "MlpPolicy",
        venv,
        seed=seed,
        device="cpu",
        policy_kwargs={"net_arch": list(settings.net_arch)},
        tensorboard_log=str(out / "tb"),
        verbose=verbose,
        **algo_kwargs,
    )
    if algo == "ppo" and settings.initial_replace_prob is not None:
        _bias_first_actions(model, settings.initial_replace_prob)
    return model


def _save(model: PPO | DQN, venv: VecNormalize, out: Path) -> None:
    """The model, SB3's own VecNormalize file (to resume training) and the observation
    statistics evaluation needs, without pickle."""
    save_agent(model, out, venv)  # agent.json + agent.npz: what TrainedAgent loads, no pickle
    model.save(out / "model.zip")
    venv.save(str(out / "vecnormalize.pkl"))
    # beside model.zip: what convert_trusted_model_zip needs to rebuild agent.json/.npz
    ObsNormalization.from_vec_normalize(venv).save(out / "obs_normalization.npz")


def _bias_first_actions(model: Any, replace_prob: float) -> None:
    """Start PPO's policy at P(replace) = ``replace_prob`` instead of 1/2.

    A policy that replaces every other step learns nothing but the cost of replacing (and
    a pad replaced within a few steps never shows the agent its end of life); a small prior
    on replacing is the usual fix for such a rare, expensive action.
    """
    if not 0.0 < replace_prob < 1.0:
        raise ValueError(f"initial_replace_prob must be in (0, 1), got {replace_prob}")
    import torch

    logit = float(np.log(replace_prob / (1.0 - replace_prob)))
    with torch.no_grad():
        model.policy.action_net.weight.mul_(0.01)
        model.policy.action_net.bias.copy_(torch.tensor([0.0, logit]))


class TrainedAgent:
    """A saved agent as a policy: normalises observations with its training statistics,
    then asks the SB3 model (deterministic by default). Acts on ``agent_env`` observations,
    one or a batch.

    Args:
        out_dir: A folder written by :func:`train_agent`.
    """

    def __init__(self, out_dir: str | Path) -> None:
        out = Path(out_dir)
        meta = json.loads((out / "train.json").read_text())
        # agent.json + agent.npz, never the pickled model.zip (agents.learning.persist)
        self.model = load_agent(out)
        self.normalization = self.model.normalization
        self.predictor = str(meta["predictor"])

    def normalize(self, obs: NDArray[Any]) -> NDArray[np.float32]:
        return self.normalization.normalize(obs)

    def predict(
        self,
        observation: NDArray[Any],
        state: tuple[NDArray[Any], ...] | None = None,
        episode_start: NDArray[np.bool_] | None = None,
        deterministic: bool = True,
    ) -> tuple[NDArray[Any], tuple[NDArray[Any], ...] | None]:
        action, state = self.model.predict(
            self.normalize(observation), state, episode_start, deterministic
        )
        return np.asarray(action), state
