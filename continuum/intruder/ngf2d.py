"""NGF in 2D (x-z) on the periodic shear cell, with or without the rigid rod (Henann & Kamrin 2014).

Equations (see docs/intruder.md), with p = pi / normal_stress_ratio (``framework.py``):
    div(2 eta D) - grad pi - rho_s nu g e_z = 0,   div u = 0,   eta = p / g,
    A^2 d^2 lap g = |mu - mu_s| (g - g_loc(mu, p)),   mu = tau / p,  tau = |T'| / sqrt(2),
i.e. shear rate = g mu with the stress parallel to the deformation rate (Henann & Kamrin 2013).
Walls: Navier slip u = V - b du/dz (top), u = b du/dz (bottom), b = ``PlanarShear.slip_length``
(0: no slip; ``mac.build_operators``); dg/dn = 0. Rod: no slip (rigid translation (U, 0)); dg/dn = 0
on its surface.

Two solutions:
- ``NGFRodSolver`` (model ``ngf``): the model as written, the fluidity equation solved with the
  stress and pressure of the flow around the rod; the framework's Anderson iteration in
  (ln g, p). This is NGF's prediction.
- ``frozen`` (label ``ngf_frozen``): the far field's fluidity and pressure kept around the rod,
  one Stokes solve, U = U_drift + F / K exactly: the secondary-rheology limit of small F. A named
  approximation, never NGF's score: once the rod is pushed its stress ratio and pressure are
  not a solution of the model (mu_max, p_min reported).
"""
from __future__ import annotations

import time
from typing import Any

import numpy as np
import scipy.sparse as sp
import xarray as xr
from scipy.sparse.linalg import splu

from .. import ngf
from ..errors import ConvergenceError, OutOfRangeError
from ..geometry import PlanarShear
from ..parameters import NGFParameters
from .flow import Flow, fill_solid
from .framework import RodSolver
from .mac import MacGrid, assemble, build_operators, rod_mask
from .scene import GridOptions, RodIntruder

MODEL = "ngf"
FROZEN = "ngf_frozen"
#: Floor on the fluidity, relative to its largest value. NGF's fluidity decays as exp(-z / xi)
#: below the shear zone; with a small A it underflows (1e-255 of its peak at A = 0.01) and the
#: Stokes system with eta = p / g is singular to working precision. Material 1e9 times less fluid
#: than the shear band is at rest for any comparison with the DEM (U is then bounded by this
#: floor); where the floor reaches the rod it is reported (``floor_at_rod``).
FLUIDITY_FLOOR = 1e-9
#: Largest momentum residual (in units of P_wall / d) of an accepted frozen solve.
RESIDUAL_TOL = 1e-6
#: Largest change of ln g in one accelerated step: far beyond it the linearisation the Anderson
#: history carries is meaningless (the first steps next to the pushed rod want e-fold changes).
LN_G_STEP = 2.0


def fluidity_laplacian(grid: MacGrid, solid: np.ndarray) -> sp.csr_matrix:
    """Five-point Laplacian (m-2) over the material cells, periodic in x, with zero flux through
    the walls and the rod surface (links to walls and solid cells are left out)."""
    nx, nz = grid.nx, grid.nz
    i, j = np.meshgrid(np.arange(nx), np.arange(nz))
    c = (j * nx + i).ravel()
    rows, cols, vals = [], [], []
    links = [((j * nx + (i + 1) % nx).ravel(), np.ones(c.size, bool), 1.0 / grid.hx**2),
             ((np.minimum(j + 1, nz - 1) * nx + i).ravel(), (j < nz - 1).ravel(), 1.0 / grid.hz**2)]
    for nb, ok, w in links:
        ok = ok & ~solid[c] & ~solid[nb]
        a, b = c[ok], nb[ok]
        rows += [a, b, a, b]
        cols += [b, a, a, b]
        vals += [np.full(a.size, w), np.full(a.size, w), np.full(a.size, -w), np.full(a.size, -w)]
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(grid.n_cells, grid.n_cells))


def planar_ngf(geometry: PlanarShear, params: NGFParameters, nz: int, case: str | None) -> xr.Dataset:
    """The 1D NGF solution on a grid 8 times finer than the 2D one (the far field)."""
    return ngf.solve(geometry, params, n_grid=8 * nz + 1, case=case)


class NGFRodSolver(RodSolver):
    """NGF around the rod: the model's field is ln g at the cells (tolerance ``options.tolerance``)."""

    model = MODEL

    def __init__(self, geometry: PlanarShear, params: NGFParameters, cell_length_x: float,
                 rod: RodIntruder | None, options: GridOptions = GridOptions(), case: str | None = None,
                 planar: xr.Dataset | None = None) -> None:
        if not isinstance(params, NGFParameters):
            raise TypeError(f"ngf needs NGFParameters, got {type(params).__name__}")
        super().__init__(geometry, params, cell_length_x, rod, options, case)
        self._planar = planar
        solid = self.mask.solid_cells
        self._lap = (params.A * geometry.d) ** 2 * fluidity_laplacian(self.grid, solid)
        self._ident_solid = sp.diags(solid.astype(float))
        self._g_floor = 0.0

    def planar_solution(self) -> xr.Dataset:
        if self._planar is None:
            self._planar = planar_ngf(self.geometry, self.params, self.grid.nz, self.case)
        return self._planar

    def bulk_density(self, fields: dict[str, np.ndarray]) -> float:
        return self.geometry.rho_s * self.params.nu

    def initial_fields(self, planar: xr.Dataset) -> dict[str, np.ndarray]:
        g = np.interp(self.z_cells, planar.z.values, planar.fluidity.values)
        return {"ln_g": np.log(np.maximum(g, FLUIDITY_FLOOR * float(g.max())))}

    @property
    def field_tolerances(self) -> dict[str, float]:
        return {"ln_g": self.options.tolerance}

    @property
    def step_limits(self) -> dict[str, float]:
        return {"ln_g": LN_G_STEP}

    def viscosity(self, fields: dict[str, np.ndarray], p: np.ndarray) -> np.ndarray:
        g = np.exp(fields["ln_g"])
        g = np.maximum(g, FLUIDITY_FLOOR * float(g[self.material].max()))
        return p / g

    @np.errstate(under="ignore")
    def update(self, flow: Flow, fields: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        mat, params = self.material, self.params
        p = flow.p_eff
        mu = flow.mu[mat]
        dmu = np.zeros(self.grid.n_cells)
        dmu[mat] = np.maximum(np.abs(mu - params.mu_i.mu_s), params.delta_mu)
        rhs = np.zeros(self.grid.n_cells)
        rhs[mat] = -dmu[mat] * ngf.local_fluidity(mu, p[mat], params, self.geometry.d, self.geometry.rho_s)
        g = splu((self._lap - sp.diags(dmu) + self._ident_solid).tocsc()).solve(rhs)
        # An M-matrix with a non-negative source: g >= 0. Underflow deep in the bed is floored a
        # thousand times under the viscosity's floor, relative to the current iterate's largest
        # fluidity (an early iterate can put the whole bed below mu_s, where g_loc = 0 and the
        # update is g = 0: the floor, with the step limit, turns that into a bounded step).
        g_ref = float(np.exp(np.max(fields["ln_g"][mat])))
        return {"ln_g": np.log(np.maximum(g, 1e-300 + FLUIDITY_FLOOR * 1e-3 * g_ref))}

    def output_fields(self, flow: Flow, fields: dict[str, np.ndarray]) -> dict[str, tuple[np.ndarray, str, str]]:
        return {"fluidity": (np.exp(fields["ln_g"]), "s-1", "granular fluidity g (NaN inside the rod)")}


def solve_coupled(geometry: PlanarShear, params: NGFParameters, cell_length_x: float, rod: RodIntruder | None,
                  options: GridOptions = GridOptions(), case: str | None = None,
                  warm: dict[str, np.ndarray] | None = None, planar: xr.Dataset | None = None):
    """NGF's converged 2D solution (``framework.RodSolution``)."""
    return NGFRodSolver(geometry, params, cell_length_x, rod, options, case, planar).solve(warm)


# The far-field fluidity underflows to zero deep in the bed when A is small (see FLUIDITY_FLOOR).
@np.errstate(under="ignore")
def solve_frozen(geometry: PlanarShear, params: NGFParameters, cell_length_x: float, rod: RodIntruder | None,
                 options: GridOptions = GridOptions(), case: str | None = None) -> dict[str, Any]:
    """``ngf_frozen``: one Stokes solve with eta = p_1D / g_1D and the top wall at V (the 1D
    pressure convention, p = sigma_zz / normal_stress_ratio).

    Returns a dict: ``speed`` (m s-1; None without rod), ``fields``, ``converged``,
    ``iterations`` (1), ``residual`` (momentum, over P_wall / d), ``n_grid``, ``tau_top``, ``top_wall_slip``,
    ``drift_speed``, ``mobility``, ``mu_max``, ``p_min``, ``fluidity_floor``, ``floor_at_rod``,
    ``planar_solve_seconds``, ``solve_seconds``.
    """
    t0 = time.perf_counter()
    solver = _FrozenSolver(geometry, params, cell_length_x, rod, options, case)
    t1 = time.perf_counter()
    planar = solver.planar_solution()
    planar_seconds = time.perf_counter() - t1
    fields = solver.initial_fields(planar)
    g = np.exp(fields["ln_g"])
    grid, mask = solver.grid, solver.mask
    floor_at_rod = False
    if rod is not None:
        near = np.hypot(solver.x_cells - 0.5 * cell_length_x, solver.z_cells - rod.depth_from_bottom) <= rod.diameter
        floor_at_rod = bool(np.any(g[near & solver.material] <= FLUIDITY_FLOOR * float(g.max()) * (1 + 1e-12)))
    p_far = np.interp(solver.z_cells, planar.z.values, planar.p.values)
    flow = solver.stokes(p_far / g, fields, p_far)
    nc = grid.n_cells
    keep = ~np.concatenate([mask.u_faces, mask.w_faces, np.ones(nc, bool)])
    r = flow.system.matrix @ flow.x - (flow.rhs_load + flow.system.unconstrained_rhs(flow.top_speed, None))
    residual = float(np.abs(r[keep]).max() / (geometry.wall_pressure / geometry.d))
    mat = solver.material
    out: dict[str, Any] = {
        "converged": residual <= RESIDUAL_TOL, "iterations": 1, "residual": residual, "n_grid": nc,
        "fluidity_floor": FLUIDITY_FLOOR * float(g.max()), "floor_at_rod": floor_at_rod, "tau_top": flow.tau_top,
        "top_wall_slip": solver.top_wall_slip(flow),
        "planar_solve_seconds": planar_seconds, "planar": planar, "coupling": "frozen",
        # where the stress ratio around the rod exceeds mu_s the frozen fluidity is not
        # self-consistent (the coupled solve fluidises there): reported, not hidden
        "mu_max": float(flow.mu[mat].max()), "p_min": float(flow.p[mat].min()),
        "speed": None if rod is None else flow.rod_speed,
    }
    out.update(solver._rod_outputs(flow))
    out["fields"] = solver._dataset(flow, fields)
    out["solve_seconds"] = time.perf_counter() - t0
    return out


class _FrozenSolver(NGFRodSolver):
    model = FROZEN


def solve_2d(geometry: PlanarShear, params: NGFParameters, cell_length_x: float, rod: RodIntruder | None,
             options: GridOptions = GridOptions(), case: str | None = None, coupling: str = "coupled") -> dict:
    """Compatibility wrapper: ``coupling`` "coupled" (NGF, the framework's solve) or "frozen"
    (``ngf_frozen``); the same dict keys as ``solve_frozen``."""
    if coupling == "frozen":
        return solve_frozen(geometry, params, cell_length_x, rod, options, case)
    if coupling != "coupled":
        raise ValueError(f"coupling must be 'frozen' or 'coupled', got {coupling!r}")
    sol = solve_coupled(geometry, params, cell_length_x, rod, options, case)
    out = {"converged": sol.converged, "iterations": sol.iterations, "residual": sol.residual,
           "residuals": sol.residuals, "n_grid": sol.n_grid, "planar_solve_seconds": sol.planar_seconds,
           "planar": sol.planar, "coupling": "coupled", "fields": sol.fields, "solve_seconds": sol.solve_seconds,
           "speed": None if rod is None else sol.speed, "state": sol.state}
    out.update(sol.attrs)
    return out
