"""Geometry and loading of a planar shear cell, shared by every continuum model.

Conventions used throughout ``continuum``: flow direction x, gradient direction z (pointing up,
from the fixed bottom wall at z = 0 to the moving top wall at z = depth), vorticity direction y;
gravity acts along -z. Stresses are compressive positive: the pressure ``p`` is one third of the
trace of the stress and is positive in a confined granular bed. SI units everywhere.
"""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class PlanarShear:
    """A layer of grains sheared between two rough parallel walls.

    Attributes:
        depth: distance between the bottom and top walls, H (m).
        wall_speed: speed V of the top wall along +x (m s-1); the bottom wall is at rest.
        wall_pressure: normal stress P_wall the top wall applies to the layer (Pa, compressive
            positive).
        gravity: magnitude g of gravity along -z (m s-2); 0 for the homogeneous rheometer.
        d: mean grain diameter (m).
        rho_s: grain material density (kg m-3).
        normal_stress_ratio: sigma_zz / p, the normal stress on the shear planes over the mean
            normal stress (one third of the trace). The momentum balance fixes sigma_zz(z) (wall
            load plus weight); the models' constitutive laws are written in p, as mu(I) is, so
            p = sigma_zz / normal_stress_ratio. 1 means no normal-stress differences; a DEM
            value is measured on the rheometer (taken independent of depth and I).
        slip_length: Navier slip length b of both walls (m, >= 0): the grains next to a wall move
            relative to it by b times the shear rate there, u(H) = V - b gammadot(H) at the top and
            u(0) = b gammadot(0) at the bottom (the rough DEM wall's velocity jump at its contact
            plane, docs/models.md "The wall"). 0 is no slip. A rate-independent model whose
            shear concentrates in a band of zero width has no finite wall shear rate: there the
            band is the slip, and b changes nothing.
    """

    depth: float
    wall_speed: float
    wall_pressure: float
    gravity: float
    d: float
    rho_s: float
    normal_stress_ratio: float = 1.0
    slip_length: float = 0.0

    @property
    def top_pressure(self) -> float:
        """Mean normal stress p (Pa) under the top wall: P_wall / normal_stress_ratio."""
        return self.wall_pressure / self.normal_stress_ratio

    @property
    def pressure_gradient(self) -> float:
        """dp / d(depth) per unit solid fraction (Pa m-1): g rho_s / normal_stress_ratio."""
        return self.gravity * self.rho_s / self.normal_stress_ratio

    def __post_init__(self) -> None:
        for name in ("depth", "wall_pressure", "d", "rho_s"):
            value = getattr(self, name)
            if not value > 0.0:
                raise ValueError(f"PlanarShear.{name} must be positive, got {value!r}")
        if self.gravity < 0.0:
            raise ValueError(f"PlanarShear.gravity is a magnitude (acts along -z), got {self.gravity!r}")
        if self.wall_speed < 0.0:
            raise ValueError(f"PlanarShear.wall_speed must be >= 0 (top wall moves along +x), got {self.wall_speed!r}")
        if not 0.5 < self.normal_stress_ratio < 2.0:
            raise ValueError(f"PlanarShear.normal_stress_ratio (sigma_zz / p) = {self.normal_stress_ratio!r} is "
                             "outside (0.5, 2): not a dense granular flow")
        if not 0.0 <= self.slip_length < self.depth:
            raise ValueError(f"PlanarShear.slip_length = {self.slip_length!r} m must be >= 0 and below the depth")
        if self.depth < 2.0 * self.d:
            raise ValueError(f"PlanarShear.depth={self.depth!r} m is under two grain diameters (d={self.d!r} m)")
