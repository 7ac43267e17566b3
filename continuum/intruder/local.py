"""Models without a 2D solve here: the yield-force check of the local models and the kinematic
rod speed of the volume-averaged model (derivations in docs/intruder.md).

Yield force of the rod in a Coulomb material (sin phi = mu_s for mu(I), sin_phi for the
critical-state models; plane strain, so the tensorial yield |T'| / sqrt 2 = sin phi p is
Mohr-Coulomb with that sin phi), the smaller of two upper-bound estimates:
- bearing: Broms (1964) lateral resistance of a deep rigid pile in cohesionless soil,
  F_b = 3 K_p p(z_i) D, K_p = (1 + sin phi) / (1 - sin phi) (uncertain to about +-50 %);
- layer sliding in the periodic cell: the rod pushes the whole layer above the plane tangent to
  its bottom, whose mean shear stress becomes tau + F / L_x, so
  F_l = L_x (sin phi p(z_i - D/2) - tau). With L_x = 16 d this is the smaller one by ~10x.

Above F_l the rod slides the layer under it. For the rate-dependent mu(I) that mechanism has a
speed (``layer_sliding_speed``): the rod, smeared over the cell's length, adds F / L_x to the
shear stress below its axis, tau(z) = tau_top + (F / L_x) [z < z_i]; every height then shears
at gammadot = I(tau / p) sqrt(p / rho_s) / d, the top-wall stress tau_top is set by u(H) = V
(with the walls' Navier slip b = ``PlanarShear.slip_length``: u(0) = b gammadot(0) and
u(H) = V - b gammadot(H)), and the rod moves with the material at its height, U = u(z_i) averaged
over its disc. The rate-independent models (critical state, the volume-averaged model) have no
such speed.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import xarray as xr
from scipy.integrate import cumulative_trapezoid
from scipy.optimize import brentq

from ..errors import OutOfRangeError
from ..geometry import PlanarShear
from ..parameters import MuIParameters
from .scene import RodIntruder, disc_average


@dataclass(frozen=True)
class YieldForce:
    """Estimates of the force per length that moves the rod with the bed otherwise rigid (N m-1)."""

    bearing: float
    layer_sliding: float

    @property
    def value(self) -> float:
        return min(self.bearing, self.layer_sliding)


def yield_force(planar: xr.Dataset, sin_phi: float, rod: RodIntruder, cell_length_x: float) -> YieldForce:
    """Yield-force estimates from a 1D planar solution (needs ``p`` on z and the ``tau`` attribute)."""
    z, p = planar.z.values, planar.p.values
    k_p = (1.0 + sin_phi) / (1.0 - sin_phi)
    p_centre = float(np.interp(rod.depth_from_bottom, z, p))
    p_below = float(np.interp(rod.depth_from_bottom - rod.radius, z, p))
    tau = float(planar.attrs["tau"])
    return YieldForce(bearing=3.0 * k_p * p_centre * rod.diameter,
                      layer_sliding=cell_length_x * (sin_phi * p_below - tau))


def rod_in_static_zone(planar: xr.Dataset, rod: RodIntruder) -> bool:
    """True when the 1D solution has u_x = 0 over the rod's whole height (local models)."""
    z, u = planar.z.values, planar.u_x.values
    span = (z >= rod.depth_from_bottom - rod.radius) & (z <= rod.depth_from_bottom + rod.radius)
    top = float(np.interp(rod.depth_from_bottom + rod.radius, z, u))
    return bool(np.all(u[span] == 0.0) and top == 0.0)


def kinematic_speed(planar: xr.Dataset, rod: RodIntruder) -> float:
    """Volume-averaged model: the rod is carried by the creep, U = disc average of the 1D u_x."""
    return disc_average(planar.z.values, planar.u_x.values, rod.depth_from_bottom, rod.radius)


def check_geometry(geometry: PlanarShear, rod: RodIntruder, cell_length_x: float) -> None:
    rod.check_inside(geometry, cell_length_x)


def layer_sliding_speed(planar: xr.Dataset, mu_i: MuIParameters, geometry: PlanarShear, rod: RodIntruder,
                        cell_length_x: float, case: str | None = None) -> tuple[float, float]:
    """Rod speed U (m s-1) of local mu(I) with the rod smeared into a layer (module docstring), and
    the top-wall shear stress tau_top (Pa) that keeps u(H) = V - b gammadot(H) (b the walls' slip
    length; the bottom wall's slip b gammadot(0) starts u).

    The pressure profile is the 1D solution's (the push does not change the vertical balance; the
    change of nu with I under the extra stress is neglected). With F = 0 this is the 1D solution.
    """
    z = planar.z.values
    p = planar.p.values
    jump = rod.force_per_length / cell_length_x
    below = z < rod.depth_from_bottom
    scale = np.sqrt(p / geometry.rho_s) / geometry.d
    b = geometry.slip_length

    def rate(tau_top: float) -> np.ndarray:
        mu = (tau_top + jump * below) / p
        if np.any(np.abs(mu) >= mu_i.mu_2):
            raise OverflowError
        # mu(I) is isotropic: the shear rate takes the sign of the shear stress.
        return np.sign(mu) * mu_i.inertial_number(np.abs(mu)) * scale

    def velocity(gammadot: np.ndarray) -> np.ndarray:
        # the bottom wall's Navier slip b gammadot(0) starts the profile
        return b * gammadot[0] + cumulative_trapezoid(gammadot, z, initial=0.0)

    def mismatch(tau_top: float) -> float:
        try:
            gammadot = rate(tau_top)
        except OverflowError:
            return np.inf if tau_top > 0.0 else -np.inf
        # u(H) + b gammadot(H) = V: the top wall's Navier slip
        return float(velocity(gammadot)[-1]) + b * float(gammadot[-1]) - geometry.wall_speed

    # tau_top may be negative (the top wall holds back a plug the rod drives); every height must
    # stay below mu_2 p, which bounds it on both sides.
    limit_above = mu_i.mu_2 * float(p[~below].min())
    limit_below = mu_i.mu_2 * float(p[below].min()) if below.any() else np.inf
    lo = (1.0 - 1e-9) * max(-limit_above, -limit_below - jump)
    hi = (1.0 - 1e-9) * min(limit_above, limit_below - jump)
    if not (hi > lo and mismatch(lo) < 0.0 < mismatch(hi)):
        raise OutOfRangeError("local_mu_i", f"F / L_x = {jump:.3g} Pa: no top-wall stress within mu_2 p gives the "
                              f"wall speed (the layer under the rod cannot carry the push)", case)
    tau_top = brentq(mismatch, lo, hi, xtol=1e-12, rtol=1e-12)
    speed = disc_average(z, velocity(rate(tau_top)), rod.depth_from_bottom, rod.radius)
    return speed, tau_top
