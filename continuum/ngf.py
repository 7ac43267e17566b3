"""Non-local granular fluidity, NGF (Kamrin & Koval 2012; Henann & Kamrin 2013; seed eq 7).

Steady planar shear at uniform tau, with gammadot = g mu and

    A^2 d^2 g'' = |mu - mu_s| (g - g_loc),      g_loc = sqrt(p / (rho_s d^2)) (mu - mu_s) / (b mu)
                                                for mu > mu_s, else 0,

which is xi^2 g'' = g - g_loc with xi = A d / sqrt(|mu - mu_s|), multiplied through by 1 / xi^2 so
that it stays regular at mu = mu_s (where xi diverges). |mu - mu_s| is floored at
``NGFParameters.delta_mu`` (the documented cap on xi). Walls: dg/dz = 0 (zero fluidity flux, the
common choice of Henann & Kamrin). For a given tau the problem is linear in g: a tridiagonal
solve; tau is the root of int_0^H g mu dz + b (gammadot(0) + gammadot(H)) = V (brentq), b the
walls' Navier slip length (``PlanarShear.slip_length``).

NGF has no dilatancy law: the layer's weight uses a constant solid fraction ``params.nu``, and no
nu profile is returned.
"""
from __future__ import annotations

import time

import numpy as np
import xarray as xr
from scipy.linalg import solve_banded

from .errors import ConvergenceError, OutOfRangeError
from .geometry import PlanarShear
from .tolerance import wall_root
from .grid import cumulative_trapezoid, uniform_grid
from .parameters import NGFParameters
from .solution import build_solution

MODEL = "ngf"
_RTOL = 1e-10


def local_fluidity(mu: np.ndarray, p: np.ndarray, params: NGFParameters, d: float, rho_s: float) -> np.ndarray:
    """g_loc (s-1) of the linearised local law mu = mu_s + b I; zero where mu <= mu_s."""
    mu_s, b = params.mu_i.mu_s, params.mu_i.b
    excess = np.maximum(mu - mu_s, 0.0)
    return np.sqrt(p / rho_s) / d * excess / (b * mu)


def fluidity_profile(z: np.ndarray, mu: np.ndarray, p: np.ndarray, params: NGFParameters,
                     d: float, rho_s: float) -> np.ndarray:
    """Solve A^2 d^2 g'' = |mu - mu_s| (g - g_loc) with g' = 0 at both ends of a uniform grid z.

    Second-order central differences; the zero-flux condition uses a ghost node (g_-1 = g_1).
    mu and p are given on z (any profile: the planar solver passes tau / p(z), tests pass
    piecewise-constant mu).
    """
    n = z.size
    h = z[1] - z[0]
    if not np.allclose(np.diff(z), h, rtol=1e-9, atol=0.0):
        raise ValueError("fluidity_profile needs a uniform grid")
    dmu = np.maximum(np.abs(mu - params.mu_i.mu_s), params.delta_mu)
    k2 = dmu / (params.A * d) ** 2  # 1 / xi^2
    inv_h2 = 1.0 / h**2
    # zeros, not empty: solve_banded never reads bands[0, 0] or bands[2, -1], but the finiteness
    # check below does, and uninitialised memory can hold NaN.
    bands = np.zeros((3, n))
    bands[0, 1:] = inv_h2
    bands[1, :] = -2.0 * inv_h2 - k2
    bands[2, :-1] = inv_h2
    bands[0, 1] = 2.0 * inv_h2  # ghost node at the bottom wall
    bands[2, -2] = 2.0 * inv_h2  # ghost node at the top wall
    rhs = -k2 * local_fluidity(mu, p, params, d, rho_s)
    if not (np.all(np.isfinite(bands)) and np.all(np.isfinite(rhs))):
        raise ConvergenceError("ngf", float("nan"), f"the fluidity equation is not finite (A = {params.A!r}, "
                               "or a stress ratio or pressure that is not)")
    try:
        return solve_banded((1, 1), bands, rhs, overwrite_ab=True, overwrite_b=True, check_finite=False)
    except np.linalg.LinAlgError as exc:
        raise ConvergenceError("ngf", float("nan"), f"the fluidity equation is singular (A = {params.A!r}): {exc}") from None


# Deep below the shear zone g decays as exp(-z / xi); with a small A it falls below the smallest
# double. Underflow to zero is the right value there (a bed at rest), not an error.
@np.errstate(under="ignore")
def solve(geometry: PlanarShear, params: NGFParameters, n_grid: int = 200, case: str | None = None,
          max_iterations: int = 200, tolerance: float | None = None) -> xr.Dataset:
    """Steady velocity-driven planar shear with NGF.

    Returns the contract's Dataset with u_x, shear_rate, p, mu (and ``fluidity``) on a uniform
    grid of n_grid nodes; attrs include ``A``, ``tau`` (Pa), ``nu_weight``.

    max_iterations bounds the shear-stress root search (brentq iterations).

    Raises:
        ConvergenceError: the shear-stress root did not reach its tolerance.
        OutOfRangeError: no shear stress up to 10 P_wall drives the wall at the requested speed.
    """
    t0 = time.perf_counter()
    V, P = geometry.wall_speed, geometry.top_pressure
    z = uniform_grid(geometry, n_grid)
    p = P + geometry.pressure_gradient * params.nu * (geometry.depth - z)
    mu_s = params.mu_i.mu_s
    parameters = {"mu_s": mu_s, "mu_2": params.mu_i.mu_2, "I_0": params.mu_i.I_0, "A": params.A,
                  "nu_weight": params.nu, "delta_mu": params.delta_mu}

    def profile(tau: float) -> tuple[np.ndarray, np.ndarray]:
        mu = tau / p
        g = fluidity_profile(z, mu, p, params, geometry.d, geometry.rho_s)
        return mu, g * mu

    b = geometry.slip_length

    def speed_mismatch(tau: float) -> float:
        # the band's velocity drop plus each wall's Navier slip b gammadot
        _, gammadot = profile(tau)
        return (np.trapezoid(gammadot, z) + b * (gammadot[0] + gammadot[-1])) / V - 1.0

    if V == 0.0:
        raise OutOfRangeError(MODEL, "a layer at rest has no unique shear stress", case)
    # V(tau) is 0 up to tau = mu_s * min(p) (nothing above yield, g_loc = 0) and then rises.
    lo = mu_s * P
    hi = lo * 1.001
    while speed_mismatch(hi) < 0.0:
        lo, hi = hi, hi + 2.0 * (hi - mu_s * P)
        if hi > 10.0 * P:
            raise OutOfRangeError(MODEL, f"no shear stress below 10 P_wall drives the wall at {V} m/s", case)
    try:
        tau, converged, residual, iterations = wall_root(speed_mismatch, lo, hi, tolerance, _RTOL, max_iterations)
    except ValueError as exc:
        raise ConvergenceError(MODEL, np.nan, f"shear-stress root failed: {exc}", case) from exc
    mu, gammadot = profile(tau)
    if not converged or not np.all(np.isfinite(gammadot)):
        raise ConvergenceError(MODEL, residual, "wall-speed condition not met", case)
    if np.any(gammadot < 0.0):
        raise ConvergenceError(MODEL, residual, "negative fluidity: grid too coarse for xi", case)
    u = b * gammadot[0] + cumulative_trapezoid(gammadot, z)
    return build_solution(
        MODEL, geometry, z,
        {"u_x": u, "shear_rate": gammadot, "p": p, "mu": mu, "fluidity": gammadot / mu},
        converged=True, iterations=iterations, residual=residual,
        solve_seconds=time.perf_counter() - t0, n_grid=n_grid, parameters=parameters,
        extra_attrs={"tau": float(tau), "slip_length": b, "top_wall_slip": b * float(gammadot[-1])},
    )
