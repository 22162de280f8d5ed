"""BrakeWear core, in pipeline order: ``model`` (physics of one braking event, the atlas,
the wear clock, the K distribution, the coupled run-to-failure simulator), ``data`` (event
logs and datasets), ``prognostics`` (predictor protocol and registry, metrics, evaluation),
``env`` (BrakeWear-v0, its vector env and the RUL observation wrapper) and ``cli``.

Importing the package registers ``BrakeWear-v0`` and ``BrakeWearFleet-v0``. No torch or
Stable-Baselines3 here, and no import of the downstream packages (twin, baselines, agents,
sim2real): they plug in through entry points.
"""

from gymnasium.envs.registration import register, registry

__version__ = "0.1.0"

if "BrakeWear-v0" not in registry:
    register(
        id="BrakeWear-v0",
        entry_point="brake_env.env.brake_wear:make_env",
        vector_entry_point="brake_env.env.vector:BrakeWearVectorEnv",
        disable_env_checker=False,
    )

if "BrakeWearFleet-v0" not in registry:
    register(
        id="BrakeWearFleet-v0",
        entry_point="brake_env.env.fleet.env:BrakeWearFleetEnv",
        disable_env_checker=False,
    )
