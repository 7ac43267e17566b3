"""Grids and quadratures shared by the planar solvers."""
from __future__ import annotations

import numpy as np

from .geometry import PlanarShear


def uniform_grid(geometry: PlanarShear, n_grid: int) -> np.ndarray:
    """n_grid nodes from the bottom wall (z = 0) to the top wall (z = depth), both included."""
    if n_grid < 3:
        raise ValueError(f"n_grid must be >= 3, got {n_grid}")
    return np.linspace(0.0, geometry.depth, n_grid)


def cumulative_trapezoid(y: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Integral of y from x[0] to each x[i] by the trapezoidal rule (second order), starting at 0."""
    out = np.empty_like(y, dtype=float)
    out[0] = 0.0
    np.cumsum(0.5 * (y[1:] + y[:-1]) * np.diff(x), out=out[1:])
    return out


def hydrostatic_pressure(z: np.ndarray, nu: np.ndarray, geometry: PlanarShear) -> np.ndarray:
    """p(z) = (P_wall + g rho_s * integral_z^H nu dz') / r (Pa): the vertical momentum balance
    gives sigma_zz, and p = sigma_zz / r with r = ``geometry.normal_stress_ratio``."""
    weight_below_top = cumulative_trapezoid(nu, z)
    return geometry.top_pressure + geometry.pressure_gradient * (weight_below_top[-1] - weight_below_top)
