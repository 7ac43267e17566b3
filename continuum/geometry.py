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
    """

    depth: float
    wall_speed: float
    wall_pressure: float
    gravity: float
    d: float
    rho_s: float

    def __post_init__(self) -> None:
        for name in ("depth", "wall_pressure", "d", "rho_s"):
            value = getattr(self, name)
            if not value > 0.0:
                raise ValueError(f"PlanarShear.{name} must be positive, got {value!r}")
        if self.gravity < 0.0:
            raise ValueError(f"PlanarShear.gravity is a magnitude (acts along -z), got {self.gravity!r}")
        if self.wall_speed < 0.0:
            raise ValueError(f"PlanarShear.wall_speed must be >= 0 (top wall moves along +x), got {self.wall_speed!r}")
        if self.depth < 2.0 * self.d:
            raise ValueError(f"PlanarShear.depth={self.depth!r} m is under two grain diameters (d={self.d!r} m)")
