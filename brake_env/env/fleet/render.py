"""The frames of BrakeWearFleet-v0: the fleet at a glance, drawn with numpy alone.

One row per vehicle: its pad's true volume as a bar down to end of life (green, amber
under 40% of its usable life, red under 15%), its duty this shift (H hot, M mild, P park,
S in the shop), and the hot-route RUL in shifts: a fleet wrapper's estimate when there is one
(``info["rul_estimate"]["hot_rul_mean"]``), else the expected shifts left on the hot route
from the true volume and K (the closed-form wear clock of the route). A header gives the shift, the
shifts to the next window, the free bays, the stock and the pads on order. The bitmap font
and drawing helpers are BrakeWear-v0's (:mod:`brake_env.env.render`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from brake_env.env.fleet.routes import HOT, route_wear_model
from brake_env.env.render import (
    BACKGROUND,
    BAD,
    DIM,
    GOOD,
    TEXT,
    WARN,
    Color,
    draw_text,
    events_text,
    fill,
    outline,
)  # fmt: skip

if TYPE_CHECKING:
    from brake_env.env.fleet.env import BrakeWearFleetEnv

ROW, WIDTH, TOP = 16, 320, 40
_DUTY = {-1: "P", 0: "H", 1: "M"}
_DUTY_COLOR: dict[str, Color] = {"H": (235, 120, 60), "M": (90, 160, 230), "P": DIM, "S": WARN}


def duty_letters(info: dict[str, Any], down: NDArray[np.int64]) -> list[str]:
    """One letter per vehicle: H, M, P, or S (in the shop or replaced this shift)."""
    veh = info["vehicles"]
    out = []
    for v, r in enumerate(veh["route"]):
        shop = bool(veh["replaced"][v]) or down[v] > 0
        out.append("S" if shop else _DUTY[int(r)])
    return out


class FleetFrame:
    """The ``rgb_array`` frame: (40 + 16 n_vehicles) x 320 pixels, RGB."""

    def __init__(self, env: BrakeWearFleetEnv) -> None:
        self.env = env
        self.height = TOP + ROW * env.config.n_vehicles + 8
        self.info: dict[str, Any] = {}
        self._hot = route_wear_model(env.atlas, HOT)

    def start(self) -> None:
        self.info = {}

    def record(self, info: dict[str, Any]) -> None:
        self.info = info

    def frame(self) -> NDArray[np.uint8]:
        env, c = self.env, self.env.config
        img = np.empty((self.height, WIDTH, 3), dtype=np.uint8)
        img[:] = BACKGROUND
        shop = env.shop
        head = f"SHIFT {env.shift}/{c.episode_shifts}  WINDOW IN {c.shifts_to_window(env.shift)}"
        draw_text(img, 4, 4, head, TEXT)
        stock = f"BAYS {shop.free_bays()}/{c.bays}  STOCK {shop.stock}  ORDERED {shop.in_transit}"
        draw_text(img, 4, 18, stock, TEXT)
        t = env.truth()
        end = env.atlas.failure_volume
        letters = duty_letters(self.info, shop.down) if self.info else ["P"] * c.n_vehicles
        est = self.info.get("rul_estimate", {}).get("hot_rul_mean")
        if est is None:  # expected hot-route shifts left, from the truth
            vol = np.maximum(t["volume_frac"], end)
            est = self._hot.rul(vol, t["wear_coeff"]) / c.events_per_shift
        unit = " SH"
        for v in range(c.n_vehicles):
            self._row(img, v, float(t["volume_frac"][v]), end, letters[v], est=est, unit=unit)
        return img

    def _row(
        self,
        img: NDArray[np.uint8],
        v: int,
        vol: float,
        end: float,
        duty: str,
        *,
        est: Any,
        unit: str,
    ) -> None:
        y = TOP + ROW * v
        draw_text(img, 4, y + 2, f"{v:>2d}", DIM)
        share = max(0.0, min(1.0, (vol - end) / (1.0 - end)))
        color = GOOD if share > 0.4 else WARN if share > 0.15 else BAD
        x0, x1 = 24, 184
        outline(img, x0, y + 1, x1, y + ROW - 3, DIM)
        fill(img, x0 + 1, y + 2, x0 + 1 + int((x1 - x0 - 2) * share), y + ROW - 4, color)
        draw_text(img, 192, y + 2, duty, _DUTY_COLOR[duty])
        if est is not None and np.isfinite(est[v]):
            value = events_text(float(est[v])) if not unit else f"{float(est[v]):.0f}{unit}"
            draw_text(img, 208, y + 2, f"RUL {value}", TEXT)


def ansi(env: BrakeWearFleetEnv, info: dict[str, Any]) -> str:
    """A text frame: header, then one line per vehicle (volume, age, duty, last events)."""
    c, shop = env.config, env.shop
    t = env.truth()
    lines = [
        f"shift {env.shift}/{c.episode_shifts}  window in {c.shifts_to_window(env.shift)}"
        f"  bays {shop.free_bays()}/{c.bays}  stock {shop.stock}  on order {shop.in_transit}"
        f"  cost {sum(info['costs'].values()):.0f}"
    ]
    letters = duty_letters(info, shop.down)
    for v in range(c.n_vehicles):
        lines.append(
            f"  {v:>3d} {letters[v]}  volume {t['volume_frac'][v]:.3f}"
            f"  age {int(t['pad_age'][v]):>7d}  down {int(shop.down[v])}"
        )
    return "\n".join(lines)
