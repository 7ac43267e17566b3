"""Volume-averaged non-local model: creep of length l, the l -> 0 limit, mass, grid order."""
from __future__ import annotations

import numpy as np
import pytest

from continuum import critical_state, volume_averaged
from continuum.parameters import VolumeAveragedParameters

from .conftest import D, shear_gravity, observed_order


def dense(z: np.ndarray) -> np.ndarray:
    return np.full_like(z, 0.62)


def test_creep_obeys_averaged_flow_rule_with_decay_length_l(cs_params):
    geo = shear_gravity()
    length = 1.5 * D
    ds = volume_averaged.solve(geo, VolumeAveragedParameters(cs_params, length), n_grid=4001)
    z, gd = ds.z.values, ds.shear_rate.values
    h = z[1] - z[0]
    # lambda = gammadot - l^2 gammadot'' must vanish off the yielding plane (the top wall)
    lam = gd[1:-1] - length**2 * (gd[2:] - 2 * gd[1:-1] + gd[:-2]) / h**2
    interior = z[1:-1] < geo.depth - 5 * h
    assert np.max(np.abs(lam[interior]) / gd[1:-1][interior]) < (h / length) ** 2  # O(h^2) FD error
    # wall condition at the bottom: l gammadot' = gammadot
    assert length * (gd[1] - gd[0]) / h / gd[0] == pytest.approx(1.0, rel=2 * h / length)
    # the decay length is l at every depth, whatever mu(z) is there
    for window in [(2 * D, 6 * D), (12 * D, 16 * D)]:
        sel = (z > window[0]) & (z < window[1])
        assert 1.0 / np.polyfit(z[sel], np.log(gd[sel]), 1)[0] == pytest.approx(length, rel=1e-9)
    assert ds.mu.values[z < 6 * D].max() < 0.75 * ds.mu.values[(z > 12 * D) & (z < 16 * D)].min() / 0.6


def test_small_l_approaches_local_critical_state(cs_params):
    geo = shear_gravity()
    n = 801
    local = critical_state.solve(geo, cs_params, n_grid=n, nu_initial=dense)
    u_diff, nu_diff = [], []
    lengths = np.array([0.8, 0.4, 0.2]) * D
    for length in lengths:
        ds = volume_averaged.solve(geo, VolumeAveragedParameters(cs_params, length), n_grid=n, nu_initial=dense)
        assert ds.attrs["tau"] == pytest.approx(local.attrs["tau"], rel=1e-12)
        u_diff.append(np.mean(np.abs(ds.u_x.values - local.u_x.values)) / geo.wall_speed)
        nu_diff.append(np.mean(np.abs(ds.nu.values - local.nu.values)))
    # both differences are carried by a layer of thickness l under the band: they scale with l
    for diff in (u_diff, nu_diff):
        ratios = np.array(diff[:-1]) / np.array(diff[1:])
        assert np.all((ratios > 1.8) & (ratios < 2.2)), ratios
    # magnitudes: a creep layer exp(-(H - z) / l) carries mean(u) / V ~ l / H, and dilation
    # (0.62 - nu_cs(P_wall)) exp(-(H - z) / l)
    assert u_diff[-1] < 1.1 * lengths[-1] / geo.depth
    dnu_top = 0.62 - float(cs_params.line.nu_cs(geo.wall_pressure))
    assert nu_diff[-1] < 1.1 * dnu_top * lengths[-1] / geo.depth


def test_dilation_conserves_mass_and_depends_on_initial_packing(cs_params):
    geo = shear_gravity()
    params = VolumeAveragedParameters(cs_params, 2 * D)
    finals = []
    for nu0 in (0.62, 0.63):
        ds = volume_averaged.solve(geo, params, n_grid=801, nu_initial=lambda z, v=nu0: np.full_like(z, v))
        assert np.trapezoid(ds.nu.values, ds.z.values) == pytest.approx(nu0 * geo.depth, rel=1e-7)
        assert ds.nu.values[-1] == pytest.approx(float(cs_params.line.nu_cs(geo.wall_pressure)), rel=1e-10)
        assert ds.attrs["final_depth"] > geo.depth  # the top dilates
        finals.append(ds)
    # same kinematics, different packing left below the band
    assert abs(finals[0].nu.values[400] - finals[1].nu.values[400]) > 5e-3
    np.testing.assert_allclose(finals[0].attrs["tau"], finals[1].attrs["tau"], rtol=1e-12)


def test_grid_convergence_is_second_order(cs_params):
    geo = shear_gravity()
    params = VolumeAveragedParameters(cs_params, 2 * D)
    n = np.array([50, 100, 200])
    depths = [volume_averaged.solve(geo, params, n_grid=k + 1, nu_initial=dense).attrs["final_depth"] for k in n]
    reference = volume_averaged.solve(geo, params, n_grid=6401, nu_initial=dense).attrs["final_depth"]
    orders = observed_order(n, depths, reference)
    assert np.all((orders > 1.8) & (orders < 2.2)), orders


def test_uniform_pressure_leaves_velocity_undetermined(cs_params):
    ds = volume_averaged.solve(shear_gravity(gravity=0.0), VolumeAveragedParameters(cs_params, D), n_grid=51)
    assert ds.attrs["velocity_determined"] == 0 and "u_x" not in ds
