"""BrakeWear-v0: when to replace the brake pads of a heavy mining vehicle."""

from __future__ import annotations

import os
from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from brake_env.env.config import EnvConfig
from brake_env.env.pads import PadLife, PadService
from brake_env.env.render import Dashboard
from brake_env.env.shared import check_render_mode, env_atlas, make_registered
from brake_env.model.atlas import Atlas
from brake_env.prognostics.protocol import MEASURED

KEEP, REPLACE = 0, 1
OBS_NAMES = (*MEASURED, "events_since_install")
# Sensor ranges of the observation (the event-log schema's physically possible ranges,
# narrowed where the schema is unbounded); readings are clipped into them.
_OBS_LOW = np.array([0.0, 0.0, -np.pi / 2, 0.0, -273.15, 0.0, 0.0], dtype=np.float32)
_OBS_HIGH = np.array([200.0, 1e6, np.pi / 2, 1e9, 3000.0, 1e4, 0.0], dtype=np.float32)


def check_action(action: Any) -> int:
    """``action`` as 0 (keep) or 1 (replace), or one clear error: an element of
    ``Discrete(2)`` is an int or a 0-d integer array (Gymnasium's ``Discrete.contains``),
    so ``1.0``, ``True``-like arrays and ``[0, 1]`` are refused, not guessed at."""
    if isinstance(action, np.ndarray | np.generic) and action.shape != ():
        raise ValueError(
            "BrakeWear-v0: step() takes one action, 0 (keep) or 1 (replace), not an array of"
            f" shape {action.shape}: got {action!r} (a vector env takes one per sub-environment)"
        )
    if not isinstance(action, int | np.integer | np.ndarray) or (
        isinstance(action, np.ndarray) and action.dtype.kind not in "iu"
    ):
        raise ValueError(
            f"BrakeWear-v0: action must be the int 0 (keep) or 1 (replace) of Discrete(2),"
            f" got {action!r} ({type(action).__name__})"
        )
    if int(action) not in (KEEP, REPLACE):
        raise ValueError(f"BrakeWear-v0: action must be 0 (keep) or 1 (replace), got {action!r}")
    return int(action)


def make_env(**kwargs: Any) -> gym.Env[Any, Any]:
    """The registered entry point of ``BrakeWear-v0`` (:func:`make_registered`)."""
    return make_registered(BrakeWearEnv, **kwargs)


def observation_space(config: EnvConfig) -> spaces.Box:
    high = _OBS_HIGH.copy()
    high[-1] = config.episode_events
    return spaces.Box(_OBS_LOW, high, dtype=np.float32)


class BrakeWearEnv(gym.Env[NDArray[np.float32], np.int64]):
    """
    ## Description

    A heavy mining vehicle (42-54 t) brakes again and again on a ramp; every braking event
    wears its pads, and a thinner pad heats more, so friction fades and wear accelerates
    (the coupled physics of the atlas, docs/model.md-4). When the pad falls below its critical
    volume the most severe event can no longer stop the vehicle: a brake failure. The agent
    decides, every ``decision_interval`` braking events, whether to keep the pads or replace
    them now. Replacing early wastes pad life; replacing late risks a failure, which costs
    far more than a planned replacement. Each new pad has its own wear coefficient K drawn
    from the configured regime (in-distribution, out-of-distribution or mixed), so how
    long a pad lasts is uncertain and must be inferred from the sensor readings.

    ## Action Space

    `Discrete(2)`:

    | Num | Action                          |
    |-----|---------------------------------|
    | 0   | keep the installed pads         |
    | 1   | replace the pads before braking |

    ## Observation Space

    `Box(7,)`, float32: the latest measured braking event (with sensor noise) and the pad's
    age. Readings are clipped to the sensor ranges below.

    | Num | Observation           | Min     | Max            | Unit   |
    |-----|-----------------------|---------|----------------|--------|
    | 0   | speed_kmh             | 0       | 200            | km/h   |
    | 1   | mass_kg               | 0       | 1e6            | kg     |
    | 2   | slope_rad             | -pi/2   | pi/2           | rad    |
    | 3   | energy_j              | 0       | 1e9            | J      |
    | 4   | temp_c (event mean)   | -273.15 | 3000           | deg C  |
    | 5   | stop_dist_m           | 0       | 1e4            | m      |
    | 6   | events_since_install  | 0       | episode_events | events |

    ## Transition Dynamics

    A replace action installs a new pad first. Then the step's braking events are served:
    each has operating conditions drawn uniformly over the envelope, its response is read
    from the atlas layer of the pad's current volume, and the pad loses K times its wear.
    An event that needs a pad with no life left is a failure: a corrective replacement is
    forced and the event is braked on the new pad; the episode goes on.

    ## Reward

    Minus the cost of the step: ``revenue`` (per event) minus ``planned_replacement``,
    and for each failure ``corrective_replacement + downtime + damage``. The terms are
    given by name in ``info["costs"]``; their weights are ``costs`` (:class:`CostWeights`).

    ## Starting State

    A new pad, after its first braking event (the observation needs a reading).

    ## Episode End

    Never terminated (a failure is repaired and operation continues). Truncated after
    ``episode_events`` braking events (the default 500,000 is about four pad lives).

    ## Info

    ``events`` (every event of the step as arrays named like the event-log columns:
    ``event`` is the index since installation; ground truth ``volume_frac``, ``wear_coeff``
    and ``rul_events`` included), ``costs`` (cost terms by name), ``replaced``,
    ``failures``, ``pads_retired``, ``retired`` (a :class:`~brake_env.env.pads.RetiredPad`
    for each pad taken off in the step, in order: ``life_left``, the events of life it had
    left, 0 for a failure; its ``life`` and its ``regime``) and ``truth`` (true volume, K,
    RUL, life and regime of the installed pad; for analysis only, never for a policy).
    With ``truth`` (the default) the RULs and lives are simulated when first read (about one
    pad life, ~0.1 s at the default K, per pad read); copying or pickling an info, as SB3's
    and Gymnasium's vector envs do every step, reads nothing (:mod:`brake_env.env.lazy_truth`).

    ## Arguments

    ```python
    import gymnasium as gym
    import brake_env
    env = gym.make("BrakeWear-v0", decision_interval=500, regime="mixed", ood_share=0.5)
    ```

    Every field of :class:`EnvConfig` is a keyword argument (``costs`` and ``noise`` also
    as dicts), plus ``config`` (a whole :class:`EnvConfig`), ``atlas`` (an :class:`Atlas`
    or the path of a saved one; default the preset's cached atlas) and ``render_mode``:
    None, ``"ansi"`` (a line of text) or ``"rgb_array"`` (a 240x320 dashboard: pad volume,
    true RUL, a wrapper's RUL estimate and interval, recent temperatures, counts; see
    :mod:`brake_env.env.render`). Unknown or out-of-range arguments raise ``ValueError``.

    ## Version History

    * v0: initial version.
    """

    # One frame per step (decision); 30 fps plays a 1,000-step episode in about 33 s.
    metadata = {"render_modes": ["ansi", "rgb_array"], "render_fps": 30}  # noqa: RUF012

    def __init__(
        self,
        config: EnvConfig | None = None,
        atlas: Atlas | str | os.PathLike[str] | None = None,
        render_mode: str | None = None,
        **kwargs: Any,
    ) -> None:
        self.config = EnvConfig.from_kwargs(config, **kwargs)
        check_render_mode("BrakeWear-v0", render_mode, self.metadata["render_modes"])
        self.render_mode = render_mode
        self.atlas = atlas = env_atlas(atlas, self.config.preset)
        self.action_space = spaces.Discrete(2)
        self._box = observation_space(self.config)
        self.observation_space = self._box  # type: ignore[assignment]  # Box of float32
        self._service = PadService(atlas, self.config)
        self._last_info: dict[str, Any] = {}
        self._dashboard = Dashboard(atlas.failure_volume) if render_mode == "rgb_array" else None

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[NDArray[np.float32], dict[str, Any]]:
        super().reset(seed=seed)
        self._last_info = self._service.start(self.np_random)
        if self._dashboard is not None:
            self._dashboard.start(self._last_info)
        return self._observation(), self._last_info

    def step(
        self, action: np.int64 | int
    ) -> tuple[NDArray[np.float32], SupportsFloat, bool, bool, dict[str, Any]]:
        if self._service.pad is None:
            raise RuntimeError("BrakeWear-v0: call reset() before step()")
        info = self._service.step(check_action(action) == REPLACE)
        self._last_info = info
        if self._dashboard is not None:
            self._dashboard.record(info)
        return self._observation(), self.reward(info), False, self._service.truncated, info

    @staticmethod
    def reward(info: dict[str, Any]) -> float:
        """Revenue minus the cost terms of a step's info."""
        c = info["costs"]
        return float(
            c["revenue"]
            - (c["planned_replacement"] + c["corrective_replacement"] + c["downtime"] + c["damage"])
        )

    @property
    def installed_pad(self) -> PadLife:
        """The installed pad's whole simulated life (ground truth; for wrappers that
        precompute a causal predictor over it, never for a policy)."""
        if self._service.pad is None:
            raise RuntimeError("BrakeWear-v0: call reset() first")
        return self._service.pad

    @property
    def pad_age(self) -> int:
        """Events the installed pad has braked."""
        return self._service.pos

    def render(self) -> str | NDArray[np.uint8] | None:
        if self._dashboard is not None:
            return self._dashboard.frame()
        if self.render_mode != "ansi" or not self._last_info:
            return None
        t, svc = self._last_info["truth"], self._service
        rul = "?" if t["rul_events"] is None else t["rul_events"]  # None without ``truth``
        return (
            f"event {svc.events_done:>8d}  pad age {svc.pos:>7d}  volume {t['volume_frac']:.3f}"
            f"  RUL {rul:>7}  K {t['wear_coeff']:.3g} ({t['regime']})"
            f"  failures {self._last_info['failures']}  replaced {self._last_info['replaced']}"
        )

    def _observation(self) -> NDArray[np.float32]:
        obs = self._service.observation()
        return np.clip(obs, self._box.low, self._box.high, out=obs)
