"""An effect's change of the nominal event response, on a coarse grid (localise).

A replay model with an in-event effect answers through the nominal atlas plus the effect's
change, evaluated by the physics on a coarse regular grid over (speed, mass, slope, volume)
and interpolated multilinearly (:class:`brake_env.model.lookup.RegularGridInterp`); at the
effect's neutral value the change is exactly zero. A between-events effect uses the same
grid for the change that a hotter start (by ``T0_STEP``) makes.

Changes are relative (of the temperature rise above the start temperature, for
temperatures): they are smooth over the grid where the absolute ones (wear ~ v^2) are not.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from brake_env.model.atlas import Atlas
from brake_env.model.lookup import RegularGridInterp
from brake_env.model.physics import EventResponse, simulate_events

F64 = NDArray[np.float64]
GRID_FIELDS = ("temp_mean_c", "stop_dist_m", "wear_per_k_m3", "temp_peak_c", "stop_time_s")
T0_STEP = 40.0  # start-temperature step of the finite difference for thermal history [K]
Physics = Callable[[F64, F64, F64, F64], EventResponse]


def relative_change(changed: F64, nominal: F64, name: str, t0: float) -> F64:
    """Relative change of a field (of the rise above ``t0`` for temperatures)."""
    if name.startswith("temp"):
        return (changed - t0) / (nominal - t0) - 1.0
    return changed / nominal - 1.0


def apply_change(value: F64, rel: F64, name: str, t0: float) -> F64:
    """Inverse of :func:`relative_change`: the nominal ``value`` changed by ``rel``."""
    if name.startswith("temp"):
        return value + (value - t0) * rel
    return value * (1.0 + rel)


def change_grid(
    atlas: Atlas, v_end: float, n: tuple[int, int, int, int], physics: Physics
) -> RegularGridInterp:
    """Relative change of every field of :data:`GRID_FIELDS` that ``physics`` makes against
    the nominal physics, on ``n`` nodes over the atlas's envelope and volumes down to
    ``v_end``.

    Below the nominal atlas's end of life the change is taken against the nominal physics
    at that end (the last layer the atlas has), which extends the model there.
    """
    model = atlas.spec.model
    t0 = model.brake.start_temp_c
    axes = (
        np.linspace(atlas.speed_mps[0], atlas.speed_mps[-1], n[0]),
        np.linspace(atlas.mass_kg[0], atlas.mass_kg[-1], n[1]),
        np.linspace(atlas.slope_rad[0], atlas.slope_rad[-1], n[2]),
        np.linspace(min(atlas.failure_volume, v_end), 1.0, n[3]),
    )
    sp, m, th, v = np.meshgrid(*axes, indexing="ij")
    nominal = simulate_events(sp, m, th, np.maximum(v, atlas.failure_volume), model)
    changed = physics(sp, m, th, v)
    vals = np.stack(
        [relative_change(getattr(changed, f), getattr(nominal, f), f, t0) for f in GRID_FIELDS],
        -1,
    )
    # Nodes the changed physics cannot stop (past its own end of life) hold the value of
    # the nearest lower-wear node: the state path never goes there.
    for i in range(n[3] - 2, -1, -1):
        bad = ~np.isfinite(vals[..., i, :])
        vals[..., i, :][bad] = vals[..., i + 1, :][bad]
    return RegularGridInterp(axes, np.nan_to_num(vals))
