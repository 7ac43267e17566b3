"""Volume-averaged non-local plasticity (seed eqs 8-11; Dsouza & Nott 2020), planar 1D.

Derivation (docs/models.md, section "Volume-averaged"): to O(l^2) the averaged flow rule is
B = D - l^2 D'' with B = lambda dF/dsigma the local plastic rate. Steady planar flow has
div u = 0 so, as in the local model, alpha = 1 wherever lambda > 0, and the yield condition
admits lambda > 0 only on the weakest plane z* (with gravity). Elsewhere lambda = 0, i.e.
gammadot - l^2 gammadot'' = 0: the shear is not local plastic flow but the averaged influence of
the yielding plane, and decays as exp(-|z - z*| / l) whatever the local stress ratio.

Wall conditions (the velocity equation is third order in u): no slip u(0) = 0, u(H) = V, and at
each rough wall the condition that the wall itself hosts no plastic events (its grains are
frozen), so the averaged rate is the free-space response of the yielding plane:
l gammadot' = gammadot at z = 0 and l gammadot' = -gammadot at z = H. With them
gammadot(z) = C exp(-|z - z*| / l), C fixed by int_0^H gammadot dz = V; u_x is evaluated in
closed form on the nodes (no quadrature error).

The packing evolves to steady state from ``nu_initial`` (continuum.yielding): the isotropic part
of the flow rule dilates (alpha < 1) or compacts (alpha > 1) the yielding plane, and the
averaging spreads that volume change with the same weight exp(-|z - z*| / l), until alpha = 1
there. Planes that never yield keep the packing they had when the weakest plane reached its
critical state, so the steady nu(z) depends on the initial one.
"""
from __future__ import annotations

import time

import numpy as np
import xarray as xr

from .critical_state import parameter_attrs
from .geometry import PlanarShear
from .tolerance import event_tolerance
from .grid import hydrostatic_pressure, uniform_grid
from .packing import InitialPacking, initial_packing
from .parameters import VolumeAveragedParameters
from .solution import build_solution
from .yielding import evolve, exponential_spread

MODEL = "volume_averaged"


def creep_profile(z: np.ndarray, z_star: float, depth: float, length: float,
                  wall_speed: float, slip_length: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """u_x and gammadot for gammadot = C exp(-|z - z*| / l) with int_0^H gammadot dz + b
    (gammadot(0) + gammadot(H)) = V, b the walls' Navier slip length (m; u(0) = b gammadot(0)).

    Closed form of the cumulative integral, so the only grid dependence is where z* lies.
    """
    weight = exponential_spread(length)
    below = z <= z_star
    # integral of exp(-|z' - z*| / l) from 0 to z, divided by l
    e_bottom = weight(np.array([0.0]), z_star)[0]
    integral = np.where(
        below,
        weight(z, z_star) - e_bottom,
        (1.0 - e_bottom) + (1.0 - weight(z, z_star)),
    )
    e_top = weight(np.array([depth]), z_star)[0]
    # the walls' slips, b gammadot, in the same units (the integral over l)
    slips = slip_length / length * (e_bottom + e_top)
    total = (1.0 - e_bottom) + (1.0 - e_top) + slips
    u = wall_speed * (integral + slip_length / length * e_bottom) / total
    gammadot = wall_speed * weight(z, z_star) / (length * total)
    return u, gammadot


def solve(geometry: PlanarShear, params: VolumeAveragedParameters, n_grid: int = 200,
          nu_initial: InitialPacking = None, max_step: float = 2e-3,
          case: str | None = None, max_iterations: int = 20000, tolerance: float | None = None) -> xr.Dataset:
    """Steady velocity-driven planar shear with the volume-averaged model, reached by evolving the
    packing from ``nu_initial`` (callable nu(z) on the initial layer, (z, nu) samples, or None for
    a critical packing at every depth).

    Args (besides the above):
        max_step: largest change of ln nu at the yielding plane per evolution step.
        max_iterations: evolution steps allowed before ConvergenceError.

    Returns:
        Dataset with u_x, shear_rate (unless the yielding plane is undetermined), nu, p, mu on the
        steady-state node heights; attrs ``l`` (m), ``tau`` (Pa), ``shear_band_height`` (m),
        ``final_depth`` (m), ``velocity_determined``.
    """
    t0 = time.perf_counter()
    cs = params.critical
    z0 = uniform_grid(geometry, n_grid)
    nu0 = initial_packing(z0, geometry, cs.line, nu_initial)
    p = hydrostatic_pressure(z0, nu0, geometry)
    state = evolve(z0, nu0, p, cs, exponential_spread(params.l), MODEL, max_step=max_step,
                   max_events=max_iterations, case=case, tol=event_tolerance(tolerance))
    fields = {"nu": state.nu, "p": p, "mu": state.tau / p}
    final_depth = float(state.z[-1])
    band_height = -1.0
    if state.band >= 0:
        band_height = float(state.z[state.band])
        u, gammadot = creep_profile(state.z, band_height, final_depth, params.l, geometry.wall_speed,
                                    geometry.slip_length)
        fields.update({"u_x": u, "shear_rate": gammadot})
    attrs = parameter_attrs(cs)
    attrs["l"] = params.l
    return build_solution(
        MODEL, geometry, state.z, fields, converged=True, iterations=state.events,
        residual=state.residual, solve_seconds=time.perf_counter() - t0, n_grid=n_grid,
        parameters=attrs,
        extra_attrs={"tau": state.tau, "shear_band_height": band_height, "final_depth": final_depth,
                     "velocity_determined": int(state.band >= 0), "slip_length": geometry.slip_length,
                     "top_wall_slip": (geometry.slip_length * float(fields["shear_rate"][-1])
                                       if "shear_rate" in fields else float("nan"))},
    )
