"""What one 2D solve around the rod gives (``framework.RodSolver``): the Stokes flow of one
viscosity field (``Flow``), a converged solution (``RodSolution``), the explicit stress a model may
add to the momentum balance (``ExtraStress``), and how fields are carried into the rod's cells.

Grids and sign conventions as in ``framework``: flat arrays, cells j * nx + i, corners j * nx + i
(j = 0..nz); stresses tensile positive except the pressures (compressive positive).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import xarray as xr
from scipy import ndimage

from .mac import MacGrid, StokesSystem


@dataclass(frozen=True)
class ExtraStress:
    """An explicit tensile-positive stress (Pa) added to 2 eta D in the momentum balance.

    ``xx`` and ``zz`` at the cell centres, ``xz`` (acting on x-faces along z... the d/dz of it
    enters the x balance) and ``zx`` (its d/dx enters the z balance) at the corners; ``zx`` None
    means symmetric (zx = xz). Arrays flat, cells j * nx + i, corners j * nx + i (j = 0..nz).
    """

    xx: np.ndarray
    zz: np.ndarray
    xz: np.ndarray
    zx: np.ndarray | None = None


@dataclass
class Flow:
    """The Stokes solution for one viscosity field, on the grid (flat arrays, cells j * nx + i).

    Attributes:
        u, w: face velocities (m s-1): u on the x-faces (n_cells), w on the interior z-faces.
        pi: Stokes in-plane mean normal stress at the cells (Pa, compressive positive; its level
            set by the top wall's load P_wall).
        p: model pressure pi / normal_stress_ratio (Pa); ``p_eff`` the same floored at P_FLOOR x
            the top pressure (what the constitutive laws use).
        d_xx: du/dx at the cells (s-1; d_zz = -d_xx).
        d_xz: (du/dz + dw/dx) / 2 at the cells (s-1, the corners' values averaged).
        shear_rate: 2 sqrt(d_xx^2 + d_xz^2) at the cells (s-1; du/dz in planar shear).
        s_xx, s_xz: deviatoric stress (tensile positive) at the cells (Pa), viscous plus explicit.
        tau: sqrt(s_xx^2 + s_xz^2) (Pa); mu = tau / p_eff.
        eta: the viscosity the flow was solved with (Pa s).
        d_xz_corners, s_xz_corners: at the corners (n_corners).
        top_speed, rod_speed: V and U (m s-1; U NaN without rod).
        tau_top: mean shear stress on the top wall (Pa, the drive).
        rod_force_parts: (f_load, f_top, f_rod) the material's force on the rod along x (N m-1)
            for walls and rod at rest, per unit top speed, per unit rod speed (None without rod).
    """

    u: np.ndarray
    w: np.ndarray
    pi: np.ndarray
    p: np.ndarray
    p_eff: np.ndarray
    d_xx: np.ndarray
    d_xz: np.ndarray
    shear_rate: np.ndarray
    s_xx: np.ndarray
    s_xz: np.ndarray
    tau: np.ndarray
    mu: np.ndarray
    eta: np.ndarray
    d_xz_corners: np.ndarray
    s_xz_corners: np.ndarray
    top_speed: float
    rod_speed: float
    tau_top: float
    rod_force_parts: tuple[float, float, float] | None
    x: np.ndarray = field(repr=False)
    system: StokesSystem = field(repr=False)
    rhs_load: np.ndarray = field(repr=False)


@dataclass
class RodSolution:
    """A converged 2D solution (``RodSolver.solve``).

    ``state`` (the model's fields and p on the cells) is what a warm start takes; ``residuals``
    the last plain step's change of each unknown in the units its tolerance is stated in.
    """

    model: str
    speed: float
    converged: bool
    iterations: int
    residuals: dict[str, float]
    solve_seconds: float
    n_grid: int
    flow: Flow
    state: dict[str, np.ndarray]
    fields: xr.Dataset
    planar: xr.Dataset
    planar_seconds: float
    attrs: dict[str, Any] = field(default_factory=dict)

    @property
    def residual(self) -> float:
        """Largest residual over the unknowns, each over its tolerance (< 1: converged)."""
        return float(max(self.residuals.get(k + "_over_tol", 0.0) for k in self.residuals))


def fill_solid(values: np.ndarray, solid: np.ndarray, grid: MacGrid) -> np.ndarray:
    """Copy into solid cells the value of the nearest material cell."""
    if not solid.any():
        return values
    mask2 = solid.reshape(grid.nz, grid.nx)
    _, (jj, ii) = ndimage.distance_transform_edt(mask2, sampling=(grid.hz, grid.hx), return_indices=True)
    return values.reshape(grid.nz, grid.nx)[jj, ii].ravel()
