"""Train a Stable-Baselines3 agent to time pad replacement, on BrakeWear-v0 wrapped with a
predictor's RUL estimates; save it with its observation normalisation and load it back.

The agent's env is ``AgentFeatures(RULObservation(BrakeWear-v0, predictor, precompute))``
in SB3 vector envs under ``VecNormalize``. Hyperparameters come from
``agents/hyperparams/<predictor>.toml`` (:mod:`agents.hyperparameters`). torch and SB3 are
imported by the functions that use them, so importing this module stays light.
"""

from __future__ import annotations

import copy
import json
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any
from weakref import WeakKeyDictionary

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

from agents.features import AgentFeatures
from agents.hyperparameters import VecSettings, check_algo, load_hyperparams
from brake_env.env.brake_wear import BrakeWearEnv
from brake_env.env.pads import PadLife
from brake_env.env.wrappers import RULObservation
from brake_env.model.atlas import Atlas
from brake_env.prognostics.protocol import RULEstimate, RULPredictor

if TYPE_CHECKING:
    from stable_baselines3 import DQN, PPO
    from stable_baselines3.common.callbacks import CallbackList
    from stable_baselines3.common.vec_env import VecNormalize

__all__ = ["TrainResult", "TrainedAgent", "agent_env", "train_agent"]


def agent_env(
    predictor: RULPredictor,
    atlas: Atlas,
    env_kwargs: dict[str, Any] | None = None,
    estimate_cache: WeakKeyDictionary[PadLife, RULEstimate] | None = None,
) -> gym.Env[NDArray[np.float32], Any]:
    """One BrakeWear-v0 as a learned agent sees it (its own copy of the fitted predictor;
    ``estimate_cache`` shares precomputed estimates between envs of one predictor)."""
    base = BrakeWearEnv(atlas=atlas, **(env_kwargs or {}))
    return AgentFeatures(
        RULObservation(
            base, copy.deepcopy(predictor), precompute=True, estimate_cache=estimate_cache
        )
    )


@dataclass(frozen=True)
class TrainResult:
    """Where a trained agent is and what training cost.

    Attributes:
        out_dir: Folder with ``model.zip``, ``vecnormalize.pkl``, ``obs_normalization.npz``,
            ``train.json``, ``checkpoints/``, ``eval/`` and TensorBoard logs in ``tb/``.
        predictor, algo, timesteps, seed: What was trained.
        seconds: Wall time of ``learn`` (training, evaluation and checkpoint callbacks).
        hyperparams: The hyperparameters used.
    """

    out_dir: str
    predictor: str
    algo: str
    timesteps: int
    seed: int
    seconds: float
    hyperparams: dict[str, Any]


def train_agent(
    predictor: RULPredictor,
    atlas: Atlas,
    out_dir: str | Path,
    *,
    algo: str = "ppo",
    timesteps: int = 100_000,
    seed: int = 0,
    env_kwargs: dict[str, Any] | None = None,
    hyperparams: dict[str, Any] | None = None,
    eval_episodes: int = 1,
    n_evals: int = 4,
    progress_bar: bool = False,
    verbose: int = 0,
) -> TrainResult:
    """Train an SB3 agent against ``predictor``'s estimates and save it in ``out_dir``.

    Args:
        predictor: A fitted predictor; every env gets its own copy.
        atlas: The atlas of the env.
        out_dir: Where the model, its normalisation, checkpoints and logs go.
        algo: ``ppo`` or ``dqn``.
        timesteps: Environment steps of training (all envs together).
        seed: Seeds the algorithm and the training envs (env i gets seed + i).
        env_kwargs: BrakeWear-v0 keyword arguments.
        hyperparams: The algorithm's table; default the predictor's hyperparameter file.
        eval_episodes: Episodes of each periodic evaluation (EvalCallback).
        n_evals: How many evaluations and checkpoints during training.
        progress_bar: Show SB3's progress bar.
        verbose: SB3 verbosity.
    """
    import torch

    check_algo(algo)
    if timesteps < 1:
        raise ValueError(f"timesteps must be >= 1, got {timesteps}")
    hp = dict(hyperparams if hyperparams is not None else load_hyperparams(predictor.name, algo))
    settings, algo_kwargs = VecSettings.split(hp)
    # A tiny MLP gains nothing from threads; on 2 cores they only contend with the envs.
    torch.set_num_threads(settings.torch_threads)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    gamma = float(algo_kwargs.get("gamma", 0.99))
    venv, eval_venv = _vec_envs(predictor, atlas, env_kwargs or {}, settings, seed, gamma)
    every = max(timesteps // (settings.n_envs * max(n_evals, 1)), 1)
    callbacks = _callbacks(eval_venv, out, every, eval_episodes)
    model = _model(algo, venv, seed, settings, algo_kwargs, out, verbose)
    t0 = time.perf_counter()
    model.learn(total_timesteps=timesteps, callback=callbacks, progress_bar=progress_bar)
    seconds = time.perf_counter() - t0
    result = TrainResult(str(out), predictor.name, algo, timesteps, seed, seconds, hp)
    _save(model, venv, settings, out)
    (out / "train.json").write_text(
        json.dumps({**asdict(result), "env_kwargs": env_kwargs or {}}, indent=2) + "\n"
    )
    venv.close()
    eval_venv.close()
    return result


def _vec_envs(
    predictor: RULPredictor,
    atlas: Atlas,
    env_kwargs: dict[str, Any],
    settings: VecSettings,
    seed: int,
    gamma: float,
) -> tuple[VecNormalize, VecNormalize]:
    """The training vector env and the evaluation env, both under VecNormalize.

    Training pads come from a fixed pool (``pad_pool``; 0 = fresh pads): each is simulated
    and run through the predictor once, shared by all training envs, which makes a slow
    predictor (the twin: ~4e4 events/s, ~3 s a pad) affordable to train on. Evaluation
    always meets fresh pads.
    """
    from stable_baselines3.common.monitor import Monitor
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    train_kwargs = {**env_kwargs, "pad_pool": settings.pad_pool, "pad_pool_seed": seed}
    shared: WeakKeyDictionary[PadLife, RULEstimate] = WeakKeyDictionary()

    def maker(rank: int) -> Callable[[], gym.Env[Any, Any]]:
        return lambda: Monitor(agent_env(predictor, atlas, train_kwargs, shared))

    def eval_maker() -> gym.Env[Any, Any]:
        return Monitor(agent_env(predictor, atlas, env_kwargs))

    venv = VecNormalize(
        DummyVecEnv([maker(i) for i in range(settings.n_envs)]),
        norm_obs=settings.norm_obs,
        norm_reward=settings.norm_reward,
        gamma=gamma,
    )
    venv.seed(seed)
    eval_venv = VecNormalize(
        DummyVecEnv([eval_maker]), norm_obs=settings.norm_obs, norm_reward=False, training=False
    )
    eval_venv.seed(seed + 10_000)
    return venv, eval_venv


def _callbacks(eval_venv: VecNormalize, out: Path, every: int, eval_episodes: int) -> CallbackList:
    """Periodic evaluation (``out/eval``) and checkpoints (``out/checkpoints``)."""
    from stable_baselines3.common.callbacks import CallbackList, CheckpointCallback, EvalCallback

    return CallbackList(
        [
            EvalCallback(
                eval_venv,
                n_eval_episodes=eval_episodes,
                eval_freq=every,
                log_path=str(out / "eval"),
                best_model_save_path=None,
                deterministic=True,
                verbose=0,
            ),
            CheckpointCallback(
                save_freq=every, save_path=str(out / "checkpoints"), save_vecnormalize=True
            ),
        ]
    )


def _model(
    algo: str,
    venv: VecNormalize,
    seed: int,
    settings: VecSettings,
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


def _save(model: PPO | DQN, venv: VecNormalize, settings: VecSettings, out: Path) -> None:
    """The model, SB3's own VecNormalize file (to resume training) and the observation
    statistics evaluation needs, without pickle."""
    from stable_baselines3.common.running_mean_std import RunningMeanStd

    model.save(out / "model.zip")
    venv.save(str(out / "vecnormalize.pkl"))
    rms = venv.obs_rms
    assert isinstance(rms, RunningMeanStd)  # a Box observation, not a Dict
    np.savez(
        out / "obs_normalization.npz",
        mean=rms.mean,
        var=rms.var,
        clip_obs=venv.clip_obs,
        epsilon=venv.epsilon,
        enabled=settings.norm_obs,
    )


def _bias_first_actions(model: Any, replace_prob: float) -> None:
    """Start PPO's policy at P(replace) = ``replace_prob`` instead of 1/2.

    A replacement installs a new pad, whose whole life is simulated (~40 ms), and a policy
    that replaces every other step learns nothing but the cost of replacing; a small prior
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
    then asks the SB3 model (deterministic by default). Acts on ``agent_env`` observations.

    Args:
        out_dir: A folder written by :func:`train_agent`.
    """

    def __init__(self, out_dir: str | Path) -> None:
        from stable_baselines3 import DQN, PPO

        out = Path(out_dir)
        meta = json.loads((out / "train.json").read_text())
        cls: type[PPO] | type[DQN] = PPO if meta["algo"] == "ppo" else DQN
        self.model = cls.load(out / "model.zip", device="cpu")
        with np.load(out / "obs_normalization.npz") as z:
            self.mean, self.var = z["mean"], z["var"]
            self.clip, self.eps = float(z["clip_obs"]), float(z["epsilon"])
            self.enabled = bool(z["enabled"])
        self.predictor = str(meta["predictor"])

    def normalize(self, obs: NDArray[Any]) -> NDArray[np.float32]:
        if not self.enabled:
            return np.asarray(obs, dtype=np.float32)
        z = (np.asarray(obs) - self.mean) / np.sqrt(self.var + self.eps)
        return np.clip(z, -self.clip, self.clip).astype(np.float32)

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
