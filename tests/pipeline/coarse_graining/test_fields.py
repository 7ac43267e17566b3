"""The fields workflow step: contract file, physical checks on a synthetic static bed with exact
answers, and on real DEM output of the reduced shear_gravity run.

Real-data tests take the run folder from the ``shear_gravity_run`` fixture if the suite provides
one (the reduced workflow run once per session by tests/conftest.py).
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from pipeline.coarse_graining import field_checks
from pipeline.coarse_graining import coarse_grain as cg
from pipeline.coarse_graining import fields
from pipeline.coarse_graining.vtk import write_fields_vtk
from pipeline.dumps.reader import CONTACT_COLUMNS

CONTRACT = ("nu", "rho", "u_x", "u_z", "shear_rate", "sigma_xx", "sigma_yy", "sigma_zz", "sigma_xz",
            "sigma_xz_contact", "sigma_xz_kinetic", "p", "mu", "I")
CONFIG = {"material": {"d": 0.002, "rho_s": 2500.0}, "cases": {}}


def write_static_bed(run_dir: Path, layers: int = 16, side: int = 4, load: float = 200.0, tau: float = 60.0,
                     g: float = 9.81, snapshots: int = 8) -> dict:
    """A simple-cubic column bed in static equilibrium: layer 0 the bottom wall (type 2), the last
    layer the top wall (type 3), each vertical contact carrying the load plus the weight above and
    a uniform shear traction. Every force balance is exact, so every check has an exact answer."""
    d, rho_s = 0.002, 2500.0
    m = rho_s * math.pi * d**3 / 6
    a = d
    i, j, k = np.meshgrid(np.arange(side), np.arange(side), np.arange(layers), indexing="ij")
    pos = np.column_stack([(i.ravel() + 0.5) * a, (j.ravel() + 0.5) * a, (k.ravel() + 0.5) * a])
    layer = k.ravel()
    types = np.where(layer == 0, 2, np.where(layer == layers - 1, 3, 1))
    ids = np.arange(1, pos.shape[0] + 1)
    vel = np.zeros_like(pos)
    vel[:, 0] = 0.1 * layer / (layers - 1)
    # Contacts between vertical neighbours; particle 1 is the upper one, f the force on it.
    upper = np.nonzero(layer > 0)[0]
    lower = upper - 1  # k is the fastest index of the meshgrid ravel
    # The upper grain of each contact carries the load plus the flowing grains at or above it.
    above = np.array([np.sum((types == 1) & (pos[:, 0] == pos[u, 0]) & (pos[:, 1] == pos[u, 1]) & (layer >= layer[u]))
                      for u in upper])
    fz = load * a * a + m * g * above
    contacts = np.column_stack([pos[upper], pos[lower], ids[upper], ids[lower], np.zeros(upper.size),
                                np.full(upper.size, -tau * a * a), np.zeros(upper.size), fz,
                                np.full(upper.size, 1e-7), 0.5 * (pos[upper] + pos[lower])])
    box = f"0 {side * a}\n0 {side * a}\n0 {layers * a}\n"
    (run_dir / "dumps").mkdir(parents=True)
    (run_dir / "series").mkdir()
    dt, every = 1e-6, 1000
    pcols = np.column_stack([ids, types, pos, vel, np.zeros_like(pos), np.full(ids.size, d / 2), np.full(ids.size, m),
                             np.zeros_like(pos)])
    # Each flowing grain is in equilibrium: total force f = 0 (contacts balance gravity).
    with open(run_dir / "dumps/particles_000.dump", "w") as fp, open(run_dir / "dumps/contacts_000.dump", "w") as fc:
        for s in range(snapshots):
            step = 1000 + s * every
            fp.write(f"ITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ATOMS\n{ids.size}\nITEM: BOX BOUNDS pp pp ff\n{box}"
                     "ITEM: ATOMS id type x y z vx vy vz omegax omegay omegaz radius mass fx fy fz \n")
            np.savetxt(fp, pcols, fmt="%.17g")
            fc.write(f"ITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ENTRIES\n{upper.size}\nITEM: BOX BOUNDS pp pp ff\n{box}"
                     "ITEM: ENTRIES " + " ".join(f"c_pgl[{c}]" for c in range(1, 17)) + " \n")
            np.savetxt(fc, contacts, fmt="%.17g")
    area = (side * a) ** 2
    flowing = np.sum(types == 1)
    with open(run_dir / "series/production_000.txt", "w") as fs:
        fs.write("# Time-averaged data\n# TimeStep v_time ...\n")
        for s in range(20):
            t = (1000 + s * 400) * dt
            fs.write(f"{1000 + s * 400} {t} {tau * area} {-(load * area + flowing * m * g)} {-tau * area} "
                     f"{load * area} {(layers - 0.5) * a} 0 1e-7\n")
    run = {"case": "shear_gravity", "run": "synthetic", "d": d, "density": rho_s, "time_step": dt,
           "steady_state_window": [0.001, 0.001 + (snapshots - 1) * every * dt], "cell": [side * a, side * a],
           "production_window": [1000 * dt, (1000 + 19 * 400) * dt],
           "wall_pressure": load, "gravity": g, "wall_speed": 0.1, "wall_clock_seconds": 1.0,
           "particle_dumps": ["dumps/particles_000.dump"], "contact_dumps": ["dumps/contacts_000.dump"],
           "contact_columns": list(CONTACT_COLUMNS), "provenance": {"config": {}, "software": {}}}
    (run_dir / "run.json").write_text(json.dumps(run))
    return run


def test_static_bed_satisfies_every_check_exactly(tmp_path):
    write_static_bed(tmp_path / "run")
    result, checks = fields.run_fields(CONFIG, tmp_path / "run")
    ds = result.dataset
    # Wall stress: the identities of field_checks are exact here (equilibrium, no inertia).
    for wall in ("bottom", "top"):
        for name in ("sigma_zz", "sigma_xz"):
            assert abs(checks[f"wall_series_{wall}_{name}_residual"]) < 1e-9, (wall, name)
            assert abs(checks[f"wall_dump_{wall}_{name}_residual"]) < 1e-9, (wall, name)
    for key, value in checks.items():
        if key.startswith("identity_"):
            assert value < 1e-12, key
    # Momentum balance: exact pointwise; what remains is the trapezoid integral of rho_body.
    assert checks["balance_residual_xz"] < 1e-9
    assert checks["balance_residual_zz"] < 0.03
    np.testing.assert_allclose(ds["sigma_xz"].sel(z=slice(0.008, 0.024)), -60.0, rtol=1e-9)


def test_workflow_step_writes_the_contract_atomically(tmp_path):
    run = write_static_bed(tmp_path / "run")
    out = tmp_path / "fields/shear_gravity/synthetic.nc"
    config = Path(__file__).resolve().parents[3] / "config" / "ci.yaml"
    argv = ["--config", str(config), "--run-dir", str(tmp_path / "run"), "--out", str(out)]
    assert fields.main(argv) == 0
    assert [p.name for p in out.parent.iterdir()] == ["synthetic.nc"]  # no temporary left behind
    assert fields.main(argv[:3] + [str(tmp_path / "missing"), "--out", str(tmp_path / "x.nc")]) == 1
    assert not (tmp_path / "x.nc").exists()
    with xr.open_dataset(out) as ds:
        for name in CONTRACT:
            for var in (name, f"{name}_err"):
                assert ds[var].dims == ("z",)
                assert ds[var].attrs["units"] and ds[var].attrs["long_name"], var
        assert ds["z"].attrs["units"] == "m"
        for attr in ("kernel", "width", "time_window", "number_of_snapshots", "d", "rho_s", "config_json",
                     "software_versions_json", "error_blocks"):
            assert attr in ds.attrs, attr
        assert ds.attrs["number_of_snapshots"] == 8
        assert ds.attrs["d"] == run["d"] and ds.attrs["rho_s"] == run["density"]


def test_plane_fields_and_vtk(tmp_path):
    write_static_bed(tmp_path / "run", layers=10)
    result, _ = fields.run_fields(CONFIG, tmp_path / "run", plane=True)
    ds = result.dataset
    assert ds["nu"].dims == ("x", "z")
    # A bed at rest: every snapshot alike, the stresses' standard errors ~0, so the contact rule's
    # check (its gap from the exact integral over the error) fails and the exact integral is used.
    assert ds.attrs["contact_integral"] == "exact"
    assert ds.attrs["contact_rule_check"] > cg.RULE_CHECK_LIMIT
    # Averaged over x, the x-z field of a bed is its profile. The mean over the x grid points is
    # the periodic trapezoid rule for the x integral; the kink of the cut Gaussian at 3 w limits
    # that rule to about 1e-4 here, hence 1e-3.
    profile, _ = fields.run_fields(CONFIG, tmp_path / "run")
    inner = slice(0.004, 0.014)
    for name in ("sigma_xz", "sigma_zz", "nu"):
        np.testing.assert_allclose(ds[name].sel(z=inner).mean("x"), profile.dataset[name].sel(z=inner), rtol=1e-3)
    path = write_fields_vtk(ds, tmp_path / "f.vts")
    import pyvista as pv

    grid = pv.read(path)
    assert grid.dimensions == (ds.sizes["x"], 1, ds.sizes["z"])
    np.testing.assert_allclose(grid.point_data["nu"].reshape(ds.sizes["x"], ds.sizes["z"], order="F"), ds["nu"].values)
    # ParaView arrays: velocity a 3-vector, stress a symmetric 3x3 tensor (row-major).
    n = ds.sizes["x"] * ds.sizes["z"]
    assert grid.point_data["velocity"].shape == (n, 3) and grid.point_data["stress"].shape == (n, 9)
    tensor = grid.point_data["stress"].reshape(n, 3, 3)
    np.testing.assert_allclose(tensor, np.transpose(tensor, (0, 2, 1)))
    np.testing.assert_allclose(tensor[:, 0, 2].reshape(ds.sizes["x"], ds.sizes["z"], order="F"), ds["sigma_xz"].values)
    np.testing.assert_allclose(grid.point_data["velocity"][:, 0].reshape(ds.sizes["x"], ds.sizes["z"], order="F"),
                               ds["u_x"].values)


# ---- real DEM output ---------------------------------------------------------------------------


@pytest.fixture
def sg_run(shear_gravity_run: Path) -> Path:
    """The reduced workflow's shear_gravity run (tests/conftest.py)."""
    return shear_gravity_run


@pytest.fixture
def sg_fields(sg_run: Path) -> dict[float, tuple]:
    d = json.loads((sg_run / "run.json").read_text())["d"]
    return {ratio: fields.run_fields(CONFIG, sg_run, width=ratio * d) for ratio in (0.5, 1.0)}


def test_real_contact_stress_identity_is_exact(sg_fields):
    for _, checks in sg_fields.values():
        for wall in ("bottom", "top"):
            for comp in ("xz", "zz"):
                assert checks[f"identity_exact_{wall}_{comp}"] < 1e-9


def test_real_momentum_balance_in_the_bulk(sg_fields):
    """Residual at most 3 % of p, beyond twice the fields' own standard error (10 snapshots
    scatter sigma by ~4-6 % of p, so a sharper statement needs a longer production run)."""
    for ratio, (_, c) in sg_fields.items():
        p = c["balance_p_bulk"]
        height = c["balance_bulk_z_hi"] - c["balance_bulk_z_lo"]
        slope_zz_residual = abs(c["balance_slope_zz"] - c["balance_slope_zz_expected"]) * height / p
        slope_xz_residual = abs(c["balance_slope_xz"]) * height / p
        assert slope_zz_residual <= 0.03 + 2 * c["balance_sigma_zz_err_over_p"], ratio
        assert slope_xz_residual <= 0.03 + 2 * c["balance_sigma_xz_err_over_p"], ratio
        assert c["balance_residual_zz"] <= 0.03 + 2 * c["balance_sigma_zz_err_over_p"], ratio
        assert c["balance_residual_xz"] <= 0.03 + 2 * c["balance_sigma_xz_err_over_p"], ratio


def test_real_wall_stress_matches_wall_force(sg_fields):
    """Against the contact forces on the bottom wall at the same snapshots: the traction vector
    (sigma_xz, sigma_zz) within 3 % of its magnitude, which the normal stress dominates (the shear
    component alone is a few Pa against a grain inertia term of the same order between the wall
    and the check plane). Against the production-averaged wall series: within 3 % of the wall's
    normal stress plus twice the combined standard error of the two averages."""
    for ratio, (result, c) in sg_fields.items():
        assert abs(c["wall_dump_bottom_sigma_zz_residual"]) < 0.03, ratio
        assert abs(c["wall_dump_bottom_sigma_xz_residual_over_normal"]) < 0.03, ratio
        for wall, fz in (("bottom", "fbot_z"), ("top", "ftop_z")):
            for name, f in (("sigma_zz", fz), ("sigma_xz", fz.replace("_z", "_x"))):
                got = c[f"wall_series_{wall}_{name}"]
                expected = c[f"wall_series_{wall}_{name}_expected"]
                noise = math.hypot(c[f"wall_series_{wall}_{name}_err"], c[f"series_{f}_err_over_area"])
                scale = abs(c[f"wall_series_{wall}_sigma_zz_expected"])
                assert abs(got - expected) <= 0.03 * scale + 2 * noise, (ratio, wall, name, got, expected, noise)


def test_real_bulk_values_do_not_depend_on_width(sg_fields):
    """w = 0.5 d against w = 1 d: bulk means agree within twice their combined standard error."""
    (a, ca), (b, _) = sg_fields[0.5], sg_fields[1.0]
    lo, hi = ca["balance_bulk_z_lo"], ca["balance_bulk_z_hi"]
    for name in ("nu", "sigma_zz", "sigma_xz", "p", "mu", "rho"):
        va = a.dataset[name].sel(z=slice(lo, hi))
        vb = b.dataset[name].interp(z=va["z"])
        ea = float(a.dataset[f"{name}_err"].sel(z=slice(lo, hi)).mean())
        eb = float(b.dataset[f"{name}_err"].sel(z=slice(lo, hi)).mean())
        diff = abs(float(va.mean()) - float(vb.mean()))
        # nu and rho barely fluctuate in time; for them compare to 1 % of the value.
        allowed = 2 * math.hypot(ea, eb) + (0.01 * abs(float(va.mean())) if name in ("nu", "rho") else 0.0)
        assert diff <= allowed, (name, diff, allowed)



@pytest.mark.workflow
def test_displacement_speed_agrees_with_the_snapshot_speed_and_planes_sit_inside_the_walls(reduced_results: Path) -> None:
    for path in sorted((reduced_results / "fields" / "shear_gravity").glob("r*.nc")):
        ds = xr.open_dataset(path)
        d = float(ds.attrs["d"])
        # The bed-wall contacts act between the wall grains' centres and the bed, within a grain.
        assert 0.0 < ds.attrs["z_bottom_contact_plane"] - ds.attrs["z_bottom_wall"] < d
        assert 0.0 < ds.attrs["z_top_wall"] - ds.attrs["z_top_contact_plane"] < d
        z = ds.z.values
        inside = (z > ds.attrs["z_bottom_wall"] + 1.5 * d) & (z < ds.attrs["z_top_wall"] - 1.5 * d)
        # Two estimates of the same mean velocity: their difference within the combined errors.
        diff = np.abs(ds.u_x.values - ds.u_x_disp.values)[inside]
        scale = np.hypot(ds.u_x_err.values, ds.u_x_disp_err.values)[inside]
        assert np.mean(diff < 3.0 * scale) > 0.9, path
        # Deep in the creep the displacements resolve what the snapshots do not.
        deep = inside & (ds.u_x.values < 0.01 * ds.attrs["wall_speed"])
        assert np.median(ds.u_x_disp_err.values[deep]) < np.median(ds.u_x_err.values[deep])
        ds.close()


@pytest.mark.workflow
def test_fields_files_are_cf_and_cf_xarray_finds_axes_and_errors(reduced_results: Path) -> None:
    import cf_xarray  # noqa: F401  (registers the .cf accessor)

    ds = xr.open_dataset(reduced_results / "fields" / "shear_gravity" / "r1.nc")
    assert ds.attrs["Conventions"] == "CF-1.10" and ds.attrs["title"] and ds.attrs["history"] and ds.attrs["source"]
    assert ds.cf.axes["Z"] == ["z"]
    assert ds["z"].attrs["positive"] == "up"
    assert ds.cf["u_x"].attrs["ancillary_variables"] == "u_x_err"
    assert "u_x_err" in ds.cf.get_associated_variable_names("u_x")["ancillary_variables"]
    assert ds["nu"].attrs["cell_methods"] == "time: mean"
    for key, value in ds.attrs.items():
        if not isinstance(value, str) and not key.endswith("_units"):
            assert f"{key}_units" in ds.attrs, key
    ds.close()



@pytest.mark.workflow
def test_paraview_collection_and_particles_of_a_real_run(reduced_results: Path, tmp_path: Path) -> None:
    import pyvista as pv

    pvd = reduced_results / "paraview" / "shear_gravity.pvd"
    text = pvd.read_text()
    files = sorted((reduced_results / "paraview" / "shear_gravity").glob("*.vtp"))
    assert {f.stem for f in files} == {"r1", "r2"} and all(f"shear_gravity/{f.name}" in text for f in files)
    line = pv.read(files[0])
    ds = xr.open_dataset(reduced_results / "fields" / "shear_gravity" / "r1.nc")
    np.testing.assert_allclose(line.point_data["velocity"][:, 0], ds["u_x"].values)
    np.testing.assert_allclose(line.point_data["stress"][:, 8], ds["sigma_zz"].values)
    # the grains of the averaged snapshots, on request
    out = tmp_path / "grains"
    code = fields.main(["--config", str(reduced_results / "config.effective.json"), "--run-dir",
                        str(reduced_results / "dem" / "shear_gravity" / "r1"), "--out", str(tmp_path / "r1.nc"),
                        "--particles-vtk", str(out)])
    assert code == 0
    clouds = sorted(out.glob("particles_*.vtu"))
    assert len(clouds) == int(ds.attrs["number_of_snapshots"])
    cloud = pv.read(clouds[0])
    assert cloud.point_data["velocity"].shape[1] == 3 and {"radius", "type"} <= set(cloud.point_data.keys())
    assert "particles_" in (out / "particles.pvd").read_text()
    ds.close()


def test_mean_error_counts_the_correlation_time(rng):
    # AR(1) with coefficient a: the mean of n samples has variance (1 + a) / (1 - a) / n of the
    # uncorrelated one (a = 0.9: 19 times). 200 series of 2000 samples: the stated errors' RMS
    # matches the scatter of the means within the sampling noise of both (~10 %).
    a, n = 0.9, 2000
    means, errors = [], []
    for _ in range(200):
        x = np.empty(n)
        x[0] = rng.normal()
        noise = rng.normal(size=n) * np.sqrt(1 - a * a)
        for i in range(1, n):
            x[i] = a * x[i - 1] + noise[i]
        means.append(x.mean())
        errors.append(field_checks.mean_error(x, 5))
    expected = np.sqrt((1 + a) / (1 - a) / n)
    assert abs(np.std(means) / expected - 1) < 0.15
    assert abs(np.sqrt(np.mean(np.square(errors))) / expected - 1) < 0.15
