"""Local mu(I) rheology with the nu(I) dilatancy law (Jop, Forterre & Pouliquen 2006).

Steady planar shear: tau is uniform and p(z) = P_wall + g rho_s int_z^H nu dz'. At each height
mu = tau / p, the shear rate is gammadot = I(mu) sqrt(p / rho_s) / d and nu = nu_c - a I(mu).
Where mu <= mu_s the model predicts no flow: gammadot = 0 and u_x = 0 exactly (nu = nu_c there,
the law at I = 0). tau is fixed by the wall speed: int_0^H gammadot dz + b (gammadot(H) +
gammadot(0)) = V, b the walls' Navier slip length (``PlanarShear.slip_length``).

Why the flowing layer is solved in the pressure variable: every local quantity depends on z only
through p, and dz/dp = -1 / (g rho_s nu(p)), so with p as the independent variable the weight, the
height and the velocity are plain quadratures over [P_wall, p_end] with no fixed-point iteration,
and the yield plane (p = tau / mu_s) is an end point of the interval instead of a kink inside a
cell. With gravity the flowing layer can be a small fraction of a grain thick at creeping wall
speeds; nodes uniform in p put all n_grid nodes inside it.
"""
from __future__ import annotations

import time

import numpy as np

from .errors import ConvergenceError, OutOfRangeError
from .geometry import PlanarShear
from .tolerance import wall_root
from .grid import cumulative_trapezoid
from .parameters import LocalMuIParameters
from .solution import build_solution
import xarray as xr

MODEL = "local_mu_i"
_RTOL = 1e-10


def _flowing_layer(tau: float, geometry: PlanarShear, params: LocalMuIParameters, n: int) -> dict[str, np.ndarray]:
    """Profiles of the flowing layer for shear stress tau, on n nodes uniform in p.

    Returns arrays ordered from the top wall downwards: p, z, I, nu, gammadot, and the integrated
    velocity drop below the top wall, plus whether the yield plane lies inside the layer.
    """
    mu_law, nu_law = params.mu_i, params.solid_fraction
    weight = geometry.pressure_gradient

    def profiles(p_end: float) -> tuple[np.ndarray, ...]:
        p = np.linspace(geometry.top_pressure, p_end, n)
        inertial = mu_law.inertial_number(tau / p)
        nu = nu_law.nu(inertial)
        depth_below_top = cumulative_trapezoid(1.0 / (weight * nu), p)
        return p, inertial, nu, depth_below_top

    p_yield = tau / mu_law.mu_s
    p, inertial, nu, depth_below_top = profiles(p_yield)
    yield_inside = depth_below_top[-1] <= geometry.depth
    if not yield_inside:
        # The whole layer flows: find the bottom-wall pressure by Newton on depth(p_end) = H; the
        # depth is nearly linear in p_end (nu barely varies), so three or four steps suffice.
        p_end = p_yield
        for _ in range(50):
            excess = depth_below_top[-1] - geometry.depth
            if abs(excess) <= 1e-13 * geometry.depth:
                break
            p_end -= excess * weight * nu[-1]
            p, inertial, nu, depth_below_top = profiles(p_end)
        else:
            raise ConvergenceError(MODEL, abs(excess) / geometry.depth, "bottom-wall pressure did not converge")
    gammadot = inertial * np.sqrt(p / geometry.rho_s) / geometry.d
    velocity_drop = cumulative_trapezoid(gammadot / (weight * nu), p)
    z = geometry.depth - depth_below_top
    if not yield_inside:
        z[-1] = 0.0  # the Newton tolerance above leaves a 1e-13 relative offset
    return {"p": p, "z": z, "I": inertial, "nu": nu, "gammadot": gammadot,
            "velocity_drop": velocity_drop, "yield_inside": np.array(yield_inside)}


def solve(geometry: PlanarShear, params: LocalMuIParameters, n_grid: int = 200, case: str | None = None,
          max_iterations: int = 200, tolerance: float | None = None) -> xr.Dataset:
    """Steady velocity-driven planar shear with the local mu(I), nu(I) laws.

    Args:
        geometry: the shear cell (with or without gravity).
        params: mu(I) and nu(I) laws.
        n_grid: nodes across the flowing layer (uniform in pressure); the static layer below the
            yield plane, where the solution is exact (u = 0, nu = nu_c, p linear), gets as many
            evenly spaced nodes.
        case: label used in error messages.

    Returns:
        The contract's Dataset with u_x, shear_rate, nu, p, mu on z (m), plus attrs ``tau`` (Pa)
        and ``yield_height`` (m, height of the plane mu = mu_s; 0 if the whole layer flows).

    max_iterations bounds the shear-stress root search (brentq iterations).

    Raises:
        OutOfRangeError: the wall speed needs a stress ratio beyond mu_2 or an inertial number
            where the linear nu(I) is no longer positive.
        ConvergenceError: the shear-stress root did not reach its tolerance.
    """
    t0 = time.perf_counter()
    mu_law, nu_law = params.mu_i, params.solid_fraction
    V, P = geometry.wall_speed, geometry.top_pressure
    parameters = {"mu_s": mu_law.mu_s, "mu_2": mu_law.mu_2, "I_0": mu_law.I_0, "nu_c": nu_law.nu_c, "a": nu_law.a}

    if geometry.gravity == 0.0 or V == 0.0:
        # Uniform pressure (or no flow): the exact solution is homogeneous shear.
        return _homogeneous(geometry, params, n_grid, parameters, t0)

    i_limit = min(nu_law.I_max, 1e6)

    b = geometry.slip_length

    def wall_slips(layer: dict[str, np.ndarray]) -> tuple[float, float]:
        # Navier slip at each wall: b times the shear rate there (0 at a bottom wall at rest)
        bottom = b * float(layer["gammadot"][-1]) if not bool(layer["yield_inside"]) else 0.0
        return b * float(layer["gammadot"][0]), bottom

    def speed_mismatch(inertial_top: float) -> float:
        tau = float(mu_law.mu(inertial_top)) * P
        layer = _flowing_layer(tau, geometry, params, n_grid)
        top_slip, bottom_slip = wall_slips(layer)
        return (layer["velocity_drop"][-1] + top_slip + bottom_slip) / V - 1.0

    # Bracket the top-wall inertial number: V(I_top) rises monotonically from 0 at I_top = 0.
    lo, hi = 0.0, 1e-8
    while speed_mismatch(hi) < 0.0:
        lo, hi = hi, hi * 4.0
        if hi >= i_limit:
            raise OutOfRangeError(MODEL, f"wall speed {V} m/s needs I above {i_limit:.3g} at the top wall, "
                                  "beyond the range of the nu(I) law", case)
    try:
        i_top, converged, residual, iterations = wall_root(speed_mismatch, lo, hi, tolerance, _RTOL, max_iterations)
    except ValueError as exc:
        raise ConvergenceError(MODEL, np.nan, f"shear-stress root failed: {exc}", case) from exc
    if not converged:
        raise ConvergenceError(MODEL, residual, "wall-speed condition not met", case)

    tau = float(mu_law.mu(i_top)) * P
    layer = _flowing_layer(tau, geometry, params, n_grid)
    # flowing layer, reordered bottom to top
    z_f, p_f, nu_f, gd_f = (layer[k][::-1] for k in ("z", "p", "nu", "gammadot"))
    top_slip, bottom_slip = wall_slips(layer)
    u_f = V - top_slip - layer["velocity_drop"][::-1]
    z_yield = float(z_f[0])
    if bool(layer["yield_inside"]) and z_yield > 0.0:
        z_s = np.linspace(0.0, z_yield, n_grid, endpoint=False)
        p_s = p_f[0] + geometry.pressure_gradient * nu_law.nu_c * (z_yield - z_s)
        z = np.concatenate([z_s, z_f])
        p = np.concatenate([p_s, p_f])
        nu = np.concatenate([np.full_like(z_s, nu_law.nu_c), nu_f])
        u = np.concatenate([np.zeros_like(z_s), u_f])
        gd = np.concatenate([np.zeros_like(z_s), gd_f])
        u[n_grid] = 0.0  # yield plane: the drop integrates to V there up to the root tolerance
    else:
        z, p, nu, u, gd = z_f, p_f, nu_f, u_f, gd_f
        u[0] = bottom_slip
        z_yield = 0.0
    return build_solution(
        MODEL, geometry, z, {"u_x": u, "shear_rate": gd, "nu": nu, "p": p, "mu": tau / p},
        converged=True, iterations=iterations, residual=residual,
        solve_seconds=time.perf_counter() - t0, n_grid=n_grid, parameters=parameters,
        extra_attrs={"tau": tau, "yield_height": z_yield, "slip_length": b, "top_wall_slip": top_slip},
    )


def _homogeneous(geometry: PlanarShear, params: LocalMuIParameters, n_grid: int,
                 parameters: dict[str, float], t0: float) -> xr.Dataset:
    """Exact solution at uniform pressure: gammadot = V / (H + 2 b) (each wall slips by b gammadot)
    and mu = mu(I) everywhere."""
    mu_law, nu_law = params.mu_i, params.solid_fraction
    z = np.linspace(0.0, geometry.depth, n_grid)
    b = geometry.slip_length
    gammadot = geometry.wall_speed / (geometry.depth + 2.0 * b)
    P = geometry.top_pressure
    if geometry.gravity != 0.0:
        raise OutOfRangeError(MODEL, "a bed at rest under gravity has no unique stress state")
    inertial = gammadot * geometry.d / np.sqrt(P / geometry.rho_s)
    if inertial >= nu_law.I_max:
        raise OutOfRangeError(MODEL, f"I = {inertial:.3g} is beyond the range of the nu(I) law")
    mu = float(mu_law.mu(inertial))
    ones = np.ones_like(z)
    return build_solution(
        MODEL, geometry, z,
        {"u_x": gammadot * (z + b), "shear_rate": gammadot * ones, "nu": float(nu_law.nu(inertial)) * ones,
         "p": P * ones, "mu": mu * ones},
        converged=True, iterations=0, residual=0.0, solve_seconds=time.perf_counter() - t0,
        n_grid=n_grid, parameters=parameters,
        extra_attrs={"tau": mu * P, "yield_height": 0.0, "slip_length": b, "top_wall_slip": b * gammadot},
    )
