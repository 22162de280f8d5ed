"""RegularGridInterp: exact at nodes, linear functions reproduced, clamped outside."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import RegularGridInterpolator

from brake_env.model.lookup import RegularGridInterp


def _axes() -> tuple[np.ndarray, ...]:
    # Steps that are not binary fractions, so node positions come with rounding.
    return (
        np.linspace(2.0, 9.0, 6),
        np.linspace(1e4, 4e4, 3),
        np.linspace(-0.07, 0.21, 5),
        np.linspace(0.13, 1.0, 7),
    )


def test_exact_at_every_node() -> None:
    axes = _axes()
    vals = np.random.default_rng(0).normal(size=(*(a.size for a in axes), 2))
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), -1)
    out = RegularGridInterp(axes, vals)(grid)
    assert out.shape == vals.shape
    assert np.array_equal(out, vals)


def test_reproduces_multilinear_functions() -> None:
    axes = _axes()
    coef = np.array([0.5, -3e-5, 7.0, 2.0])

    def f(x: np.ndarray) -> np.ndarray:  # linear in each axis, with a cross term
        return 1.5 + x @ coef + 0.3 * x[..., 0] * x[..., 3]

    grid = np.stack(np.meshgrid(*axes, indexing="ij"), -1)
    interp = RegularGridInterp(axes, f(grid))
    rng = np.random.default_rng(1)
    lo, hi = np.array([a[0] for a in axes]), np.array([a[-1] for a in axes])
    pts = lo + (hi - lo) * rng.random((500, 4))
    np.testing.assert_allclose(interp(pts), f(pts), rtol=1e-12)


def test_agrees_with_scipy_and_selects_fields() -> None:
    axes = _axes()[:3]
    vals = np.random.default_rng(2).normal(size=(6, 3, 5, 3))
    rng = np.random.default_rng(3)
    lo, hi = np.array([a[0] for a in axes]), np.array([a[-1] for a in axes])
    pts = (lo + (hi - lo) * rng.random((200, 3))).reshape(10, 20, 3)
    ours = RegularGridInterp(axes, vals)
    ref = RegularGridInterpolator(axes, vals)(pts)
    np.testing.assert_allclose(ours(pts), ref, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(ours(pts, [2, 0]), ref[..., [2, 0]], rtol=1e-12, atol=1e-12)


def test_clamps_outside_the_grid() -> None:
    axes = (np.linspace(0.0, 1.0, 3), np.linspace(10.0, 20.0, 4))
    vals = np.arange(12.0).reshape(3, 4)  # scalar values: no fields axis
    interp = RegularGridInterp(axes, vals)
    pts = np.array([[-5.0, 15.0], [0.0, 15.0], [7.0, 99.0], [1.0, 20.0], [-1.0, -1.0]])
    out = interp(pts)
    assert out.shape == (5,)
    assert out[0] == out[1]  # below the first speed node: held at it
    assert out[2] == out[3] == vals[-1, -1]
    assert out[4] == vals[0, 0]


def test_one_axis_and_bad_input() -> None:
    interp = RegularGridInterp([np.array([0.0, 2.0, 4.0])], np.array([1.0, 5.0, 3.0]))
    np.testing.assert_array_equal(interp(np.array([[1.0], [3.0], [5.0]])), [3.0, 4.0, 3.0])
    with pytest.raises(ValueError, match="evenly spaced"):
        RegularGridInterp([np.array([0.0, 1.0, 3.0])], np.zeros(3))
    with pytest.raises(ValueError, match="do not match"):
        RegularGridInterp([np.array([0.0, 1.0])], np.zeros(3))
    with pytest.raises(ValueError, match="shape"):
        interp(np.zeros((2, 2)))
