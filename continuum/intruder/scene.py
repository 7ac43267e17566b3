"""The intruder scene: a rigid rod in the planar shear cell, the grid options, and the result.

Frame and signs (as in the rest of ``continuum``): x along the top wall's motion, periodic with
period ``cell_length_x``; z up from the fixed bottom wall (z = 0) to the moving top wall
(z = depth); gravity along -z; stresses compressive positive. The rod spans y, so the problem is
2D in x-z and forces are per unit length of rod (N m-1).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import xarray as xr

from ..geometry import PlanarShear


@dataclass(frozen=True)
class RodIntruder:
    """A rigid circular rod spanning the periodic y direction.

    Attributes:
        diameter: rod diameter D (m).
        depth_from_bottom: height z_i of the rod's centre above the bottom wall (m); its depth
            below the top wall is ``geometry.depth - depth_from_bottom``.
        force_per_length: constant horizontal force F applied to the rod along +x, per unit
            length of rod (N m-1). F >= 0.

    The rod translates along x only: it is held at its height (no vertical motion) and does not
    rotate, as a rod driven by a force spread evenly over its grains (LIGGGHTS ``fix aveforce``)
    with its vertical position held. The vertical force and torque needed to hold it are reported.
    """

    diameter: float
    depth_from_bottom: float
    force_per_length: float

    def __post_init__(self) -> None:
        if not self.diameter > 0.0:
            raise ValueError(f"RodIntruder.diameter must be positive, got {self.diameter!r}")
        if self.force_per_length < 0.0:
            raise ValueError(f"RodIntruder.force_per_length must be >= 0 (along +x), got {self.force_per_length!r}")

    @property
    def radius(self) -> float:
        return 0.5 * self.diameter

    @classmethod
    def below_top(cls, geometry: PlanarShear, diameter: float, depth_below_top: float,
                  force_per_length: float) -> "RodIntruder":
        """Rod whose centre lies ``depth_below_top`` (m) under the top wall."""
        return cls(diameter, geometry.depth - depth_below_top, force_per_length)

    def check_inside(self, geometry: PlanarShear, cell_length_x: float) -> None:
        """Raise ValueError unless the rod clears both walls and fits in the periodic cell."""
        r, z = self.radius, self.depth_from_bottom
        if not (r < z < geometry.depth - r):
            raise ValueError(f"rod (centre z = {z!r} m, radius {r!r} m) does not fit between the walls")
        if not self.diameter < cell_length_x:
            raise ValueError(f"rod diameter {self.diameter!r} m is not smaller than the periodic length {cell_length_x!r} m")


@dataclass(frozen=True)
class GridOptions:
    """Uniform x-z grid and nonlinear-iteration controls for the 2D solves (``framework.py``).

    Attributes:
        cells_per_d: cells per grain diameter, the same in x and z; the counts are rounded so that
            the periodic length and the depth are whole numbers of cells.
        tolerance: largest change of each of the model's own fields in one plain step, in that
            field's units (ln g for NGF: 1e-4 is 0.01 % in the fluidity, a thousandth of the
            0.1-decade error of the DEM's rod speed). A model may state its own.
        pressure_tolerance: largest change of p in one plain step, relative to the far-field p
            at that height. 1e-4 moves mu = tau / p by 1e-4 mu (4e-5 at mu_s), two orders of
            magnitude under the calibration's error on mu_s (a few 1e-3).
        velocity_tolerance: largest relative change of any face velocity in one plain step
            (relative to its own size, down to 1e-5 V: ``framework.VELOCITY_FLOOR``). 1e-3: a
            twentieth of the DEM's 0.02 V error in the band and of its 0.15-decade (40 %) error
            in the creep; ln g within 1e-4 moves velocities by about 1e-4 of themselves.
        rod_speed_tolerance: largest relative change of the rod speed U in one plain step
            (1e-3: 250 times under the DEM's 25 % error on U).
        max_iterations: evaluations of the fixed-point map (one Stokes solve and one
            constitutive update each) before ``ConvergenceError``.
        relaxation: damping of the fixed-point step (Anderson's first step, or plain Picard).
        anderson_depth: history of the Anderson mixing; 0 means damped Picard.
    """

    cells_per_d: float = 4.0
    tolerance: float = 1e-4
    pressure_tolerance: float = 1e-4
    velocity_tolerance: float = 1e-3
    rod_speed_tolerance: float = 1e-3
    max_iterations: int = 400
    relaxation: float = 0.2
    anderson_depth: int = 5

    def __post_init__(self) -> None:
        if not self.cells_per_d > 0.0:
            raise ValueError(f"cells_per_d must be positive, got {self.cells_per_d!r}")
        if not 0.0 < self.relaxation <= 1.0:
            raise ValueError(f"relaxation must be in (0, 1], got {self.relaxation!r}")
        for name in ("tolerance", "pressure_tolerance", "velocity_tolerance", "rod_speed_tolerance"):
            if not getattr(self, name) > 0.0:
                raise ValueError(f"GridOptions.{name} must be positive, got {getattr(self, name)!r}")
        if self.anderson_depth < 0 or self.max_iterations < 1:
            raise ValueError("GridOptions.anderson_depth must be >= 0 and max_iterations >= 1")

    def counts(self, geometry: PlanarShear, cell_length_x: float) -> tuple[int, int]:
        """(nx, nz) cell counts for the cell."""
        nx = max(4, int(round(cell_length_x / geometry.d * self.cells_per_d)))
        nz = max(4, int(round(geometry.depth / geometry.d * self.cells_per_d)))
        return nx, nz


@dataclass
class IntruderSpeed:
    """One model's prediction of the rod's steady speed.

    Attributes:
        model: model name (contract names).
        speed: steady rod speed U along +x (m s-1).
        converged, iterations, residual, solve_seconds, n_grid: as in the contract's model files
            (n_grid = number of 2D cells; 0 when no 2D solve was needed).
        method: how U was obtained ("2d" for the model's own 2D solve; "frozen" for the
            ngf_frozen approximation; "yield_check", "layer_sliding", "1d_flow", "kinematic" for
            the 1D estimates of models without a 2D solver).
        drift_speed: the part of U at zero force with the converged viscosity field (m s-1;
            the rod carried by the creep), NaN where not computed.
        mobility: dU/dF at the converged viscosity field (m s-1 per N m-1), NaN where not computed.
        yield_force: the model's estimate of the force that moves the rod when nothing else
            would (N m-1), NaN where the model has none.
        planar_solve_seconds: time of the 1D planar solve that gave the far field (s).
        fields: 2D fields on the cell centres (x, z) for plotting (u_x, u_z, fluidity,
            shear_rate, p, mu, solid), or None when no 2D solve was made.
        attrs: extra diagnostics (top-wall shear stress, vertical force and torque on the rod...).
        state: a 2D solve's converged fields and pressure on the cells (a warm start), or None.
    """

    model: str
    speed: float
    converged: bool
    iterations: int
    residual: float
    solve_seconds: float
    n_grid: int
    method: str
    drift_speed: float = float("nan")
    mobility: float = float("nan")
    yield_force: float = float("nan")
    planar_solve_seconds: float = float("nan")
    fields: xr.Dataset | None = None
    attrs: dict[str, float | int | str] = field(default_factory=dict)
    state: dict[str, np.ndarray] | None = field(default=None, repr=False)

    def summary(self) -> dict[str, float | int | str]:
        """Flat scalar record (for a CSV row or NetCDF attributes)."""
        out: dict[str, float | int | str] = {
            "model": self.model, "speed": float(self.speed), "converged": int(self.converged),
            "iterations": int(self.iterations), "residual": float(self.residual),
            "solve_seconds": float(self.solve_seconds), "n_grid": int(self.n_grid), "method": self.method,
            "drift_speed": float(self.drift_speed), "mobility": float(self.mobility),
            "yield_force": float(self.yield_force), "planar_solve_seconds": float(self.planar_solve_seconds),
        }
        out.update(self.attrs)
        return out


def disc_average(profile_z: np.ndarray, profile_values: np.ndarray, centre: float, radius: float,
                 n: int = 401) -> float:
    """Average over a disc of a field that depends on z only (area-weighted), by quadrature in
    the angle t: z = centre - radius cos t, weight sin^2 t (exact for fields linear in z)."""
    t = np.linspace(0.0, np.pi, n)
    values = np.interp(centre - radius * np.cos(t), profile_z, profile_values)
    w = np.sin(t) ** 2
    return float(np.trapezoid(values * w, t) / np.trapezoid(w, t))
