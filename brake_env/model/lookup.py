"""The atlas lookup: trilinear interpolation on the regular (speed, mass, slope) grid of
every atlas layer (paper 2.1.2). The one home of locating conditions in the grid and
gathering cell corners; :class:`~brake_env.model.atlas.Atlas` queries go through it, and so
do the twin (every layer at once) and sim2real (several atlases on one grid).
:class:`RegularGridInterp` is the same interpolation on any regular grid of any number of
axes (sim2real's coarse grids over speed, mass, slope and volume).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

F64 = NDArray[np.float64]
AXIS_NAMES = ("speed_mps", "mass_kg", "slope_rad")


class GridLookup:
    """Trilinear lookup of per-layer fields on one regular grid.

    Args:
        axes: (speed [m/s], mass [kg], slope [rad]) node coordinates, each evenly spaced.
        fields: Name -> array of shape (layers, n_speed, n_mass, n_slope).
    """

    def __init__(self, axes: tuple[F64, F64, F64], fields: dict[str, F64]) -> None:
        self.axes = axes
        self.fields = fields
        self._tables: dict[tuple[str, ...], F64] = {}
        self._profiles: dict[str, F64] = {}
        # Per axis (3, 1): nodes, first and last node, for locating 1-D points in one pass.
        self._n = np.array([a.size for a in axes])[:, None]
        self._lo = np.array([a[0] for a in axes])[:, None]
        self._hi = np.array([a[-1] for a in axes])[:, None]

    # ---------------------------------------------------------------- locate
    def locate(self, s: F64, m: F64, th: F64, clip: bool = False) -> tuple[NDArray[np.intp], F64]:
        """Flat cell index within a layer and fractional position (3, ...) inside the cell.

        Conditions outside the grid raise ``ValueError`` unless ``clip`` is set; a node hit
        within rounding is the node, so node values come back exactly.
        """
        idx, frac = [], []
        for name, x, axis in zip(AXIS_NAMES, (s, m, th), self.axes, strict=True):
            lo, hi = axis[0], axis[-1]
            if x.size and not np.all(np.isfinite(x)):
                raise ValueError(f"{name} must be finite (got NaN or inf)")
            if clip:
                x = np.clip(x, lo, hi)
            elif x.size and (np.min(x) < lo - 1e-9 or np.max(x) > hi + 1e-9):
                raise ValueError(
                    f"{name} outside the atlas grid [{lo:.6g}, {hi:.6g}]:"
                    f" got range [{np.min(x):.6g}, {np.max(x):.6g}]"
                )
            u = np.clip((x - lo) * ((axis.size - 1) / (hi - lo)), 0.0, axis.size - 1)
            r = np.rint(u)
            u = np.where(np.abs(u - r) < 1e-9, r, u)
            i = np.minimum(u.astype(np.intp), axis.size - 2)
            idx.append(i)
            frac.append(u - i)
        cm, ct = self.axes[1].size - 1, self.axes[2].size - 1
        return (idx[0] * cm + idx[1]) * ct + idx[2], np.stack(frac)

    def _locate_points(self, s: F64, m: F64, th: F64) -> tuple[NDArray[np.intp], F64]:
        """:meth:`locate` with ``clip`` of 1-D points, the three axes in one pass (the
        same arithmetic, so the same cells and fractions)."""
        x = np.stack([s, m, th])
        if not np.all(np.isfinite(x)):
            bad = AXIS_NAMES[int(np.argmin(np.isfinite(x).all(axis=1)))]
            raise ValueError(f"{bad} must be finite (got NaN or inf)")
        n, lo, hi = self._n, self._lo, self._hi
        u = np.clip((np.clip(x, lo, hi) - lo) * ((n - 1) / (hi - lo)), 0.0, n - 1)
        r = np.rint(u)
        u = np.where(np.abs(u - r) < 1e-9, r, u)
        i = np.minimum(u.astype(np.intp), n - 2)
        return (i[0] * (n[1, 0] - 1) + i[1]) * (n[2, 0] - 1) + i[2], u - i

    # ---------------------------------------------------------------- one layer per point
    def corner_table(self, names: tuple[str, ...]) -> F64:
        """Fields regrouped as (layers, cells, fields, 8): each cell's corners side by side,
        so one gather per event fetches everything the interpolation needs (cached)."""
        if names not in self._tables:
            a = np.stack([self.fields[n] for n in names], axis=-1)  # (L, ns, nm, nt, F)
            n_l, ns, nm, nt, n_f = a.shape
            corners = [
                a[:, ds : ns - 1 + ds, dm : nm - 1 + dm, dt : nt - 1 + dt]
                for ds in (0, 1)
                for dm in (0, 1)
                for dt in (0, 1)
            ]
            self._tables[names] = np.stack(corners, axis=-1).reshape(n_l, -1, n_f, 8)
        return self._tables[names]

    def interp(
        self, names: tuple[str, ...], layer: NDArray[np.intp], cell: NDArray[np.intp], f: F64
    ) -> dict[str, F64]:
        """Fields at located points, each at its own layer (inputs broadcast together)."""
        out = self.interp_array(names, layer, cell, f)
        return {n: out[..., i] for i, n in enumerate(names)}

    def interp_array(
        self, names: tuple[str, ...], layer: NDArray[np.intp], cell: NDArray[np.intp], f: F64
    ) -> F64:
        """As :meth:`interp`, the fields stacked on a last axis: shape (..., len(names))."""
        table = self.corner_table(names)
        if layer.ndim == 0 or np.all(layer == layer.flat[0]):
            g = table[int(layer.flat[0])][cell]  # one layer: gather from a cache-sized slice
        else:
            g = table.reshape(-1, *table.shape[2:])[layer * table.shape[1] + cell]
        return trilinear(g, f)

    # ---------------------------------------------------------------- every layer per point
    def profile(
        self,
        s: F64,
        m: F64,
        th: F64,
        field: str = "temp_mean_c",
        layer: NDArray[np.intp] | None = None,
    ) -> tuple[F64, F64]:
        """(field, d field / d slope) of 1-D points: at every layer, shape (points, layers),
        or at each point's own ``layer``, shape (points,). Points outside the grid are
        clipped to it (a noisy slope sensor reads beyond the envelope now and then)."""
        cell, f = self._locate_points(s, m, th)
        table = self._corner_layers(field)
        g = table[cell] if layer is None else table[cell, :, layer]
        fs, fm, ft = (x[:, None] for x in f)
        if layer is None:
            fs, fm, ft = fs[..., None], fm[..., None], ft[..., None]
        lo, hi = g[:, 0::2], g[:, 1::2]  # slope-low and slope-high corners, order (s, m)
        dslope = float(self.axes[2][1] - self.axes[2][0])
        c = lo + ft * (hi - lo)
        return _bilerp(c, fs[:, 0], fm[:, 0]), _bilerp((hi - lo) / dslope, fs[:, 0], fm[:, 0])

    def profiles(
        self, s: F64, m: F64, th: F64, field: str = "temp_mean_c", layers: slice = slice(None)
    ) -> F64:
        """``field`` and its slope derivative at every layer (or the ``layers`` slice) of 1-D
        points, shape (points, 2, layers): each a weighted sum of the cell's 8 corners, one
        small matrix product per point. The interpolant of :meth:`profile`, equal to it to
        rounding (~1e-15 relative) in about half the time: the digital twin's hot path.
        Points outside the grid are clipped to it."""
        cell, f = self._locate_points(s, m, th)
        corners = self._corner_layers(field)[cell, :, layers]  # (points, 8, layers)
        return np.matmul(_corner_weights(f, float(self.axes[2][1] - self.axes[2][0])), corners)

    def _corner_layers(self, field: str) -> F64:
        """``field`` as (cells, 8 corners, layers), bit order (speed, mass, slope): one
        contiguous gather per point fetches a cell at every layer (cached)."""
        if field not in self._profiles:
            t = self.corner_table((field,))[:, :, 0, :]  # (L, cells, 8)
            self._profiles[field] = np.ascontiguousarray(np.moveaxis(t, 0, -1))
        return self._profiles[field]


class RegularGridInterp:
    """Multilinear interpolation on a regular grid of any number of axes.

    Points outside the grid are clamped to it; a point within rounding of a node is that
    node, so node values come back exactly. Vectorised over points: one gather per cell
    corner (2^d of them), whatever the number of points.

    Args:
        axes: Node coordinates of each axis, evenly spaced and increasing, 2 or more each.
        values: Array of shape (n_0, ..., n_{d-1}) or (n_0, ..., n_{d-1}, fields).
    """

    def __init__(self, axes: Sequence[ArrayLike], values: ArrayLike) -> None:
        ax = [np.asarray(a, dtype=np.float64) for a in axes]
        vals = np.asarray(values, dtype=np.float64)
        shape = tuple(a.size for a in ax)
        if not ax or any(a.ndim != 1 or a.size < 2 for a in ax):
            raise ValueError("RegularGridInterp needs one or more axes of 2 or more nodes")
        if vals.shape[: len(ax)] != shape or vals.ndim > len(ax) + 1:
            raise ValueError(
                f"values of shape {vals.shape} do not match axes of sizes {shape}"
                " (optionally followed by one fields axis)"
            )
        for i, a in enumerate(ax):
            d = np.diff(a)
            if not np.all(d > 0) or not np.allclose(d, d[0], rtol=1e-9, atol=0.0):
                raise ValueError(f"axis {i} must be evenly spaced and increasing")
        self.scalar = vals.ndim == len(ax)
        self.lo = np.array([a[0] for a in ax])
        self.step = np.array([(a[-1] - a[0]) / (a.size - 1) for a in ax])
        self.n = np.array(shape)
        self.values = vals.reshape(int(np.prod(shape)), -1)
        strides = np.array([int(np.prod(shape[i + 1 :])) for i in range(len(ax))])
        # Corner c takes the upper node along axis a where bit a of c is set.
        self._bits = (np.arange(2 ** len(ax))[:, None] >> np.arange(len(ax))) & 1
        self._offsets = self._bits @ strides
        self._strides = strides

    @property
    def ndim(self) -> int:
        return int(self.n.size)

    def __call__(self, points: ArrayLike, cols: Sequence[int] | None = None) -> F64:
        """Values at ``points`` (..., d): shape (...) for scalar values, else (..., fields),
        or only the fields ``cols``."""
        pts = np.asarray(points, dtype=np.float64)
        if pts.shape[-1:] != (self.ndim,):
            raise ValueError(f"points must have shape (..., {self.ndim}), got {pts.shape}")
        lead = pts.shape[:-1]
        x = pts.reshape(-1, self.ndim)
        vals = self.values if cols is None else self.values[:, list(cols)]
        # Divides by the step where GridLookup.locate multiplies by its inverse: each keeps
        # the rounding its callers' outputs were produced with (their bytes are tested).
        u = np.clip((x - self.lo) / self.step, 0.0, self.n - 1.0)
        r = np.rint(u)
        u = np.where(np.abs(u - r) < 1e-9, r, u)
        i = np.minimum(u.astype(np.int64), self.n - 2)
        f = u - i
        g = 1.0 - f
        base = i @ self._strides
        out = np.zeros((x.shape[0], vals.shape[1]))
        for bits, off in zip(self._bits, self._offsets, strict=True):
            w = np.ones(x.shape[0])
            for a in range(self.ndim):
                w = w * (f[:, a] if bits[a] else g[:, a])
            out += w[:, None] * vals[base + off]
        if self.scalar and cols is None:
            return out[:, 0].reshape(lead)
        return out.reshape(*lead, vals.shape[1])


def trilinear(g: F64, f: F64) -> F64:
    """Trilinear interpolation of gathered corners ``g`` (..., 8), bit order (speed, mass,
    slope), at fractions ``f`` (3, ...): 7 lerps ``(1-f) a + f b``, exact at every node."""
    fs, fm, ft = (x[..., None] for x in f)  # broadcast over the fields axis
    gs = 1.0 - ft
    c = [gs * g[..., 2 * i] + ft * g[..., 2 * i + 1] for i in range(4)]  # along slope
    gm = 1.0 - fm
    c0, c1 = gm * c[0] + fm * c[1], gm * c[2] + fm * c[3]  # along mass
    return (1.0 - fs) * c0 + fs * c1  # along speed


def trapezoid_weights(n: int) -> F64:
    """Weights of the uniform mean of a piecewise-linear function on ``n`` even nodes."""
    w = np.ones(n)
    w[[0, -1]] = 0.5
    return w / w.sum()


def _corner_weights(f: F64, dslope: float) -> F64:
    """(points, 2, 8): the trilinear weight of each cell corner at fractions ``f`` (3,
    points), and its derivative along slope per unit slope, corners in bit order (speed,
    mass, slope)."""
    fs, fm, ft = f
    ab = (np.stack([1.0 - fs, fs])[:, None] * np.stack([1.0 - fm, fm])[None]).reshape(4, -1)
    w = np.empty((fs.size, 2, 4, 2))
    w[:, 0, :, 0] = (ab * (1.0 - ft)).T
    w[:, 0, :, 1] = (ab * ft).T
    w[:, 1, :, 1] = ab.T / dslope
    w[:, 1, :, 0] = -w[:, 1, :, 1]
    return w.reshape(-1, 2, 8)


def _bilerp(c: F64, fs: F64, fm: F64) -> F64:
    """Combine 4 corner values (axis 1, order (s0m0, s0m1, s1m0, s1m1)) bilinearly."""
    a = c[:, 0] + fm * (c[:, 1] - c[:, 0])
    b = c[:, 2] + fm * (c[:, 3] - c[:, 2])
    return a + fs * (b - a)
