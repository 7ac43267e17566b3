"""The walls' Navier slip (``PlanarShear.slip_length``) in every 1D planar model.

The law: the grains at a wall move relative to it by b times the shear rate there, u(H) = V - b
gammadot(H), u(0) = b gammadot(0). A rate-dependent model's stress is the one whose band carries
the wall speed less the slips; a rate-independent model's stress does not move.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from continuum import cosserat, critical_state, local_mu_i, ngf, volume_averaged
from continuum.parameters import CosseratParameters, VolumeAveragedParameters

from .conftest import D, shear_gravity

B = 0.45 * D  # the rheometer's order of magnitude (issue 54)


def with_slip(geo, b=B):
    return dataclasses.replace(geo, slip_length=b)


def test_homogeneous_shear_slips_at_both_walls(local_params):
    # Exact: gammadot (H + 2 b) = V, u = gammadot (z + b)
    geo = with_slip(shear_gravity(wall_speed_factor=0.3, gravity=0.0))
    ds = local_mu_i.solve(geo, local_params, n_grid=51)
    gammadot = geo.wall_speed / (geo.depth + 2 * B)
    np.testing.assert_allclose(ds.shear_rate, gammadot, rtol=1e-13)
    assert float(ds.u_x[0]) == pytest.approx(B * gammadot, rel=1e-12)
    assert float(ds.u_x[-1]) == pytest.approx(geo.wall_speed - B * gammadot, rel=1e-12)


def _navier_residuals(ds, geo):
    u, gd = ds.u_x.values, ds.shear_rate.values
    top = (u[-1] + geo.slip_length * gd[-1]) / geo.wall_speed - 1.0
    bottom = (u[0] - geo.slip_length * gd[0]) / geo.wall_speed
    return top, bottom


@pytest.mark.parametrize("model", ["local_mu_i", "ngf", "cosserat", "volume_averaged"])
def test_gravity_bed_obeys_the_navier_law_at_both_walls(model, local_params, ngf_params, cs_params):
    geo = with_slip(shear_gravity(wall_speed_factor=0.3))
    solver, params = {
        "local_mu_i": (local_mu_i.solve, local_params), "ngf": (ngf.solve, ngf_params),
        "cosserat": (cosserat.solve, CosseratParameters(cs_params, l=1.0 * D)),
        "volume_averaged": (volume_averaged.solve, VolumeAveragedParameters(cs_params, 1.5 * D)),
    }[model]
    ds = solver(geo, params, n_grid=801)
    top, bottom = _navier_residuals(ds, geo)
    # the wall speed condition is met to the root's tolerance (1e-10) or, where u is a trapezoid
    # integral of a resolved profile, to its O(h^2) error
    assert abs(top) < 1e-6 and abs(bottom) < 1e-9
    # the wall really slips: a visible share of V, not round-off
    assert float(ds.attrs["top_wall_slip"]) / geo.wall_speed > 0.02


@pytest.mark.parametrize("model", ["local_mu_i", "ngf"])
def test_rate_dependent_stress_is_the_no_slip_stress_at_the_band_speed(model, local_params, ngf_params):
    # Slips s_top and s_bottom leave the band V - s_top - s_bottom: the no-slip solution at that
    # wall speed has the same shear stress.
    solver, params = {"local_mu_i": (local_mu_i.solve, local_params), "ngf": (ngf.solve, ngf_params)}[model]
    base = shear_gravity(wall_speed_factor=0.3)
    slipping = solver(with_slip(base), params, n_grid=801)
    slips = float(slipping.attrs["top_wall_slip"]) + B * float(slipping.shear_rate.values[0])
    band = dataclasses.replace(base, wall_speed=base.wall_speed - slips)
    reference = solver(band, params, n_grid=801)
    assert float(slipping.attrs["tau"]) == pytest.approx(float(reference.attrs["tau"]), rel=1e-7)
    assert float(slipping.attrs["tau"]) < float(solver(base, params, n_grid=801).attrs["tau"])


def test_rate_independent_stress_does_not_move(cs_params):
    base = shear_gravity(wall_speed_factor=0.3)
    params = CosseratParameters(cs_params, l=1.0 * D)
    assert cosserat.solve(with_slip(base), params, n_grid=401).attrs["tau"] == pytest.approx(
        cosserat.solve(base, params, n_grid=401).attrs["tau"], rel=1e-12)
    a, b = critical_state.solve(with_slip(base), cs_params), critical_state.solve(base, cs_params)
    assert a.attrs["tau"] == b.attrs["tau"]
    np.testing.assert_array_equal(a.u_x.values, b.u_x.values)


@pytest.mark.parametrize("bad", [-1e-4, 1.0])
def test_slip_length_out_of_range_is_refused(bad):
    with pytest.raises(ValueError, match="slip_length"):
        with_slip(shear_gravity(), bad)
