"""BrakeWear core, in pipeline order: ``model`` (physics of one braking event, the atlas,
the wear clock, the K distribution, the coupled run-to-failure simulator), ``data`` (event
logs and datasets), ``prognostics`` (predictor protocol and registry, metrics, evaluation),
``env`` (BrakeWear-v0, its vector env and the RUL observation wrapper) and ``cli``.

Importing the package registers ``BrakeWear-v0``, ``BrakeWearFleet-v2`` (the benchmark's
fleet: a fleet file, 365 shifts, the episode's cost in the last step's ``info``; docs/
benchmark.md), and the earlier ``BrakeWearFleet-v1`` (the same on ``id``-regime fleets; it
refuses the others, whose net changed in v2), ``BrakeWearFleet-v0`` (730 shifts, no episode
cost) and ``BrakeWearFleetSmall-v0`` (the 2-vehicle fleet, ``SMALL_FLEET``), which keep
working. No torch or Stable-Baselines3 here, and no import of the downstream packages (twin,
baselines, agents, sim2real): they plug in through entry points.
"""

from gymnasium.envs.registration import register, registry

from brake_env.env.fleet.config import SMALL_FLEET, FleetConfig

__version__ = "0.1.0"

if "BrakeWear-v0" not in registry:
    register(
        id="BrakeWear-v0",
        entry_point="brake_env.env.brake_wear:make_env",
        vector_entry_point="brake_env.env.vector:BrakeWearVectorEnv",
        disable_env_checker=False,
    )

# The fleet envs truncate themselves after ``episode_shifts``; ``max_episode_steps`` (the
# default config's episode_shifts) only tells Gymnasium, SB3 and RLlib the episode length,
# through the TimeLimit wrapper ``gym.make`` adds. A run with more shifts than that passes
# ``max_episode_steps`` too (or -1), else TimeLimit cuts it short: see the fleet env's
# "Episode End". Fewer shifts need nothing (the env truncates first).
FLEET_SHIFTS = FleetConfig.episode_shifts
BENCHMARK_SHIFTS = 365

if "BrakeWearFleet-v0" not in registry:
    register(
        id="BrakeWearFleet-v0",
        entry_point="brake_env.env.fleet.registered:make_fleet_env",
        max_episode_steps=FLEET_SHIFTS,
        disable_env_checker=False,
    )

# v2: the fleet of a fleet file (default: the shipped ``default``; ``fleet="small"`` or a
# path), whose episode_shifts (365 in the shipped files) is the benchmark's episode. v1 is v2
# on fleets of the ``id`` regime and refuses the others (their net's credit changed in v2).
for version in ("v1", "v2"):
    if f"BrakeWearFleet-{version}" not in registry:
        register(
            id=f"BrakeWearFleet-{version}",
            entry_point=f"brake_env.env.fleet.registered:make_fleet_env_{version}",
            max_episode_steps=BENCHMARK_SHIFTS,
            disable_env_checker=False,
        )

if "BrakeWearFleetSmall-v0" not in registry:
    register(
        id="BrakeWearFleetSmall-v0",
        entry_point="brake_env.env.fleet.registered:make_fleet_env",
        kwargs=dict(SMALL_FLEET),
        max_episode_steps=FLEET_SHIFTS,
        disable_env_checker=False,
    )
