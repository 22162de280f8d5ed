"""The ``rgb_array`` frame of BrakeWear-v0: a dashboard drawn with numpy alone.

What a person needs to follow an episode (a video of RL Zoo's ``record_video``, SB3's
``VecVideoRecorder``): the pad's volume against its end of life, the pad's age, the true
RUL, a wrapper's RUL estimate and its interval on one axis, the temperatures of the recent
steps, and the episode's step, event, replacement and failure counts.

Everything comes from the infos the env returns. The RUL estimate is read when the frame
is drawn, from the latest info: :class:`~brake_env.env.wrappers.RULObservation` adds
``info["rul_estimate"]`` to that same dict after the base env returned it, so the base env
shows a wrapper's estimate without knowing the wrapper. Text uses a 3x5 bitmap font; no
plotting library, so a frame costs well under a millisecond of drawing.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from brake_env.prognostics.protocol import EventBatch

HEIGHT, WIDTH = 240, 320
HISTORY = 96  # steps of the temperature strip (3 px each)

Color = tuple[int, int, int]
BACKGROUND: Color = (22, 24, 32)
TEXT: Color = (225, 225, 225)
DIM: Color = (120, 124, 140)
GOOD: Color = (70, 190, 90)
WARN: Color = (235, 170, 40)
BAD: Color = (225, 60, 50)
ESTIMATE: Color = (80, 150, 240)
TEMP: Color = (240, 130, 50)

# 3x5 glyphs, rows top to bottom; every character a frame needs (lower case drawn as upper).
_FONT = {
    "0": "111 101 101 101 111", "1": "010 110 010 010 111", "2": "111 001 111 100 111",
    "3": "111 001 111 001 111", "4": "101 101 111 001 001", "5": "111 100 111 001 111",
    "6": "111 100 111 101 111", "7": "111 001 001 010 010", "8": "111 101 111 101 111",
    "9": "111 101 111 001 111", "A": "010 101 111 101 101", "B": "110 101 110 101 110",
    "C": "011 100 100 100 011", "D": "110 101 101 101 110", "E": "111 100 110 100 111",
    "F": "111 100 110 100 100", "G": "011 100 101 101 011", "H": "101 101 111 101 101",
    "I": "111 010 010 010 111", "J": "001 001 001 101 010", "K": "101 101 110 101 101",
    "L": "100 100 100 100 111", "M": "101 111 111 101 101", "N": "110 101 101 101 101",
    "O": "010 101 101 101 010", "P": "110 101 110 100 100", "Q": "010 101 101 110 011",
    "R": "110 101 110 101 101", "S": "011 100 010 001 110", "T": "111 010 010 010 010",
    "U": "101 101 101 101 111", "V": "101 101 101 101 010", "W": "101 101 111 111 101",
    "X": "101 101 010 101 101", "Y": "101 101 010 010 010", "Z": "111 001 010 100 111",
    " ": "000 000 000 000 000", ".": "000 000 000 000 010", "-": "000 000 111 000 000",
    ":": "000 010 000 010 000", "/": "001 001 010 100 100", "[": "110 100 100 100 110",
    "]": "011 001 001 001 011", "%": "101 001 010 100 101", "+": "000 010 111 010 000",
    "=": "000 111 000 111 000", "(": "010 100 100 100 010", ")": "010 001 001 001 010",
    "?": "111 001 010 000 010",
}  # fmt: skip
GLYPHS = np.array(
    [[[c == "1" for c in row] for row in rows.split()] for rows in _FONT.values()], dtype=bool
)
# ASCII code -> glyph index; anything the font lacks is drawn as "?".
_LOOKUP = np.full(128, list(_FONT).index("?"), dtype=np.intp)
_LOOKUP[[ord(c) for c in _FONT]] = np.arange(len(_FONT))
_LOOKUP[[ord(c) for c in "abcdefghijklmnopqrstuvwxyz"]] = _LOOKUP[
    [ord(c) for c in "ABCDEFGHIJKLMNOPQRSTUVWXYZ"]
]

Frame = NDArray[np.uint8]


_SCALED: dict[int, NDArray[np.bool_]] = {}


def text_mask(text: str, scale: int = 2) -> NDArray[np.bool_]:
    """The pixels of ``text`` in the bitmap font: 5 * scale rows, 4 * scale - scale per
    character (a one-column gap between characters)."""
    if scale not in _SCALED:  # each glyph scaled once, with its gap column after it
        spaced = np.pad(GLYPHS, ((0, 0), (0, 0), (0, 1)))
        _SCALED[scale] = spaced.repeat(scale, axis=1).repeat(scale, axis=2)
    codes = np.frombuffer(text.encode("ascii", "replace"), dtype=np.uint8)
    glyphs = _SCALED[scale][_LOOKUP[codes]]  # (n, 5 * scale, 4 * scale)
    return glyphs.transpose(1, 0, 2).reshape(5 * scale, -1)[:, :-scale]


def draw_text(img: Frame, x: int, y: int, text: str, color: Color, scale: int = 2) -> None:
    """Draw ``text`` with its top-left corner at pixel (x, y), clipped to the frame."""
    if not text:
        return
    mask = text_mask(text, scale)
    h = min(mask.shape[0], img.shape[0] - y)
    w = min(mask.shape[1], img.shape[1] - x)
    if h > 0 and w > 0:
        img[y : y + h, x : x + w][mask[:h, :w]] = color


def fill(img: Frame, x0: int, y0: int, x1: int, y1: int, color: Color) -> None:
    """Fill the rectangle of columns [x0, x1) and rows [y0, y1)."""
    img[max(y0, 0) : max(y1, 0), max(x0, 0) : max(x1, 0)] = color


def outline(img: Frame, x0: int, y0: int, x1: int, y1: int, color: Color) -> None:
    """A one-pixel frame around columns [x0, x1) and rows [y0, y1)."""
    img[y0, x0:x1] = img[y1 - 1, x0:x1] = color
    img[y0:y1, x0] = img[y0:y1, x1 - 1] = color


def events_text(x: float) -> str:
    """A count of events as an integer (exponent form past 7 digits)."""
    if not math.isfinite(x):
        return "?"
    return f"{x:.0f}" if abs(x) < 1e7 else f"{x:.1e}"


# Layout [px]: the volume bar on the left, text and the RUL axis beside it, the
# temperature strip at the bottom.
_BAR = (14, 48, 46, 168)  # x0, y0, x1, y1
_RUL_AXIS = (70, 148, 310, 162)
_STRIP = (14, 196, 14 + 3 * HISTORY, 234)


class Dashboard:
    """The state a frame shows, gathered from the env's infos, and the frame itself.

    Args:
        failure_volume: The pad's end-of-life volume fraction (the atlas's), marked on
            the volume bar [-].
    """

    def __init__(self, failure_volume: float) -> None:
        self.failure_volume = float(failure_volume)
        self._background = self._static()
        self.start(None)

    def start(self, info: Mapping[str, Any] | None) -> None:
        """A new episode; ``info`` is the reset's info (None: no episode yet)."""
        self.steps = self.events = self.replaced = self.failures = 0
        # Per-step min, mean and max of the measured event temperatures [deg C], newest
        # last; NaN where every reading of a step dropped out.
        self.temps = np.full((HISTORY, 3), np.nan)
        self._info: Mapping[str, Any] = {}
        if info is not None:
            self._take(info)

    def record(self, info: Mapping[str, Any]) -> None:
        """The info of a step."""
        self.steps += 1
        self.replaced += int(info["replaced"])
        self.failures += int(info["failures"])
        self._take(info)

    def _take(self, info: Mapping[str, Any]) -> None:
        events: EventBatch = info["events"]
        self.events += len(events)
        self._info = info
        t = events.temp_c[np.isfinite(events.temp_c)]
        self.temps[:-1] = self.temps[1:]
        self.temps[-1] = (t.min(), t.mean(), t.max()) if t.size else np.nan

    @property
    def pad_age(self) -> int:
        """Events the installed pad has braked (after the latest step)."""
        events: EventBatch | None = self._info.get("events")
        return int(events.event[-1]) + 1 if events is not None and len(events) else 0

    def frame(self) -> Frame:
        """The dashboard as an RGB image, shape (240, 320, 3), uint8."""
        img = self._background.copy()
        draw_text(img, 8, 6, f"STEP {self.steps}   EVENT {events_text(self.events)}", TEXT)
        draw_text(img, 8, 20, f"REPLACED {self.replaced}   FAILURES {self.failures}", TEXT)
        truth = self._info.get("truth")
        estimate = self._info.get("rul_estimate") or {}
        self._draw_volume(img, truth, estimate)
        self._draw_rul(img, truth, estimate)
        self._draw_temps(img)
        return img

    def _static(self) -> Frame:
        """What every frame shares: background, outlines, labels, the end-of-life mark."""
        img = np.empty((HEIGHT, WIDTH, 3), dtype=np.uint8)
        img[:] = BACKGROUND
        x0, y0, x1, y1 = _BAR
        draw_text(img, x0 + 4, y0 - 12, "PAD", DIM)
        outline(img, x0 - 1, y0 - 1, x1 + 1, y1 + 1, DIM)
        y = y1 - round(self.failure_volume * (y1 - y0))
        fill(img, x0 - 4, y - 1, x1 + 4, y + 1, BAD)
        outline(img, *_RUL_AXIS, DIM)
        sx0, sy0, sx1, sy1 = _STRIP
        draw_text(img, sx0, sy0 - 24, f"TEMPERATURE C  LAST {HISTORY} STEPS", DIM)
        outline(img, sx0 - 1, sy0 - 1, sx1 + 1, sy1 + 1, DIM)
        return img

    def _draw_volume(
        self, img: Frame, truth: Mapping[str, Any] | None, estimate: Mapping[str, float]
    ) -> None:
        """The volume bar (true volume, else the estimate's, else empty) and its text."""
        x0, y0, x1, y1 = _BAR
        draw_text(img, 70, 48, f"AGE {events_text(self.pad_age)} EVENTS", TEXT)
        if truth is not None and truth.get("volume_frac") is not None:
            volume, label = float(truth["volume_frac"]), "VOLUME"
            draw_text(img, 70, 76, f"K {truth['wear_coeff']:.2e} {truth['regime']}", DIM)
        elif "volume_frac" in estimate:
            volume, label = estimate["volume_frac"], "EST VOLUME"
        else:
            draw_text(img, 70, 62, "VOLUME NOT KNOWN", DIM)
            return
        draw_text(img, 70, 62, f"{label} {volume:.3f}", TEXT)
        # Green while well above the end of life, amber in its last third, red at it.
        margin = (volume - self.failure_volume) / max(1.0 - self.failure_volume, 1e-9)
        color = GOOD if margin > 1 / 3 else WARN if margin > 0 else BAD
        top = y1 - round(min(max(volume, 0.0), 1.0) * (y1 - y0))
        fill(img, x0, top, x1, y1, color)
        # Keep the end-of-life mark visible over the fill.
        y = y1 - round(self.failure_volume * (y1 - y0))
        fill(img, x0, y - 1, x1, y + 1, BAD)

    def _draw_rul(
        self, img: Frame, truth: Mapping[str, Any] | None, estimate: Mapping[str, float]
    ) -> None:
        """True RUL and the estimate with its interval, as text and on one axis."""
        # The env gives the true volume always, the true RUL only with ``truth``.
        rul = None if truth is None else truth.get("rul_events")
        true_rul = None if rul is None else float(rul)
        mean = estimate.get("rul_mean")
        lo, hi = estimate.get("rul_lower"), estimate.get("rul_upper")
        if true_rul is not None:
            draw_text(img, 70, 92, f"TRUE RUL {events_text(true_rul)}", GOOD)
        if mean is not None:
            draw_text(img, 70, 106, f"EST RUL {events_text(mean)}", ESTIMATE)
        else:
            draw_text(img, 70, 106, "NO RUL ESTIMATE", DIM)
        if lo is not None and hi is not None:
            draw_text(img, 70, 120, f"INTERVAL {events_text(lo)}-{events_text(hi)}", ESTIMATE)
        values = [v for v in (true_rul, mean, hi, lo) if v is not None and math.isfinite(v)]
        if not values:
            return
        x0, y0, x1, y1 = _RUL_AXIS
        scale = max(*values, 1.0) * 1.1
        draw_text(img, x0, y0 - 12, "RUL 0", DIM)
        right = f"{events_text(scale)}"
        draw_text(img, x1 - 8 * len(right), y0 - 12, right, DIM)

        def px(v: float) -> int:
            return x0 + 1 + round(max(v, 0.0) / scale * (x1 - x0 - 3))

        if lo is not None and hi is not None:
            fill(img, px(lo), y0 + 3, px(hi) + 1, y1 - 3, ESTIMATE)
        if mean is not None:
            fill(img, px(mean) - 1, y0 + 1, px(mean) + 2, y1 - 1, TEXT)
        if true_rul is not None:
            fill(img, px(true_rul) - 1, y0 - 2, px(true_rul) + 2, y1 + 2, GOOD)

    def _draw_temps(self, img: Frame) -> None:
        """Each recent step as a column from its coolest to its hottest event, mean marked."""
        x0, y0, x1, y1 = _STRIP
        known = np.isfinite(self.temps[:, 1])
        if not known.any():
            return
        lo, hi = float(np.min(self.temps[known, 0])), float(np.max(self.temps[known, 2]))
        draw_text(img, x0, y0 - 12, f"{lo:.0f} TO {hi:.0f}", DIM)
        draw_text(img, x1 - 64, y0 - 12, f"NOW {self.temps[-1, 1]:.0f}", TEMP)
        h = y1 - y0
        span = max(hi - lo, 1e-9)
        # Row of each (step, min/mean/max), 0 at the top; NaN steps never match a row.
        rows = np.where(known[:, None], (hi - self.temps) / span * (h - 1), np.nan)
        yy = np.arange(h)[:, None]
        band = (yy >= np.round(rows[:, 2])) & (yy <= np.round(rows[:, 0]))
        dot = np.abs(yy - np.round(rows[:, 1])) < 1
        width = (x1 - x0) // HISTORY
        region = img[y0:y1, x0:x1]
        region[np.repeat(band, width, axis=1)] = TEMP
        region[np.repeat(dot, width, axis=1)] = TEXT
