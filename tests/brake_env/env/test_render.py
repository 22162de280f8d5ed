"""BrakeWear-v0's rgb_array frame: SB3's make_vec_env, the checker, what the frame shows."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env
from stable_baselines3.common.env_util import make_vec_env

import brake_env  # noqa: F401  (registers BrakeWear-v0)
from brake_env.env import render
from brake_env.env.brake_wear import BrakeWearEnv
from brake_env.env.render import GLYPHS, Dashboard, text_mask
from brake_env.env.wrappers import RULObservation
from brake_env.prognostics.protocol import MEASURED, EventBatch, Oracle

FAST = {"k_mean": 1e-5, "k_std": 1e-6, "decision_interval": 500, "episode_events": 100_000}
SHAPE = (render.HEIGHT, render.WIDTH, 3)
BAR_COLORS = np.array([render.GOOD, render.WARN, render.BAD], dtype=np.uint8)


def shows(frame: np.ndarray, x: int, y: int, text: str, color: render.Color) -> bool:
    """``text`` is drawn at (x, y) in ``color``: every pixel of its glyphs has that colour."""
    mask = text_mask(text)
    region = frame[y : y + mask.shape[0], x : x + mask.shape[1]]
    return bool((region[mask] == color).all())


def bar_rows(frame: np.ndarray, failure_volume: float) -> int:
    """Height of the volume bar's fill [px]: its painted rows in the middle column, counted
    from the top painted row down (the end-of-life mark is painted on every frame)."""
    x0, y0, x1, y1 = render._BAR
    painted = (frame[y0:y1, (x0 + x1) // 2, None, :] == BAR_COLORS).all(axis=2).any(axis=1)
    mark = y1 - y0 - round(failure_volume * (y1 - y0))
    painted[mark - 1 : mark + 1] = False
    return int(len(painted) - np.argmax(painted)) if painted.any() else 0


def test_sb3_make_vec_env_with_two_envs_renders(atlas):
    # make_vec_env asks gym.make for render_mode="rgb_array" (issue: it used to raise).
    venv = make_vec_env("BrakeWear-v0", n_envs=2, seed=0, env_kwargs={"atlas": atlas, **FAST})
    venv.reset()
    for _ in range(3):
        venv.step(np.array([0, 1]))
    frames = venv.get_images()
    assert len(frames) == 2
    assert all(f.shape == SHAPE and f.dtype == np.uint8 for f in frames)
    assert not np.array_equal(frames[0], frames[1])  # env 1 replaced, env 0 did not
    venv.close()


def test_gymnasium_checker_passes_with_rgb_array(atlas):
    env = gym.make("BrakeWear-v0", atlas=atlas, render_mode="rgb_array", **FAST)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        gym_check_env(env.unwrapped)  # render check included, every declared mode
    about_render = [str(w.message) for w in caught if "render" in str(w.message).lower()]
    assert not about_render
    assert env.metadata["render_fps"] > 0
    assert "rgb_array" in env.metadata["render_modes"]


def test_frame_shows_the_true_volume_and_changes_as_the_pad_wears(atlas):
    env = BrakeWearEnv(atlas=atlas, render_mode="rgb_array", **FAST)
    _, info = env.reset(seed=3)
    first = env.render()
    assert first.shape == SHAPE and first.dtype == np.uint8
    for _ in range(20):
        _, _, _, _, info = env.step(0)
    worn = env.render()
    assert not np.array_equal(first, worn)
    volume = info["truth"]["volume_frac"]
    assert volume > atlas.failure_volume  # still on its first pad
    _, y0, _, y1 = render._BAR
    fv = atlas.failure_volume
    assert bar_rows(worn, fv) == round(volume * (y1 - y0)) < bar_rows(first, fv)
    assert shows(worn, 70, 62, f"VOLUME {volume:.3f}", render.TEXT)
    assert shows(worn, 70, 92, f"TRUE RUL {info['truth']['rul_events']}", render.GOOD)
    assert shows(worn, 8, 6, f"STEP 20   EVENT {1 + 20 * 500}", render.TEXT)
    age = env.pad_age
    assert shows(worn, 70, 48, f"AGE {age} EVENTS", render.TEXT)


def test_frame_shows_a_wrappers_estimate(atlas):
    bare = BrakeWearEnv(atlas=atlas, render_mode="rgb_array", **FAST)
    wrapped = RULObservation(BrakeWearEnv(atlas=atlas, render_mode="rgb_array", **FAST), Oracle())
    for env in (bare, wrapped):
        env.reset(seed=5)
        for _ in range(4):
            _, _, _, _, info = env.step(0)
    assert shows(bare.render(), 70, 106, "NO RUL ESTIMATE", render.DIM)
    frame = wrapped.render()
    assert shows(frame, 70, 106, f"EST RUL {info['rul_estimate']['rul_mean']:.0f}", render.ESTIMATE)
    # The interval appears once the info holds one.
    info["rul_estimate"].update(rul_lower=1000.0, rul_upper=2500.0)
    assert shows(wrapped.render(), 70, 120, "INTERVAL 1000-2500", render.ESTIMATE)


def test_frame_without_true_rul_shows_the_true_volume(atlas):
    env = BrakeWearEnv(atlas=atlas, render_mode="rgb_array", truth=False, **FAST)
    env.reset(seed=2)
    for _ in range(3):
        _, _, _, _, info = env.step(0)
    assert info["truth"]["rul_events"] is None
    frame = env.render()
    assert shows(frame, 70, 62, f"VOLUME {info['truth']['volume_frac']:.3f}", render.TEXT)
    assert shows(frame, 70, 106, "NO RUL ESTIMATE", render.DIM)
    assert not shows(frame, 70, 92, "TRUE RUL", render.GOOD)
    ansi = BrakeWearEnv(atlas=atlas, render_mode="ansi", truth=False, **FAST)
    ansi.reset(seed=2)
    assert "RUL       ?" in ansi.render()


def test_same_seed_same_frames(atlas):
    frames = []
    for _ in range(2):
        env = BrakeWearEnv(atlas=atlas, render_mode="rgb_array", **FAST)
        env.reset(seed=11)
        for a in (0, 1, 0, 0):
            env.step(a)
        frames.append(env.render())
    assert np.array_equal(*frames)


def _info(temps: np.ndarray, **extra: object) -> dict[str, object]:
    n = len(temps)
    cols = {k: np.zeros(n) for k in MEASURED}
    cols["temp_c"] = temps
    events = EventBatch(event=np.arange(100, 100 + n), **cols)
    return {"events": events, "replaced": False, "failures": 0, **extra}


def test_dashboard_without_truth_uses_the_estimate_or_says_so_and_survives_dropouts():
    board = Dashboard(failure_volume=0.2)
    board.start(_info(np.array([400.0, 410.0])))
    board.record(_info(np.full(3, np.nan)))  # every reading dropped out: a gap, no warning
    frame = board.frame()
    assert shows(frame, 70, 62, "VOLUME NOT KNOWN", render.DIM)
    assert shows(frame, 70, 48, "AGE 103 EVENTS", render.TEXT)
    assert bar_rows(frame, 0.2) == 0
    board.record(_info(np.array([420.0]), rul_estimate={"rul_mean": 50.0, "volume_frac": 0.5}))
    frame = board.frame()
    assert shows(frame, 70, 62, "EST VOLUME 0.500", render.TEXT)
    assert bar_rows(frame, 0.2) == 60
    assert shows(frame, 14, 184, "400 TO 420", render.DIM)


def test_font_glyphs_are_distinct_and_unknown_characters_are_marked():
    flat = GLYPHS.reshape(len(GLYPHS), -1)
    assert len(np.unique(flat, axis=0)) == len(GLYPHS)
    assert np.array_equal(text_mask("rul 0.5"), text_mask("RUL 0.5"))
    assert np.array_equal(text_mask("é"), text_mask("?"))
    assert text_mask("AB", scale=3).shape == (15, 2 * 12 - 3)


def test_unknown_render_mode_names_the_valid_ones(atlas):
    with pytest.raises(ValueError, match="'rgb_array'"):
        BrakeWearEnv(atlas=atlas, render_mode="human")
