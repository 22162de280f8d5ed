"""MaskablePPO from scratch on a suite's env, saved as one file, loaded for ``fleet-score``.

The agent is :class:`~agents.fleet.learning.agent.FleetAgent` (its observation statistics
frozen at the end of training; its mask rebuilt from the observation, so it acts wherever the
fleet rules act), trained by :func:`~agents.fleet.learning.agent.train_fleet_agent` with no
teacher. The saved file is a zip of SB3's own zip of the model (``model.zip``) and
``agent.json`` (the frozen statistics, the spares rule and the repair it acts with, and how it
was trained). :func:`factory` loads the shipped one (:data:`SHIPPED`).
"""

from __future__ import annotations

import io
import json
import time
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from agents.fleet.benchmark.training.config import TRAIN_SEED0, TrainingConfig, suite_env
from agents.fleet.learning.agent import FleetAgent, train_fleet_agent
from agents.fleet.policies.view import FleetLayout
from brake_env.model.atlas import Atlas

SHIPPED = Path(__file__).parents[1] / "entries" / "default" / "maskable-ppo.zip"


def train(
    config: TrainingConfig, atlas: Atlas, log: Any = None
) -> tuple[FleetAgent, dict[str, Any]]:
    """MaskablePPO trained on ``config``'s suite (its dev-side env) for its timesteps: (the
    agent, what training cost: steps and CPU seconds)."""
    from stable_baselines3.common.callbacks import BaseCallback

    if config.algorithm != "maskable_ppo":
        raise ValueError(f"maskable.train: config {config.path} is for {config.algorithm!r}")
    t0 = time.process_time()
    make, _ = suite_env(config.suite, atlas)
    layout = FleetLayout.of(make().unwrapped.config)
    first = TRAIN_SEED0 + 1000 * config.settings.seed

    class Start(BaseCallback):
        def _on_training_start(self) -> None:
            # SB3 seeded copy i with seed + i, the dev split's seeds: reset from our own
            venv: Any = self.model.get_env()
            venv.seed(first)
            self.model._last_obs = venv.reset()

        def _on_rollout_end(self) -> None:
            if log is not None:
                log(f"{self.num_timesteps} steps, {time.process_time() - t0:.0f} s CPU")

        def _on_step(self) -> bool:
            return True

    agent = train_fleet_agent(make, layout, config.settings, callback=Start())
    return agent, {"training_steps": int(agent.model.num_timesteps),
                   "cpu_seconds": time.process_time() - t0}  # fmt: skip


def save(agent: FleetAgent, path: str | Path, meta: dict[str, Any], config: TrainingConfig) -> Path:
    """``agent`` as one zip file (module docstring); ``meta`` and ``config``'s settings go
    into its ``agent.json``."""
    buf = io.BytesIO()
    agent.model.save(buf, exclude=["env", "_last_obs", "_last_original_obs"])
    doc = {"obs_mean": agent.mean.tolist(), "obs_std": agent.std.tolist(),
           "clip": agent.clip, "reorder": agent.reorder, "cover": agent.cover,
           "n_vehicles": agent.layout.n_vehicles, "meta": meta,
           "settings": repr(config.settings)}  # fmt: skip
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("model.zip", buf.getvalue())
        z.writestr("agent.json", json.dumps(doc))
    return out


def load(path: str | Path, env: Any) -> FleetAgent:
    """The agent saved at ``path``, acting on ``env`` (the suite's env: its layout).

    Raises:
        ValueError: Not such a file, or saved for another number of vehicles.
    """
    from sb3_contrib import MaskablePPO

    try:
        with zipfile.ZipFile(path) as z:
            doc = json.loads(z.read("agent.json"))
            model = MaskablePPO.load(io.BytesIO(z.read("model.zip")), device="cpu")
    except (OSError, KeyError, zipfile.BadZipFile) as e:
        raise ValueError(f"{path}: not a saved MaskablePPO agent ({e})") from None
    layout = FleetLayout.of(env.unwrapped.config)
    if doc["n_vehicles"] != layout.n_vehicles:
        raise ValueError(f"{path}: trained for {doc['n_vehicles']} vehicles, the env has"
                         f" {layout.n_vehicles}")  # fmt: skip
    mean = np.array(doc["obs_mean"], np.float32)
    reorder = None if doc["reorder"] is None else tuple(doc["reorder"])
    agent = FleetAgent(model, layout, mean, np.zeros_like(mean), doc["clip"], reorder=reorder,
                       cover=doc["cover"])  # fmt: skip
    agent.std = np.array(doc["obs_std"], np.float32)  # as frozen (not through a variance)
    return agent


def factory(env: Any) -> FleetAgent:
    """``fleet-score``'s factory: the shipped agent (trained on the default suite)."""
    return load(SHIPPED, env)
