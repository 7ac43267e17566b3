"""A converged 2D solve's fields rebuilt from its state (continuum.intruder.api.intruder_fields): the
solve's own numbers bit for bit, the rod's rigid motion on its cells, the stresses and the solid
fraction of each model. Small bed: 12 d, cell 8 d, 2 cells per d, rod 3 d at 4 d, 0.8 N/m; NGF, local
mu(I) and Cosserat (the framework's fixed point, the Newton solves, the Newton solve with the spin)."""
from __future__ import annotations

import numpy as np
import pytest

from continuum.geometry import PlanarShear
from continuum.intruder import GridOptions, RodIntruder, intruder_speed
from continuum.intruder.api import intruder_fields
from continuum.intruder.mac import MacGrid, rod_mask
from continuum.parameters import (CosseratParameters, CriticalStateLine, CriticalStateParameters, LocalMuIParameters,
                                  MuIParameters, NGFParameters, SolidFractionLaw)

D = 0.002
GEO = PlanarShear(depth=12 * D, wall_speed=0.1, wall_pressure=200.0, gravity=9.81, d=D, rho_s=2500.0,
                  normal_stress_ratio=1.058)
LX = 8 * D
MU = MuIParameters(0.374, 1.023, 0.637)
PARAMS = {"ngf": NGFParameters(MU, A=0.327, nu=0.587),
          "local_mu_i": LocalMuIParameters(MU, SolidFractionLaw(0.5868, 0.141)),
          "cosserat": CosseratParameters(CriticalStateParameters(0.374, CriticalStateLine(0.5868, 0.005, 300.0)),
                                         1.94 * D)}
ROD = RodIntruder.below_top(GEO, 3 * D, 4 * D, 0.8)
GRID = GridOptions(cells_per_d=2)


@pytest.fixture(scope="module")
def solves():
    return {m: intruder_speed(m, GEO, p, ROD, LX, GRID) for m, p in PARAMS.items()}


@pytest.mark.parametrize("model", sorted(PARAMS))
def test_the_fields_of_a_state_are_the_solve_s_own(model: str, solves) -> None:
    result = solves[model]
    ds = intruder_fields(model, GEO, PARAMS[model], ROD, LX, GRID, result.state)
    for name in result.fields.data_vars:
        np.testing.assert_array_equal(ds[name].values, result.fields[name].values, err_msg=name)
    assert ds.attrs["rod_speed"] == result.speed
    for name in ("sigma_xx", "sigma_zz", "sigma_xz", "mu_xz"):
        assert ds[name].attrs["units"] and ds[name].attrs["long_name"]
    # Compressive positive, as the DEM's: the wall drives +x above the rod, so sigma_xz < 0 there;
    # the normal stresses are the pressure's order; |sigma_xz| / p is at most the full stress ratio.
    top = ds.isel(z=-1)
    assert float(top.sigma_xz.mean()) < 0.0
    assert np.nanmin(ds.sigma_zz.values) > 0.0 and np.nanmin(ds.sigma_xx.values) > 0.0
    assert np.all(ds.mu_xz.values[np.isfinite(ds.mu.values)] <= ds.mu.values[np.isfinite(ds.mu.values)] + 1e-12)


@pytest.mark.parametrize("model", sorted(PARAMS))
def test_the_rod_moves_rigidly_in_its_fields(model: str, solves) -> None:
    """On the cells all of whose faces are the rod's, u_x is the rod's speed and u_z zero (to round-off:
    the Newton solves carry the rod's faces as unknowns, 1e-28 m/s off)."""
    ds = intruder_fields(model, GEO, PARAMS[model], ROD, LX, GRID, solves[model].state)
    nx, nz = ds.sizes["x"], ds.sizes["z"]
    pinned = rod_mask(MacGrid(nx, nz, LX / nx, GEO.depth / nz), ROD, 0.5 * LX).pinned_cells.reshape(nz, nx)
    assert pinned.sum() >= 4
    assert np.abs(ds.u_x.values[pinned] - ds.attrs["rod_speed"]).max() <= 1e-12 * GEO.wall_speed
    assert np.abs(ds.u_z.values[pinned]).max() <= 1e-12 * GEO.wall_speed


def test_the_solid_fraction_is_the_model_s_own(solves) -> None:
    """mu(I): nu(I) of the local inertial number (nu_c where the bed is at rest, lower in the flow);
    Cosserat: nu_cs(p), with its spin; NGF has no dilatancy law, so no nu."""
    local = intruder_fields("local_mu_i", GEO, PARAMS["local_mu_i"], ROD, LX, GRID, solves["local_mu_i"].state)
    law = PARAMS["local_mu_i"].solid_fraction
    inertial = local.shear_rate.values * D / np.sqrt(local.p.values / GEO.rho_s)
    np.testing.assert_allclose(local.nu.values, law.nu(inertial), rtol=1e-12)
    assert np.nanmax(local.nu.values) <= law.nu_c and np.nanmin(local.nu.values) < law.nu_c - 1e-3
    assert "nu(I)" in local.attrs["nu_method"]
    cos = intruder_fields("cosserat", GEO, PARAMS["cosserat"], ROD, LX, GRID, solves["cosserat"].state)
    np.testing.assert_allclose(cos.nu.values, PARAMS["cosserat"].critical.line.nu_cs(cos.p.values), rtol=1e-12)
    assert "spin" in cos and "nu_cs" in cos.attrs["nu_method"]
    ngf = intruder_fields("ngf", GEO, PARAMS["ngf"], ROD, LX, GRID, solves["ngf"].state)
    assert "nu" not in ngf and "fluidity" in ngf


def test_a_state_of_another_grid_or_a_label_without_a_2d_solver_is_refused(solves) -> None:
    with pytest.raises(ValueError, match="another grid"):
        intruder_fields("ngf", GEO, PARAMS["ngf"], ROD, LX, GridOptions(cells_per_d=3), solves["ngf"].state)
    with pytest.raises(ValueError, match="no 2D solver"):
        intruder_fields("ngf_frozen", GEO, PARAMS["ngf"], ROD, LX, GRID, solves["ngf"].state)
