"""The calibration study behind the default brake (docs/calibration.md).

For each lever setting, prints the failure volume (bisection on the physics; 0 if the severe
event always stops), the mean wear per event at the last 1% layer before end of life (failure
or the 5% wear-out limit) over that of a fresh pad, estimated by Monte
Carlo on the physics itself (no atlas interpolation), and the expected life at K = 2e-6.

Run: ``.venv/bin/python benchmarks/analysis/calibration_scan.py`` (about a minute on 2 cores).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from brake_env.model.atlas import Atlas, AtlasSpec
from brake_env.model.params import BrakeModel
from brake_env.model.physics import critical_volume, end_of_life, simulate_events
from brake_env.model.wear import WearModel

N_MC = 100_000


def study(model: BrakeModel, s, m, th) -> tuple[float, float, float, float]:
    vc = critical_volume(model)
    end = end_of_life(vc, model)  # failure, or the wear-out limit
    last = 1.0 - 0.01 * math.floor((1.0 - end) / 0.01 + 1e-9)
    w1 = simulate_events(s, m, th, last, model).wear_per_k_m3
    w0 = simulate_events(s, m, th, 1.0, model).wear_per_k_m3
    ratio = w1.mean() / w0.mean()
    se = np.std(w1) / w0.mean() / math.sqrt(s.size)
    coarse = Atlas.build(AtlasSpec(model=model, n_speed=12, n_mass=4, n_slope=11))
    return vc, ratio, se, float(WearModel.from_atlas(coarse).life(2e-6))


def main() -> None:
    rng = np.random.default_rng(0)
    s, m = rng.uniform(4, 15, N_MC) / 3.6, rng.uniform(42e3, 54e3, N_MC)
    th = np.radians(rng.uniform(0, 10, N_MC))
    base = BrakeModel()
    print("start_C backing_J/K pressure_bar | failure_vol  wear_end/fresh(MC)  life@2e-6 | ok")
    for t0, cb, p in [
        (25, 350, 135),
        (375, 350, 121),
        (375, 350, 130),
        (400, 350, 130),
        (425, 350, 130),
        (425, 350, 133),
        (450, 350, 130),
        (450, 350, 135),
        (450, 350, 140),
        (450, 250, 135),
        (450, 450, 135),
        (475, 350, 135),
        (475, 350, 138),
    ]:
        b = dataclasses.replace(
            base.brake,
            start_temp_c=float(t0),
            backing_heat_capacity_j_per_k=float(cb),
            line_pressure_pa=p * 1e5,
        )
        vc, ratio, se, life = study(dataclasses.replace(base, brake=b), s, m, th)
        ok = 0.15 <= vc <= 0.25 and ratio - 2 * se >= 1.2 and 3e4 <= life <= 2e5
        mark = "  <- default" if b == base.brake else ""
        print(
            f"{t0:7.0f} {cb:11.0f} {p:12.0f} | {vc:11.3f}  {ratio:8.3f} ± {se:.3f}"
            f"        {life:9.0f} | {'yes' if ok else 'no'}{mark}"
        )


if __name__ == "__main__":
    main()
