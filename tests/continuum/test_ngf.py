"""NGF: exact creep decay, an independent BVP solution, grid order, failure modes."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_bvp

from continuum import ngf
from continuum.errors import ConvergenceError

from .conftest import D, RHO_S, shear_gravity, observed_order


@pytest.mark.parametrize("ratio", [0.5, 0.8, 0.9])
def test_creep_decays_with_cooperativity_length(ngf_params, ratio):
    mu_s = ngf_params.mu_i.mu_s
    xi = ngf_params.A * D / np.sqrt(mu_s - ratio * mu_s)
    length = 40.0 * xi
    z = np.linspace(0.0, length, 4001)  # xi / h = 100: dispersion error (h / xi)^2 / 24 ~ 4e-6
    mu = np.where(z > 0.8 * length, 0.5, ratio * mu_s)  # flowing on top, uniform creep below
    p = np.full_like(z, 400.0)
    g = ngf.fluidity_profile(z, mu, p, ngf_params, D, RHO_S)
    # Below the flowing zone the equation is xi^2 g'' = g with g'(0) = 0: g = C cosh(z / xi).
    creep = (z > 2 * xi) & (z < 0.8 * length - 2 * xi)
    fitted = np.polyfit(z[creep], np.log(g[creep] / np.cosh(z[creep] / xi)), 1)[0]
    assert abs(fitted) * xi < 1e-4  # no residual exponential: the decay length is xi
    slope = np.polyfit(z[creep & (z > 10 * xi)], np.log(g[creep & (z > 10 * xi)]), 1)[0]
    assert 1.0 / slope == pytest.approx(xi, rel=1e-4)


def _bvp_reference(geo, params):
    """Independent solution of A^2 d^2 g'' = |mu - mu_s| (g - g_loc), u' = g mu, with tau as an
    unknown parameter; scaled by H, V / H, V and P_wall. tol=1e-4 bounds the collocation residual;
    the kinks of |mu - mu_s| and g_loc at the yield plane stop solve_bvp from going much lower, and
    its fourth-order collocation makes the solution itself more accurate than that."""
    mu_s, b, A = params.mu_i.mu_s, params.mu_i.b, params.A
    H, P, V = geo.depth, geo.wall_pressure, geo.wall_speed
    rate = V / H

    def rhs(s, y, k):
        p = P + geo.gravity * geo.rho_s * params.nu * H * (1.0 - s)
        mu = k[0] * P / p
        g_loc = np.sqrt(p / geo.rho_s) / geo.d * np.maximum(mu - mu_s, 0.0) / (b * mu) / rate
        return np.vstack([y[1], np.abs(mu - mu_s) * (y[0] - g_loc) * (H / (A * geo.d)) ** 2, y[0] * mu])

    def bc(ya, yb, k):
        return np.array([ya[1], yb[1], ya[2], yb[2] - 1.0])

    s = np.linspace(0.0, 1.0, 401)
    guess = np.vstack([np.full_like(s, 2.5), np.zeros_like(s), s])
    sol = solve_bvp(rhs, bc, s, guess, p=[0.4], tol=1e-4, max_nodes=200000)
    assert sol.success, sol.message
    return lambda z: sol.sol(z / H) * np.array([[rate], [rate / H], [V]]), sol.p[0] * P


@pytest.mark.parametrize("speed", [1e-3, 0.1])
def test_agrees_with_solve_bvp(ngf_params, speed):
    geo = shear_gravity(wall_speed_factor=speed)
    profile, tau = _bvp_reference(geo, ngf_params)
    ds = ngf.solve(geo, ngf_params, n_grid=8001)
    assert ds.attrs["tau"] == pytest.approx(tau, rel=1e-4)
    ref = profile(ds.z.values)
    np.testing.assert_allclose(ds.fluidity, ref[0], rtol=1e-4)
    assert np.max(np.abs(ds.u_x.values - ref[2])) <= 1e-4 * geo.wall_speed


def test_grid_convergence_is_second_order(ngf_params):
    geo = shear_gravity(wall_speed_factor=1e-3)
    n = np.array([401, 801, 1601])
    taus = [ngf.solve(geo, ngf_params, n_grid=k).attrs["tau"] for k in n]
    reference = ngf.solve(geo, ngf_params, n_grid=25601).attrs["tau"]
    orders = observed_order(n - 1, taus, reference)
    assert np.all((orders > 1.7) & (orders < 2.3)), orders


def test_creep_everywhere_and_no_nu(ngf_params):
    ds = ngf.solve(shear_gravity(), ngf_params, n_grid=201)
    assert np.all(ds.shear_rate > 0.0)
    assert "nu" not in ds
    for name in ("u_x", "shear_rate", "p", "mu"):
        assert ds[name].attrs["units"] and ds[name].attrs["long_name"]
    for key in ("converged", "iterations", "residual", "solve_seconds", "n_grid", "A", "mu_s", "d"):
        assert key in ds.attrs


def test_non_convergence_raises(ngf_params):
    with pytest.raises(ConvergenceError, match="ngf.*residual"):
        ngf.solve(shear_gravity(), ngf_params, max_iterations=2)
