"""Local rate-independent critical-state plasticity (seed eqs 1-4).

Yield: tau = p_c(nu) sin_phi Y(alpha), alpha = p / p_c(nu); associated flow rule D = lambda dF/dsigma.
In steady planar flow div u = 0, so the isotropic part of the flow rule,
tr D = lambda sin_phi Y'(alpha) (dilation positive), forces alpha = 1 wherever lambda > 0; there
the yield condition reads mu = tau / p = sin_phi. The deviatoric part only fixes the direction of
the shear, not its magnitude (rate independence).

Consequences solved for here:
- with gravity, p grows with depth, so at most one plane can be at yield: the weakest plane
  (in a critical packing, the top one) carries tau = min_z S(z) and all the shear is a
  velocity jump of V across that plane (a shear band of zero thickness); every other plane is
  rigid and keeps its initial packing. The returned u_x is 0 below the band and V above it.
  shear_rate is a Dirac mass at the band, so it is not returned as a profile; the band height
  is the attribute ``shear_band_height``.
- at uniform pressure (the rheometer) with a uniform packing every plane yields at once and the
  velocity profile is not determined by the model: u_x is then not returned
  (``velocity_determined`` = 0); nu, p and mu are.
"""
from __future__ import annotations

import time

import numpy as np
import xarray as xr

from .geometry import PlanarShear
from .tolerance import event_tolerance
from .grid import hydrostatic_pressure, uniform_grid
from .packing import InitialPacking, initial_packing
from .parameters import CriticalStateParameters
from .solution import build_solution
from .yielding import evolve

MODEL = "critical_state"


def parameter_attrs(params: CriticalStateParameters) -> dict[str, float]:
    """The critical-state parameters under the contract's names (plus the p_c(nu) line)."""
    return {"sin_phi": params.sin_phi, "n": params.n, "nu_ref": params.line.nu_ref,
            "kappa": params.line.kappa, "p_ref": params.line.p_ref}


def solve(geometry: PlanarShear, params: CriticalStateParameters, n_grid: int = 200,
          nu_initial: InitialPacking = None, case: str | None = None,
          max_iterations: int = 20000, tolerance: float | None = None) -> xr.Dataset:
    """Steady velocity-driven planar shear with local critical-state plasticity.

    Args:
        geometry: the shear cell.
        params: sin_phi, n and the critical-state line p_c(nu).
        n_grid: nodes, uniform in z.
        nu_initial: initial packing (callable nu(z), (z, nu) samples, or None for a packing at its
            critical state at every depth).
        case: label used in error messages.

    Returns:
        Dataset with nu, p, mu and (unless undetermined) u_x; attrs ``tau`` (Pa),
        ``shear_band_height`` (m; -1 if undetermined), ``velocity_determined`` (0/1).
    """
    t0 = time.perf_counter()
    z = uniform_grid(geometry, n_grid)
    nu0 = initial_packing(z, geometry, params.line, nu_initial)
    p = hydrostatic_pressure(z, nu0, geometry)
    state = evolve(z, nu0, p, params, None, MODEL, max_events=max_iterations, case=case,
                   tol=event_tolerance(tolerance))
    fields = {"nu": state.nu, "p": p, "mu": state.tau / p}
    band_height = -1.0
    if state.band >= 0:
        band_height = float(z[state.band])
        u = np.where(z > band_height, geometry.wall_speed, 0.0)
        if 0 < state.band < n_grid - 1:
            u[state.band] = 0.5 * geometry.wall_speed  # the jump is centred on the band node
        elif state.band == n_grid - 1:
            u[-1] = geometry.wall_speed  # band on the top wall: the wall node moves with it
        fields["u_x"] = u
    return build_solution(
        MODEL, geometry, z, fields, converged=True, iterations=state.events, residual=state.residual,
        solve_seconds=time.perf_counter() - t0, n_grid=n_grid, parameters=parameter_attrs(params),
        # A band of zero width has no finite shear rate: the Navier slip is not defined on it, and
        # a band on the top wall is itself the slip (geometry.slip_length changes nothing).
        extra_attrs={"tau": state.tau, "shear_band_height": band_height,
                     "velocity_determined": int(state.band >= 0), "slip_length": geometry.slip_length,
                     "top_wall_slip": (geometry.wall_speed - float(fields["u_x"][-1])) if "u_x" in fields else float("nan")},
    )
