"""Mesh dependence: what converges with the grid and what is set by it.

Physics asserted: NGF and local mu(I) on the shear_gravity cell converge at second order in dx;
the local critical-state band has zero thickness, so its measured width is a fixed multiple of dx
(0.8 dx on the top wall, 1.6 dx inside) and the profile converges only as dx^(1/2) in RMS; the
volume-averaged band on the weak-plane layer has the width of its length l, 2 l ln 5 (10-90 %)
whatever the grid.
"""
from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import xarray as xr

from continuum.mesh_study import band_width, mesh_study, study_model, weak_plane_packing
from continuum.parameters import CosseratParameters, VolumeAveragedParameters
from pipeline.stability import mesh_convergence

from .conftest import D, shear_gravity

GRIDS = (32, 64, 128, 256, 512, 4096)


def order(table: pd.DataFrame, column: str, lo: int = 64, upto: int = 512) -> np.ndarray:
    """Observed orders of ``column`` (an error against the finest grid) over successive doublings
    from ``lo`` to ``upto`` nodes (32 nodes are pre-asymptotic for NGF's creep over 20 d)."""
    rows = table[(table.n_grid >= lo) & (table.n_grid <= upto)].sort_values("n_grid")
    err = rows[column].to_numpy()
    return np.log2(err[:-1] / err[1:])


def test_band_width_of_known_profiles() -> None:
    z = np.linspace(0.0, 1.0, 20001)
    assert band_width(z, 2.0 * z, 2.0) == pytest.approx(0.8, rel=1e-12)  # homogeneous shear
    delta, z0 = 0.03, 0.4
    u = 0.5 * (1.0 + np.tanh((z - z0) / delta))
    u = (u - u[0]) / (u[-1] - u[0])
    assert band_width(z, u, 1.0) == pytest.approx(2.0 * delta * np.arctanh(0.8), rel=1e-4)
    # a jump across one interior node (u = V/2 there) reads 1.6 dx, on the top wall 0.8 dx
    zc = np.linspace(0.0, 1.0, 11)
    assert band_width(zc, np.where(zc > 0.5, 1.0, np.where(zc == 0.5, 0.5, 0.0)), 1.0) == pytest.approx(0.16)
    assert band_width(zc, np.where(zc == 1.0, 1.0, 0.0), 1.0) == pytest.approx(0.08)


def test_ngf_converges_at_second_order(ngf_params) -> None:
    table = study_model("ngf", shear_gravity(), ngf_params, GRIDS, case="shear_gravity")
    assert not table.error.any()
    np.testing.assert_allclose(order(table, "u_x_rmse_vs_finest"), 2.0, atol=0.25)
    # The width's error oscillates with where the 10 % and 90 % crossings fall inside a cell (the
    # linear interpolation's O(dx^2) term), so bound it by C dx^2 instead of fitting an order:
    # over a factor 8 in dx, a first-order error would break the bound by a factor 8.
    fine = table[table.n_grid.between(64, 512)]
    err = np.abs(fine.band_width - table.band_width.iloc[-1])
    assert np.all(err <= 0.25 * fine.dx**2 / D), (err / fine.dx**2 * D).tolist()
    assert table.converged.eq(1).all()


def test_local_mu_i_converges_at_second_order(local_params) -> None:
    table = study_model("local_mu_i", shear_gravity(), local_params, GRIDS, case="shear_gravity")
    np.testing.assert_allclose(order(table, "u_x_rmse_vs_finest"), 2.0, atol=0.3)
    assert table.converged.eq(1).all()


def test_critical_state_band_is_set_by_the_grid(cs_params) -> None:
    geometry = shear_gravity()
    table = study_model("critical_state", geometry, cs_params, GRIDS, case="shear_gravity")
    # critical packing: the band sits on the top wall, one cell wide on every grid
    np.testing.assert_allclose(table.band_width / table.dx, 0.8, rtol=1e-9)
    # a step moving by O(dx) converges in L2 only as dx^(1/2)
    np.testing.assert_allclose(order(table, "u_x_rmse_vs_finest"), 0.5, atol=0.1)
    assert table.converged.eq(0).all()

    layer = replace(geometry, gravity=0.0)
    weak = study_model("critical_state", layer, cs_params, GRIDS, case="weak_plane",
                       nu_initial=weak_plane_packing(layer, cs_params.line))
    np.testing.assert_allclose(weak.band_width / weak.dx, 1.6, rtol=1e-9)
    assert weak.converged.eq(0).all()


def test_volume_averaged_band_has_the_width_of_l(cs_params) -> None:
    geometry = replace(shear_gravity(), gravity=0.0)
    l = 1.0 * D  # the weak plane (0.41 H = 8.3 d) lies 8 l from the bottom wall: walls negligible
    params = VolumeAveragedParameters(cs_params, l=l)
    table = study_model("volume_averaged", geometry, params, GRIDS, case="weak_plane",
                        nu_initial=weak_plane_packing(geometry, cs_params.line))
    # gammadot ~ exp(-|z - z*| / l): u goes from 10 % to 90 % of V over 2 l ln 5
    np.testing.assert_allclose(table.band_width[table.n_grid >= 128], 2.0 * l * np.log(5.0), rtol=0.01)
    assert table.converged.eq(1).all()
    # and the band width is not a fixed multiple of dx
    ratio = (table.band_width / table.dx).to_numpy()
    assert ratio[-1] / ratio[0] > 50.0


def test_unsolvable_grids_are_rows_with_the_solver_message(cs_params) -> None:
    # Cosserat with l below the grid spacing cannot meet its couple-stress conditions on coarse
    # grids (see the failure catalogue); the row keeps the message, the finer grids still solve.
    params = CosseratParameters(cs_params, l=0.25 * D)
    table = study_model("cosserat", shear_gravity(), params, (16, 256, 1024), case="shear_gravity")
    coarse = table[table.n_grid == 16].iloc[0]
    assert "cosserat" in coarse.error and "did not converge" in coarse.error and np.isnan(coarse.band_width)
    assert table[table.n_grid > 16].error.eq("").all()


def test_cli_writes_the_contract_table(tmp_path: Path, local_params, ngf_params, cs_params) -> None:
    def entry(v: float) -> dict:
        return {"value": v, "error": 0.0, "fitted_on": "glass-bead reference"}

    params = {
        "local": {k: entry(v) for k, v in dict(mu_s=0.3819, mu_2=0.6435, I_0=0.279, nu_c=0.6, a=0.3).items()},
        "critical_state": {k: entry(v) for k, v in dict(sin_phi=0.3819, nu_ref=0.59, kappa=0.01, p_ref=300.0, n=1.05).items()},
        "nonlocal": {"ngf": {"A": entry(0.48)}, "volume_averaged": {"l": entry(2 * D)}, "cosserat": {"l": entry(D)}},
        "normal_stresses": {"sigma_zz_over_p": entry(1.0)},
        "wall": {"slip_length": entry(0.0)},
        "d": D, "rho_s": 2500.0,
    }
    (tmp_path / "params.json").write_text(json.dumps(params))
    g = shear_gravity()
    files = []
    for k, top in enumerate((g.depth, g.depth * 1.02)):
        ds = xr.Dataset(coords={"z": np.linspace(0.0, 0.1, 5)},
                        attrs=dict(z_bottom_wall=0.001, z_top_wall=0.001 + top, z_bottom_contact_plane=0.001,
                                   z_top_contact_plane=0.001 + top, wall_speed=g.wall_speed,
                                   wall_pressure=g.wall_pressure, gravity=g.gravity, d=D, rho_s=2500.0))
        files.append(tmp_path / f"r{k + 1}.nc")
        ds.to_netcdf(files[-1])
    out = tmp_path / "stability" / "mesh_convergence.csv"
    assert mesh_convergence.main(["--params", str(tmp_path / "params.json"), "--fields", *map(str, files),
                                  "--out", str(out), "--n-grid", "32", "64", "128"]) == 0
    table = pd.read_csv(out, keep_default_na=False, na_values=[""])
    assert list(table.columns[:2]) == ["case", "model"]
    for column in ("dx", "band_width", "u_x_rmse_vs_finest", "converged"):
        assert column in table.columns
    assert set(table.case) == {"shear_gravity", "weak_plane"}
    assert len(table) == 2 * 5 * 3
    assert not list(out.parent.glob("*.tmp"))
    # the geometry is the mean of the replicas: depth 1.01 H, dx = 1.01 H / 31 on the 32-node NGF grid
    ngf = table[(table.model == "ngf") & (table.n_grid == 32)].iloc[0]
    assert ngf.dx == pytest.approx(1.01 * g.depth / 31, rel=1e-9)
    # every model's row on the finest grid compares it with itself
    finest = table[table.n_grid == 128].dropna(subset=["band_width"])
    assert (finest.u_x_rmse_vs_finest == 0.0).all()
    # and mesh_study over all models is the concatenation of the per-model studies
    both = mesh_study(g, {"ngf": ngf_params, "local_mu_i": local_params}, (32, 64))
    assert list(both.model.unique()) == ["ngf", "local_mu_i"]
