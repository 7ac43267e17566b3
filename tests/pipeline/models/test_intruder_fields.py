"""The intruder models' 2D fields files (pipeline.models.intruder_fields): from the nominal solves'
stored states to CF NetCDF and VTK per scene, in the rod's frame with the DEM's coordinates. Small
bed (12 d, cell 8 d, 2 cells per d), rod 3 d at 4 d, NGF coupled and local mu(I) (about a second each)."""
from __future__ import annotations

import json

import numpy as np
import pytest
import xarray as xr

from pipeline.calibration.parameter_sets import model_parameters
from pipeline.models import intruder_fields as mf
from pipeline.models.intruder import scenes_of, solve_scenes
from pipeline.models.intruder_states import load_states, save_states

D = 0.002
MU = {"mu_s": 0.374, "mu_2": 1.023, "I_0": 0.637, "nu_c": 0.587, "a": 0.141}
PARAMS = {"local": {k: {"value": v} for k, v in MU.items()}, "critical_state": {},
          "nonlocal": {"ngf": {"A": {"value": 0.327}}}, "normal_stresses": {"sigma_zz_over_p": {"value": 1.058}},
          "wall": {"slip_length": {"value": 0.0, "error": 0.0}}}
Z_BOTTOM = 0.0015  # the bottom contact plane in the DEM's frame
Z_TOP_WALL = Z_BOTTOM + 12.5 * D


def run(name: str, depth: float, force: float) -> dict:
    rod = {"depth": depth * D, "diameter": 3 * D, "force": force * 4 * D, "length": 4 * D, "depth_over_d": depth,
           "depth_target_over_d": 4.0, "control": False, "force_sweep": False, "push_over_yield": 0.5}
    return {"case": "intruder", "run": name, "cell": [8 * D, 4 * D], "intruder": rod}


def fields() -> xr.Dataset:
    return xr.Dataset(attrs={"z_bottom_contact_plane": Z_BOTTOM, "z_top_contact_plane": Z_BOTTOM + 12 * D,
                             "z_top_wall": Z_TOP_WALL, "wall_speed": 0.1, "wall_pressure": 200.0, "gravity": 9.81,
                             "d": D, "rho_s": 2500.0})


@pytest.fixture(scope="module", params=["ngf", "local_mu_i"])
def written(request, tmp_path_factory):
    """A scene of two replicas (the first's rod at 4.0 d), solved, its state stored and read back,
    its fields written."""
    model = request.param
    runs, fl = [run("D4-r1", 4.0, 0.8), run("D4-r2", 4.1, 0.8)], [fields(), fields()]
    scenes = scenes_of(runs, fl, PARAMS)
    results, reasons = solve_scenes(model, model_parameters(PARAMS, model), scenes, 2.0)
    assert reasons == [None]
    folder = tmp_path_factory.mktemp(model)
    save_states(results, folder / "states.npz", model, 2.0)
    states, cells_per_d = load_states(folder / "states.npz", model, len(scenes))
    datasets, missing = mf.model_fields(model, PARAMS, runs, fl, states, cells_per_d)
    mf.write_model_fields(datasets, missing, folder / "out", {"config_json": "{}"})
    return model, results[0], folder / "out"


def test_each_scene_is_written_as_cf_netcdf_and_vtk(written) -> None:
    model, result, out = written
    assert json.loads((out / mf.INDEX).read_text()) == {"scenes": ["D4"], "not_solved": []}
    assert (out / "D4.vts").is_file() and not list(out.glob(".*tmp*"))
    with xr.open_dataset(out / "D4.nc") as ds:
        assert ds.attrs["Conventions"] == "CF-1.10" and ds.attrs["model"] == model and ds.attrs["run"] == "D4-r1"
        for name in [*ds.data_vars, "x", "z"]:
            assert ds[name].attrs.get("units") and ds[name].attrs.get("long_name"), name
        assert ds.x.attrs["axis"] == "X" and ds.z.attrs["positive"] == "up"
        assert ds["u_x_rel"].dims == ("x", "z")
        expected = {"u_x", "u_x_rel", "u_z", "p", "mu", "mu_xz", "sigma_xx", "sigma_zz", "sigma_xz", "solid"}
        assert expected <= set(ds.data_vars)
        assert ("fluidity" in ds) == (model == "ngf") and ("nu" in ds) == (model == "local_mu_i")
        # the solve's own numbers, transposed to (x, z)
        np.testing.assert_array_equal(ds.p.values, result.fields.p.values.T)
    import pyvista as pv

    mesh = pv.read(out / "D4.vts")
    assert {"u_x_rel", "p", "mu", "velocity"} <= set(mesh.point_data.keys())


def test_the_coordinates_are_the_rod_s_frame_in_the_dem_s_heights(written) -> None:
    """x from the rod's axis (the cell's middle: symmetric about 0), z the DEM's: the rod's axis at
    the DEM rod's height (the top wall's grains minus the first replica's depth)."""
    _, result, out = written
    with xr.open_dataset(out / "D4.nc") as ds:
        x, z = ds.x.values, ds.z.values
        assert np.allclose(x, -x[::-1]) and x[0] == pytest.approx(-8 * D / 2 + D / 4)
        assert z[0] == pytest.approx(Z_BOTTOM + D / 4)
        assert ds.attrs["rod_z"] == pytest.approx(Z_TOP_WALL - 4.0 * D, abs=1e-12)
        assert ds.attrs["z_bottom_contact_plane"] == pytest.approx(Z_BOTTOM)
        # the solid cells sit around (0, rod_z)
        solid = ds.solid.values.astype(bool)
        xx, zz = np.meshgrid(x, z, indexing="ij")
        assert np.hypot(xx[solid], zz[solid] - ds.attrs["rod_z"]).max() < 1.5 * D


def test_the_velocity_relative_to_the_rigid_rod_is_zero_on_it(written) -> None:
    _, result, out = written
    with xr.open_dataset(out / "D4.nc") as ds:
        solid = ds.solid.values.astype(bool)
        assert solid.sum() >= 4
        assert np.all(ds.u_x_rel.values[solid] == 0.0) and np.all(ds.u_z.values[solid] == 0.0)
        assert ds.attrs["rod_speed"] == result.speed
        # outside the rod u_x_rel is the lab velocity minus the rod's speed
        free = ~solid
        np.testing.assert_allclose(ds.u_x_rel.values[free], ds.u_x.values[free] - result.speed, rtol=0, atol=1e-15)
        assert np.isnan(ds.p.values[solid]).all()


def test_a_scene_without_a_state_is_listed_not_written(tmp_path) -> None:
    runs, fl = [run("D4-r1", 4.0, 0.8)], [fields()]
    datasets, missing = mf.model_fields("ngf", PARAMS, runs, fl, [None], 2.0)
    assert datasets == {} and missing == ["D4"]
    mf.write_model_fields(datasets, missing, tmp_path / "out")
    assert json.loads((tmp_path / "out" / mf.INDEX).read_text()) == {"scenes": [], "not_solved": ["D4"]}
    assert mf.scene_name("D4-F0.4-r12") == "D4-F0.4" and mf.scene_name("D7") == "D7"
