"""Local mu(I) with nu(I): exact homogeneous solution, an independent BVP solution, grid order."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_bvp

from continuum import local_mu_i
from continuum.errors import ConvergenceError, OutOfRangeError

from .conftest import D, shear_gravity, observed_order


@pytest.mark.parametrize("speed", [1e-3, 0.3, 5.0])
def test_uniform_stress_gives_uniform_shear_at_inverse_of_mu(local_params, speed):
    geo = shear_gravity(wall_speed_factor=speed, gravity=0.0)
    ds = local_mu_i.solve(geo, local_params, n_grid=51)
    gammadot = geo.wall_speed / geo.depth
    np.testing.assert_allclose(ds.shear_rate, gammadot, rtol=1e-13)
    # The stress ratio must be the one whose inverse mu -> I gives this shear rate.
    inertial = local_params.mu_i.inertial_number(float(ds.mu[0]))
    assert inertial * np.sqrt(geo.wall_pressure / geo.rho_s) / geo.d == pytest.approx(gammadot, rel=1e-12)
    np.testing.assert_allclose(ds.u_x, gammadot * ds.z, rtol=1e-13, atol=1e-18)
    np.testing.assert_allclose(ds.nu, 0.6 - 0.3 * inertial, rtol=1e-13)


def _bvp_reference(geo, params):
    """Independent solution: integrate dp/dz and du/dz in z with tau as an unknown parameter.

    Scaled (z / H, p / P_wall, u / V, tau / P_wall) so that solve_bvp's relative tolerance means
    the same for every component.
    """
    mu_law, nu_law = params.mu_i, params.solid_fraction
    H, P, V = geo.depth, geo.wall_pressure, geo.wall_speed

    def rhs(s, y, k):
        p = y[0] * P
        mu = k[0] / y[0]
        inertial = mu_law.I_0 * np.maximum(mu - mu_law.mu_s, 0.0) / (mu_law.mu_2 - mu)
        gammadot = inertial * np.sqrt(p / geo.rho_s) / geo.d
        dp = -geo.gravity * geo.rho_s * (nu_law.nu_c - nu_law.a * inertial) * H / P
        return np.vstack([dp, gammadot * H / V])

    def bc(ya, yb, k):
        return np.array([yb[0] - 1.0, ya[1], yb[1] - 1.0])

    s = np.linspace(0.0, 1.0, 2001)
    y0 = np.vstack([1.0 + geo.gravity * geo.rho_s * 0.6 * H * (1.0 - s) / P, s])
    sol = solve_bvp(rhs, bc, s, y0, p=[0.45], tol=1e-6, max_nodes=200000)
    assert sol.success, sol.message
    return lambda z: sol.sol(z / H) * np.array([[P], [V]]), sol.p[0] * P


@pytest.mark.parametrize("gravity", [9.81, 0.05])
def test_agrees_with_solve_bvp(local_params, gravity):
    # g = 9.81: yield plane about 2 d below the top wall; g = 0.05: the whole layer flows
    geo = shear_gravity(wall_speed_factor=0.3, gravity=gravity)
    profile, tau = _bvp_reference(geo, local_params)
    ds = local_mu_i.solve(geo, local_params, n_grid=2000)
    assert (ds.attrs["yield_height"] > 0.0) == (gravity > 1.0)
    assert ds.attrs["tau"] == pytest.approx(tau, rel=1e-4)
    p_ref, u_ref = profile(ds.z.values)
    assert np.max(np.abs(ds.u_x.values - u_ref)) <= 1e-4 * geo.wall_speed
    np.testing.assert_allclose(ds.p, p_ref, rtol=1e-4)


def test_no_flow_below_yield_plane(local_params):
    geo = shear_gravity(wall_speed_factor=1e-3)
    ds = local_mu_i.solve(geo, local_params, n_grid=100)
    below = ds.z.values < ds.attrs["yield_height"]
    assert below.sum() > 50
    assert np.all(ds.u_x.values[below] == 0.0) and np.all(ds.shear_rate.values[below] == 0.0)
    assert np.all(ds.mu.values[below] < local_params.mu_i.mu_s)
    assert np.all(ds.mu.values[~below] >= local_params.mu_i.mu_s * (1 - 1e-12))


def test_grid_convergence_is_second_order(local_params):
    geo = shear_gravity(wall_speed_factor=1e-3)
    n = np.array([20, 40, 80, 160])
    taus = [local_mu_i.solve(geo, local_params, n_grid=k).attrs["tau"] for k in n]
    reference = local_mu_i.solve(geo, local_params, n_grid=5120).attrs["tau"]
    orders = observed_order(n, taus, reference)
    assert np.all((orders > 1.8) & (orders < 2.2)), orders


def test_too_fast_wall_is_out_of_range(local_params):
    with pytest.raises(OutOfRangeError, match="local_mu_i"):
        local_mu_i.solve(shear_gravity(wall_speed_factor=1e4), local_params)


def test_non_convergence_raises(local_params):
    with pytest.raises(ConvergenceError, match="local_mu_i.*residual"):
        local_mu_i.solve(shear_gravity(), local_params, max_iterations=2)
