"""Stiffness and time-step rules for Hertz contacts in the rigid-grain limit.

The rules (stated once, recorded in every run.json):

* Stiffness: the Young's modulus E is chosen so that the *mean* contact overlap at the largest
  working pressure ``p_max`` of any case equals ``design_overlap * d``. The mean contact force
  follows from the stress of a packing (Christoffersen et al. 1981),
  ``p = Z nu <f> / (pi d^2)``, with coordination number Z and solid fraction nu; we take
  ``Z * nu = 2.7`` (Z ~ 4.5 for frictional spheres, nu ~ 0.6). Hertz:
  ``f = 4/3 E* sqrt(R*) delta^(3/2)`` with ``R* = d/4`` and ``E* = E / (2 (1 - nu_p^2))``.
  The hard bound (max overlap under ``max_overlap * d``) is checked during the run.
* Time step: ``dt = dt_over_contact_time * t_c`` with the Hertz contact time of the lightest grains
  at the largest allowed overlap (the stiffest linearised contact):
  ``t_c = pi sqrt(m* / k)``, ``m* = m_min / 2``, ``k = 2 E* sqrt(R*_min delta_max)``.

All quantities in SI units.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

#: Z * nu for a dense frictional sphere packing (coordination x solid fraction); see module doc.
COORDINATION_TIMES_SOLID_FRACTION = 2.7


@dataclass(frozen=True)
class ContactDesign:
    """Contact parameters derived from the config.

    Attributes:
        youngs_modulus: E (Pa).
        effective_modulus: E* = E / (2 (1 - nu_p^2)) for two like grains (Pa).
        p_max: largest working pressure the stiffness was designed for (Pa).
        mean_overlap_at_p_max: expected mean overlap / d at p_max (-).
        contact_time: Hertz contact time of the lightest grains at the largest allowed overlap (s).
        dt: time step (s).
    """

    youngs_modulus: float
    effective_modulus: float
    p_max: float
    mean_overlap_at_p_max: float
    contact_time: float
    dt: float

    def as_dict(self) -> dict[str, float]:
        return asdict(self)


def mean_contact_force(pressure: float, d: float) -> float:
    """Mean normal contact force (N) in a dense packing at mean stress ``pressure`` (Pa)."""
    return math.pi * d * d * pressure / COORDINATION_TIMES_SOLID_FRACTION


def hertz_effective_modulus(youngs_modulus: float, poisson_ratio: float) -> float:
    """E* (Pa) of two grains of the same material."""
    return youngs_modulus / (2.0 * (1.0 - poisson_ratio**2))


def youngs_modulus_for_overlap(pressure: float, d: float, poisson_ratio: float, overlap: float) -> float:
    """Young's modulus (Pa) giving a mean overlap ``overlap * d`` at ``pressure`` (Pa)."""
    if not 0.0 < overlap < 0.1:
        raise ValueError(f"design overlap must be in (0, 0.1) of d, got {overlap!r}")
    force = mean_contact_force(pressure, d)
    r_eff = d / 4.0
    delta = overlap * d
    e_star = 3.0 * force / (4.0 * math.sqrt(r_eff) * delta**1.5)
    return e_star * 2.0 * (1.0 - poisson_ratio**2)


def hertz_contact_time(e_star: float, d: float, rho_s: float, overlap: float) -> float:
    """Contact time (s) of two grains of diameter d (m) linearised at overlap ``overlap * d``."""
    r_eff = d / 4.0
    stiffness = 2.0 * e_star * math.sqrt(r_eff * overlap * d)
    mass = rho_s * math.pi * d**3 / 6.0
    return math.pi * math.sqrt(0.5 * mass / stiffness)


def design_contacts(
    *,
    p_max: float,
    d: float,
    polydispersity: float,
    rho_s: float,
    poisson_ratio: float,
    design_overlap: float,
    max_overlap: float,
    dt_over_contact_time: float,
) -> ContactDesign:
    """Apply the stiffness and time-step rules of the module docstring."""
    if not 0.0 < dt_over_contact_time <= 0.05:
        raise ValueError(
            f"dt_over_contact_time={dt_over_contact_time!r}: the time step must be at most a "
            "twentieth of the Hertz contact time"
        )
    if not design_overlap < max_overlap:
        raise ValueError(f"design_overlap={design_overlap!r} must be below max_overlap={max_overlap!r}")
    youngs = youngs_modulus_for_overlap(p_max, d, poisson_ratio, design_overlap)
    e_star = hertz_effective_modulus(youngs, poisson_ratio)
    d_min = d * (1.0 - polydispersity)
    t_c = hertz_contact_time(e_star, d_min, rho_s, max_overlap * d / d_min)
    return ContactDesign(
        youngs_modulus=youngs,
        effective_modulus=e_star,
        p_max=p_max,
        mean_overlap_at_p_max=design_overlap,
        contact_time=t_c,
        dt=dt_over_contact_time * t_c,
    )


def contact_design(config: dict[str, Any]) -> ContactDesign:
    """The one contact design shared by all cases, so the calibration transfers between them.

    It depends on the material section only (``design_pressure`` sets the stiffness), never on
    the other cases of the config: a DEM run reads a config that holds its own case alone.
    """
    mat = config["material"]
    return design_contacts(
        p_max=mat["design_pressure"],
        d=mat["d"],
        polydispersity=mat["polydispersity"],
        rho_s=mat["rho_s"],
        poisson_ratio=mat["poisson_ratio"],
        design_overlap=mat["design_overlap"],
        max_overlap=mat["max_overlap"],
        dt_over_contact_time=mat["dt_over_contact_time"],
    )
