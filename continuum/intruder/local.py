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
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import xarray as xr

from ..geometry import PlanarShear
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
