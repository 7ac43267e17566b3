"""Local critical-state plasticity: yield at the weakest plane, rigid elsewhere."""
from __future__ import annotations

import numpy as np
import pytest

from continuum import critical_state
from continuum.errors import ConvergenceError

from .conftest import shear_gravity


def test_critical_packing_shears_in_a_band_at_the_top_wall(cs_params):
    geo = shear_gravity()
    ds = critical_state.solve(geo, cs_params, n_grid=101)
    # alpha = 1 everywhere, so the strength sin_phi p(z) is least at the top wall
    assert ds.attrs["tau"] == pytest.approx(cs_params.sin_phi * geo.wall_pressure, rel=1e-12)
    assert ds.attrs["shear_band_height"] == pytest.approx(geo.depth)
    assert np.all(ds.u_x.values[:-1] == 0.0) and ds.u_x.values[-1] == geo.wall_speed
    assert "shear_rate" not in ds  # a Dirac mass, not a profile
    assert np.all(ds.mu.values[:-1] < cs_params.sin_phi)
    # the packing is the critical one at the local pressure
    np.testing.assert_allclose(ds.nu, cs_params.line.nu_cs(ds.p.values), rtol=1e-12)


def test_dense_packing_dilates_only_the_band(cs_params):
    geo = shear_gravity()
    ds = critical_state.solve(geo, cs_params, n_grid=101, nu_initial=lambda z: np.full_like(z, 0.62))
    assert ds.nu.values[-1] == pytest.approx(float(cs_params.line.nu_cs(geo.wall_pressure)), rel=1e-12)
    assert np.all(ds.nu.values[:-1] == 0.62)  # rigid planes keep their packing
    assert ds.attrs["tau"] == pytest.approx(cs_params.sin_phi * geo.wall_pressure, rel=1e-12)


def test_uniform_pressure_leaves_velocity_undetermined(cs_params):
    ds = critical_state.solve(shear_gravity(gravity=0.0), cs_params, n_grid=51)
    assert ds.attrs["velocity_determined"] == 0
    assert "u_x" not in ds
    np.testing.assert_allclose(ds.mu, cs_params.sin_phi, rtol=1e-12)


def test_evolution_limit_raises(cs_params):
    # a loose packing compacts plane by plane: 2 events cannot reach the steady state
    with pytest.raises(ConvergenceError, match="critical_state.*residual"):
        critical_state.solve(shear_gravity(), cs_params, n_grid=51,
                             nu_initial=lambda z: np.full_like(z, 0.58), max_iterations=2)
