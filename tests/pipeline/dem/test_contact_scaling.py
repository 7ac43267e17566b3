"""The stiffness and time-step rules invert the Hertz law they are built on."""
from __future__ import annotations

import math

import pytest

from pipeline.dem.contact_scaling import (
    design_contacts,
    hertz_contact_time,
    hertz_effective_modulus,
    mean_contact_force,
    youngs_modulus_for_overlap,
)


def test_designed_modulus_gives_the_design_overlap_back() -> None:
    d, p, nu_p, overlap = 0.002, 500.0, 0.3, 1e-3
    e_star = hertz_effective_modulus(youngs_modulus_for_overlap(p, d, nu_p, overlap), nu_p)
    force = mean_contact_force(p, d)
    # Hertz: f = 4/3 E* sqrt(R*) delta^3/2 with R* = d/4; solve for delta.
    delta = (3.0 * force / (4.0 * e_star * math.sqrt(d / 4.0))) ** (2.0 / 3.0)
    assert delta / d == pytest.approx(overlap, rel=1e-12)


def test_contact_time_scaling_with_overlap_and_mass() -> None:
    # Linearised Hertz: t_c ~ sqrt(m / k), k ~ sqrt(delta) -> t_c ~ delta^(-1/4), ~ rho^(1/2).
    t1 = hertz_contact_time(1e7, 0.002, 2500.0, 1e-3)
    assert hertz_contact_time(1e7, 0.002, 2500.0, 16e-3) == pytest.approx(t1 / 2.0, rel=1e-12)
    assert hertz_contact_time(1e7, 0.002, 4 * 2500.0, 1e-3) == pytest.approx(2.0 * t1, rel=1e-12)


def test_time_step_rule_and_bounds() -> None:
    kw = dict(p_max=800.0, d=0.002, polydispersity=0.2, rho_s=2500.0, poisson_ratio=0.3,
              design_overlap=1e-3, max_overlap=1e-2)
    design = design_contacts(dt_over_contact_time=0.04, **kw)
    assert design.dt == pytest.approx(0.04 * design.contact_time)
    assert design.dt <= design.contact_time / 20.0
    with pytest.raises(ValueError, match="twentieth"):
        design_contacts(dt_over_contact_time=0.1, **kw)
    with pytest.raises(ValueError, match="design_overlap"):
        design_contacts(dt_over_contact_time=0.04, **(kw | {"design_overlap": 0.02}))
