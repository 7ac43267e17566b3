"""Cosserat plasticity (Mohan, Nott & Rao 1999; Mohan, Rao & Nott 2002; seed eqs 5-6), planar 1D.

Fields: velocity u(z) e_x, grain spin omega(z) e_y, shear stresses on z-planes s + t (uniform,
= tau) and on x-planes s - t (s symmetric, t antisymmetric part), couple stress M = M_zy.
Steady flow is at the critical state (alpha = 1: nu = nu_cs(p), yield stress Y = sin_phi p).
The derivation is in docs/models.md ("Cosserat"); the equations solved are

    yield:      s^2 + beta t^2 + M^2 / l^2 = Y(z)^2,       s = tau - t
    moments:    dM/dz = -2 t
    flow rule:  gammadot = lambda s / Y,  gammadot - 2 omega = lambda beta t / Y,
                d omega / dz = lambda M / (l^2 Y)

so t(M, z) is the small root of (1 + beta) t^2 - 2 tau t + tau^2 - Y^2 + M^2 / l^2 = 0, the
couple stress obeys the Riccati equation dM/dz = -2 t(M, z), and with A = 1 - beta t / s and
q = gammadot A = 2 omega the kinematics reduce to d ln q / dz = 2 M / (l^2 s A).

Walls: Navier slip b gammadot (``PlanarShear.slip_length``; 0 is no slip), and the grain spin is chi_w times the vorticity gammadot / 2 (``wall_spin_ratio``),
i.e. A = chi_w, which fixes t and s at the wall and, by the yield condition, |M|. The couple stress
is positive at the bottom wall and negative at the top wall (the two walls exert the same couple
traction on the layer; in a uniform layer the solution is then symmetric). tau is the root of
M(H; tau) = M_top(tau) with M integrated upwards from the bottom wall (trapezoidal rule, Newton
on each step: the direction in which the bulk branch M = l sqrt(Y^2 - tau^2) is stable).
In the bulk the shear rate decays downwards with length xi = l mu / (2 sqrt(sin_phi^2 - mu^2)).
"""
from __future__ import annotations

import math
import time

import numpy as np
import xarray as xr

from .critical_state import parameter_attrs
from .errors import ConvergenceError, OutOfRangeError
from .geometry import PlanarShear
from .tolerance import wall_root
from .grid import cumulative_trapezoid, hydrostatic_pressure, uniform_grid
from .packing import critical_packing
from .parameters import CosseratParameters
from .solution import build_solution

MODEL = "cosserat"
_RTOL = 1e-10


class _Inadmissible(Exception):
    """The couple stress left the range where a stress state on the yield surface exists."""


def _wall_state(tau: float, Y: float, params: CosseratParameters) -> tuple[float, float, float]:
    """(s, t, |M|) at a wall where A = 1 - beta t / s = chi_w."""
    beta, chi = params.beta, params.wall_spin_ratio
    t = tau * (1.0 - chi) / (beta + 1.0 - chi)
    s = tau - t
    m2 = params.l**2 * (Y**2 - s**2 - beta * t**2)
    if m2 < 0.0:
        raise _Inadmissible
    return s, t, math.sqrt(m2)


def _antisymmetric(tau: float, M: np.ndarray | float, Y: np.ndarray | float, params: CosseratParameters):
    """Small root t of (1 + beta) t^2 - 2 tau t + tau^2 - Y^2 + M^2 / l^2 = 0 and sqrt(disc)."""
    beta, l = params.beta, params.l
    disc = (1.0 + beta) * (Y**2 - M**2 / l**2) - beta * tau**2
    root = np.sqrt(np.maximum(disc, 0.0))
    return (tau - root) / (1.0 + beta), root, disc


def _shoot(tau: float, z: np.ndarray, Y: np.ndarray, params: CosseratParameters) -> np.ndarray:
    """Couple stress M(z) integrated upwards from the bottom wall (implicit trapezoidal rule).

    The shooting is most of a Cosserat solve's time (a root in tau takes about 20 shots) and of
    the calibration's non-local fits, so the step is written out in scalars: the same operations
    in the same order as the plain form (f = -2 (tau - sqrt(disc)) / (1 + beta), below), so the
    same bits, at about half its time (docs/dem_cost.md 30)."""
    beta, l2 = params.beta, params.l**2
    onep = 1.0 + beta
    Ys = Y.tolist()
    h = float(z[1] - z[0])
    out = [0.0] * z.size
    _, _, m = _wall_state(tau, Ys[0], params)
    out[0] = m
    sqrt = math.sqrt
    btt = beta * tau * tau
    # f(M, Y) = -2 (tau - sqrt(disc)) / (1 + beta), disc = (1 + beta) (Y^2 - M^2 / l^2) - beta tau^2
    disc = onep * (Ys[0] * Ys[0] - m * m / l2) - btt
    if disc <= 0.0:
        raise _Inadmissible
    f0 = -2.0 * (tau - sqrt(disc)) / onep
    k = h / onep
    kk = k * k
    ktau = k * tau
    a = 1.0 + kk * onep / l2
    for j in range(1, z.size):
        y1 = Ys[j]
        # Trapezoidal step M1 = m + h/2 (f0 + f(M1)): M1 - c = k sqrt(disc(M1)),
        # c = m + h f0 / 2 - k tau, which squared is a quadratic in M1. Its roots with M1 >= c
        # solve the step; take the one nearest the explicit predictor (the first on a tie).
        c = m + 0.5 * h * f0 - ktau
        big_r = onep * y1 * y1 - btt
        disc_q = c * c - a * (c * c - kk * big_r)
        if disc_q < 0.0:
            raise _Inadmissible
        sq = sqrt(disc_q)
        low, high = (c - sq) / a, (c + sq) / a
        floor = -1e-14 * abs(c)
        low_ok, high_ok = low - c >= floor, high - c >= floor
        if low_ok and high_ok:
            predictor = m + h * f0
            m = low if abs(low - predictor) <= abs(high - predictor) else high
        elif low_ok:
            m = low
        elif high_ok:
            m = high
        else:
            raise _Inadmissible
        disc = onep * (y1 * y1 - m * m / l2) - btt
        if disc <= 0.0:
            raise _Inadmissible
        f0 = -2.0 * (tau - sqrt(disc)) / onep
        out[j] = m
    return np.array(out)


def solve(geometry: PlanarShear, params: CosseratParameters, n_grid: int = 400, case: str | None = None,
          max_iterations: int = 200, tolerance: float | None = None) -> xr.Dataset:
    """Steady velocity-driven planar shear with Cosserat plasticity at the critical state.

    Returns the contract's Dataset with u_x, shear_rate, nu (= nu_cs(p)), p, mu and ``spin``
    on a uniform grid; attrs ``l`` (m), ``beta``, ``wall_spin_ratio``, ``tau`` (Pa).
    """
    t0 = time.perf_counter()
    cs = params.critical
    z = uniform_grid(geometry, n_grid)
    nu = critical_packing(z, geometry, cs.line)
    p = hydrostatic_pressure(z, nu, geometry)
    Y = cs.sin_phi * p
    V = geometry.wall_speed
    if V <= 0.0:
        raise OutOfRangeError(MODEL, "a layer at rest has no unique shear stress", case)

    def mismatch(tau: float) -> float:
        """M(H) - M_top in units of l Y(H); inadmissible shots count as overshooting (M too low)."""
        scale = params.l * Y[-1]
        try:
            _, _, m_top = _wall_state(tau, Y[-1], params)
            m = _shoot(tau, z, Y, params)
        except _Inadmissible:
            return -10.0
        return (m[-1] + m_top) / scale

    # Bracket: at tau well under Y_top the bulk branch reaches the top with M > 0 (positive
    # mismatch); the largest admissible tau has the top wall state at the edge of the yield
    # surface.
    q = (params.beta**2 + params.beta * (1 - params.wall_spin_ratio) ** 2) / (params.beta + 1 - params.wall_spin_ratio) ** 2
    tau_max = Y[-1] / math.sqrt(q) * (1.0 - 1e-12)
    lo, hi = 0.5 * Y[-1], tau_max
    f_lo = mismatch(lo)
    while f_lo <= 0.0:
        lo *= 0.5
        f_lo = mismatch(lo)
        if lo < 1e-6 * Y[-1]:
            raise ConvergenceError(MODEL, np.nan, "could not bracket the shear stress", case)
    if mismatch(hi) >= 0.0:
        raise ConvergenceError(MODEL, np.nan, "no shear stress meets the top-wall spin condition", case)
    tau, converged, residual, iterations = wall_root(mismatch, lo, hi, tolerance, 1e-8, max_iterations)
    if not converged:
        raise ConvergenceError(MODEL, residual, "couple-stress boundary conditions not met", case)

    M = _shoot(tau, z, Y, params)
    t, _, _ = _antisymmetric(tau, M, Y, params)
    s = tau - t
    A = 1.0 - params.beta * t / s
    if np.any(A <= 0.0) or np.any(s <= 0.0):
        raise ConvergenceError(MODEL, residual, "spin ratio A = 1 - beta t / s left (0, inf)", case)
    log_q = cumulative_trapezoid(2.0 * M / (params.l**2 * s * A), z)
    x = log_q - log_q[-1]
    # below e^-600 of the top value the creep is set to exactly 0 (no subnormal underflow)
    shape = np.where(x < -600.0, 0.0, np.exp(np.maximum(x, -600.0))) / A
    # The stress state is rate-independent; the walls' Navier slip (b gammadot at each) only
    # shares the wall speed between the band and the two walls.
    b = geometry.slip_length
    scale = V / (np.trapezoid(shape, z) + b * (shape[0] + shape[-1]))
    gammadot = scale * shape
    u = b * gammadot[0] + cumulative_trapezoid(gammadot, z)
    residual_u = abs((u[-1] + b * gammadot[-1]) / V - 1.0)
    if residual_u > _RTOL:
        raise ConvergenceError(MODEL, residual_u, "wall speed not met", case)
    attrs = parameter_attrs(cs)
    attrs.update({"l": params.l, "beta": params.beta, "wall_spin_ratio": params.wall_spin_ratio})
    return build_solution(
        MODEL, geometry, z,
        {"u_x": u, "shear_rate": gammadot, "nu": nu, "p": p, "mu": tau / p, "spin": 0.5 * gammadot * A},
        converged=True, iterations=iterations, residual=residual,
        solve_seconds=time.perf_counter() - t0, n_grid=n_grid, parameters=attrs,
        extra_attrs={"tau": float(tau), "slip_length": b, "top_wall_slip": b * float(gammadot[-1])},
    )
