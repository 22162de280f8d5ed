"""BrakeWear core: brake physics, the atlas, the coupled wear simulator, event logs, and the
BrakeWear-v0 Gymnasium environment with its predictor protocol and RUL observation wrapper.

Importing the package registers ``BrakeWear-v0``. No torch or Stable-Baselines3 here.
"""

from gymnasium.envs.registration import register, registry

__version__ = "0.1.0"

if "BrakeWear-v0" not in registry:
    register(
        id="BrakeWear-v0",
        entry_point="brake_env.env.brake_wear:BrakeWearEnv",
        vector_entry_point="brake_env.env.vector:BrakeWearVectorEnv",
        disable_env_checker=False,
    )
