"""x-z fields around the intruder in its frame (real reduced runs)."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pyvista as pv
import xarray as xr

from pipeline.common.formats import open_fields
from pipeline.coarse_graining.coarse_grain import RULE_CHECK_LIMIT
from pipeline.coarse_graining.plane import CONTACT_POINTS


def sheared_runs(root: Path) -> list[str]:
    return sorted(p.parent.name for p in (root / "dem" / "intruder").glob("*/run.json") if "control" not in p.parent.name)


def test_x_average_is_the_runs_profile(reduced_dem: Path) -> None:
    """Shifting snapshots along the periodic x does not change x averages: the x mean of the
    rod-frame fields is the run's profile. The x grid's sum approximates the exact x integral of
    the profile's kernel (spacing below the kernel width): 2e-4 of the peak measured, 1e-2 allowed.

    The law holds for the sums linear in the grains (densities, momentum, contact stress). A
    velocity is a ratio, momentum over mass per cell: its profile is the x mean of the momentum
    over that of the mass, not the x mean of the ratio (which differs by 2 % next to the rod,
    where the mass varies along x).
    """
    for run in sheared_runs(reduced_dem):
        plane = xr.open_dataset(reduced_dem / "fields_xz" / "intruder" / f"{run}.nc")
        profile = open_fields(reduced_dem / "fields" / "intruder" / f"{run}.nc")
        np.testing.assert_allclose(plane.z.values, profile.z.values, rtol=0, atol=1e-12)
        # the contact integral the file used: the rule where its check passed, else the exact one
        ruled = plane.attrs["contact_integral"] == f"gauss_legendre_{CONTACT_POINTS}"
        assert ruled or plane.attrs["contact_integral"] == "exact", run
        assert ruled == (plane.attrs["contact_rule_check"] <= RULE_CHECK_LIMIT), run
        momentum = (plane.rho * plane.u_x.fillna(0.0)).mean("x")
        linear = {name: (plane[name].mean("x"), profile[name]) for name in ("nu", "rho", "rho_body", "sigma_xz_contact")}
        linear["momentum_x"] = (momentum, profile.rho * profile.u_x)
        linear["u_x"] = (momentum / plane.rho.mean("x"), profile.u_x)
        for name, (x_mean, expected) in linear.items():
            scale = float(np.nanmax(np.abs(expected.values)))
            np.testing.assert_allclose(x_mean.values, expected.values, rtol=0, atol=1e-2 * scale, err_msg=f"{run}: {name}")


def test_rod_sits_at_the_cell_centre_with_no_flowing_grains_inside(reduced_dem: Path) -> None:
    for run in sheared_runs(reduced_dem):
        plane = xr.open_dataset(reduced_dem / "fields_xz" / "intruder" / f"{run}.nc")
        rod = json.loads((reduced_dem / "dem" / "intruder" / run / "run.json").read_text())["intruder"]
        centre = plane.rho_body.sel(x=plane.attrs["rod_centre_x"], z=rod["z"], method="nearest")
        # Had the shift missed the rod, its hole would be smeared over x and filled with grains.
        assert float(centre) < 0.05 * float(plane.rho_body.max()), run
        grid = pv.read(reduced_dem / "fields_xz" / "intruder" / f"{run}.vts")
        assert grid.n_points == plane.sizes["x"] * plane.sizes["z"]
        np.testing.assert_allclose(np.sort(grid.point_data["nu"]), np.sort(plane.nu.values.ravel()))
