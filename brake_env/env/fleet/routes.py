"""Duty routes of the fleet: operating-condition distributions inside the atlas envelope.

A route is a box of (speed, mass, slope) inside the envelope, sampled uniformly; how much a
pad wears on it, and how the wear grows as the pad thins, is read from the atlas (the
coupled physics), never set by a factor. The measured figures (DESIGN.md 10): the hot
route (a loaded steep ramp, 8-15 km/h, 48-54 t, 6-10 deg) wears ~4.7x the mild one (level
drifts, 4-10 km/h, 42-48 t, 0-3 deg) per event on a fresh pad and ~6.6x on the last layer.

Failure. A pad fails where the envelope's most severe event (54 t, 15 km/h, 10 deg) can no
longer be stopped, the atlas's critical volume, on every route, as in BrakeWear-v0. The hot
route's most severe event is that event; a vehicle on mild duty could stop its own worst
event on a thinner pad, but any vehicle may be dispatched to the ramp in the next shift, so
a pad that cannot hold the ramp is unsafe on every vehicle (and the atlas has no layers
below that volume). One definition of failure for both envs.

A route maps the same uniform triples as the envelope (``conditions_from_uniform``): the
uniform route is exactly the paper's mix, so a vehicle on it brakes the same events as a
BrakeWear-v0 pad of the same streams (tested).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from brake_env.model.atlas import Atlas
from brake_env.model.wear import WearModel

F64 = NDArray[np.float64]
WEAR = "wear_per_k_m3"


@dataclass(frozen=True)
class Route:
    """A duty: operating conditions uniform in a box of the envelope.

    Attributes:
        name: Its name (``hot``, ``mild``, ``uniform``).
        speed_kmh: (lowest, highest) speed at brake onset [km/h].
        mass_t: (lowest, highest) vehicle mass [t].
        slope_deg: (lowest, highest) downhill slope [deg].
    """

    name: str
    speed_kmh: tuple[float, float]
    mass_t: tuple[float, float]
    slope_deg: tuple[float, float]

    def __post_init__(self) -> None:
        for f in ("speed_kmh", "mass_t", "slope_deg"):
            lo, hi = getattr(self, f)
            if not (np.isfinite(lo) and np.isfinite(hi) and lo <= hi):
                raise ValueError(f"Route {self.name}: {f} must be finite with low <= high")

    def bounds(self, atlas: Atlas) -> tuple[F64, F64]:
        """(low, high) of (speed [m/s], mass [kg], slope [rad]), checked inside the atlas
        grid. Ends on the grid's are taken from the grid itself, so that the envelope's
        route does the same arithmetic as :func:`conditions_from_uniform`."""
        axes = (atlas.speed_mps, atlas.mass_kg, atlas.slope_rad)
        si = (
            (self.speed_kmh[0] / 3.6, self.speed_kmh[1] / 3.6),
            (self.mass_t[0] * 1e3, self.mass_t[1] * 1e3),
            (np.radians(self.slope_deg[0]), np.radians(self.slope_deg[1])),
        )
        lo, hi = np.empty(3), np.empty(3)
        for i, (axis, (a, b)) in enumerate(zip(axes, si, strict=True)):
            tol = 1e-9 * (axis[-1] - axis[0])
            if a < axis[0] - tol or b > axis[-1] + tol:
                raise ValueError(
                    f"Route {self.name}: {('speed', 'mass', 'slope')[i]} range [{a:.6g}, {b:.6g}]"
                    f" leaves the atlas envelope [{axis[0]:.6g}, {axis[-1]:.6g}] (SI units)"
                )
            lo[i] = axis[0] if abs(a - axis[0]) <= tol else a
            hi[i] = axis[-1] if abs(b - axis[-1]) <= tol else b
        return lo, hi


HOT = Route("hot", (8.0, 15.0), (48.0, 54.0), (6.0, 10.0))
MILD = Route("mild", (4.0, 10.0), (42.0, 48.0), (0.0, 3.0))
UNIFORM = Route("uniform", (4.0, 15.0), (42.0, 54.0), (0.0, 10.0))
# Route index of each duty action (0 hot, 1 mild); the envelope's mix is index 2 (used to
# age the first pads as BrakeWear-v0's pads age, and in tests).
ROUTES = (HOT, MILD, UNIFORM)
ROUTE_INDEX = {r.name: i for i, r in enumerate(ROUTES)}


def route_indices(route: object, n_vehicles: int, who: str) -> NDArray[np.int64]:
    """``route`` (a name of :data:`ROUTES`, or route indices: one, or one per vehicle) as
    route indices; else one ``ValueError`` from ``who`` listing the valid routes."""
    if isinstance(route, str):
        if route not in ROUTE_INDEX:
            raise ValueError(f"{who}: unknown route {route!r}; valid are {list(ROUTE_INDEX)}")
        return np.asarray(ROUTE_INDEX[route], dtype=np.int64)
    r = np.asarray(route)
    if (
        r.dtype.kind not in "iu"
        or r.shape not in ((), (n_vehicles,))
        or ((r < 0) | (r >= len(ROUTES))).any()
    ):
        raise ValueError(
            f"{who}: route must be one of {list(ROUTE_INDEX)}, or route indices"
            f" 0-{len(ROUTES) - 1} (one, or one per vehicle), got {route!r}"
        )
    return r.astype(np.int64)


def route_table(atlas: Atlas, routes: tuple[Route, ...] = ROUTES) -> tuple[F64, F64]:
    """(low, span) arrays (routes, 3): conditions = low + span * u for uniform u."""
    lo, hi = zip(*(r.bounds(atlas) for r in routes), strict=True)
    low = np.stack(lo)
    return low, np.stack(hi) - low


def _segments(axis: F64, lo: float, hi: float) -> tuple[F64, F64]:
    """2-point Gauss-Legendre nodes and weights on [lo, hi] split at the grid nodes: exact
    for the piecewise-linear interpolant along this axis (weights sum to 1)."""
    cuts = np.unique(np.concatenate([[lo, hi], axis[(axis > lo) & (axis < hi)]]))
    if cuts.size == 1:  # a degenerate range: a point
        return cuts, np.ones(1)
    a, b = cuts[:-1], cuts[1:]
    mid, half = 0.5 * (a + b), 0.5 * (b - a)
    g = half / np.sqrt(3.0)
    x = np.stack([mid - g, mid + g], axis=1).ravel()
    w = np.repeat(half, 2)
    return x, w / w.sum()


def _route_mean(atlas: Atlas, route: Route, field: str) -> F64:
    lo, hi = route.bounds(atlas)
    axes = (atlas.speed_mps, atlas.mass_kg, atlas.slope_rad)
    (xs, ws), (xm, wm), (xt, wt) = (_segments(a, lo[i], hi[i]) for i, a in enumerate(axes))
    s, m, t = (x.ravel() for x in np.meshgrid(xs, xm, xt, indexing="ij"))
    w = np.einsum("i,j,k->ijk", ws, wm, wt).ravel()
    layers = np.arange(atlas.n_layers)[:, None]
    vals = atlas.query(s[None], m[None], t[None], layer=layers, fields=(field,))[field]
    mean = vals @ w
    mean.flags.writeable = False
    return mean


def route_mean(atlas: Atlas, route: Route, field: str = WEAR) -> F64:
    """Mean of an atlas field per layer over the route's conditions (exact for the
    trilinear interpolant: Gauss-Legendre between grid nodes), shape (layers,). For
    ``wear_per_k_m3`` times K over the pad volume it is the expected volume fraction lost
    per event in each layer [-]; cached per atlas and route."""
    cache = atlas.__dict__.setdefault("_route_means", {})
    if (route, field) not in cache:
        cache[route, field] = _route_mean(atlas, route, field)
    return cache[route, field]


def route_wear_model(atlas: Atlas, route: Route) -> WearModel:
    """The wear clock (:class:`WearModel`) of a pad kept on ``route``: expected life
    ``life_work / K`` events, RUL from a volume, and so on."""
    w = route_mean(atlas, route)
    pad_v = atlas.spec.model.brake.pad_volume_m3
    return WearModel.from_layer_wear(atlas.volumes, atlas.lower_edges, w, pad_v)
