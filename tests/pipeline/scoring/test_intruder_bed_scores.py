"""The intruder bed's scores (pipeline.scoring.intruder_bed_scores) on synthetic files: a model whose
x-averaged velocity and top-wall stress equal the DEM's scores 0; a velocity shifted by a known
fraction of V scores that fraction; a stress off by 10 % scores 0.1; the rod's cells are left out of
the model's x-average; replicas give their scatter as u_dem and dem_noise."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from pipeline.scoring import intruder_bed_scores as bed

D = 0.002
V = 0.1
LX = 8 * D
Z_BOTTOM_PLANE, Z_TOP_PLANE = 0.0017, 0.0257
WIDTH = 0.5 * D
ROD_Z = 0.015
ROD_D = 3 * D
TAU = 85.0


def profile(z):
    return V * np.exp(-(Z_TOP_PLANE - z) / (2 * D))


def dem_file(folder: Path, run: str, du: float = 0.0, tau: float = TAU) -> Path:
    z = np.arange(Z_BOTTOM_PLANE - D, Z_TOP_PLANE + D, 0.25e-3)
    ds = xr.Dataset({"u_x": ("z", profile(z) + du * V), "u_x_err": ("z", np.full(z.size, 1e-4))}, coords={"z": z},
                    attrs={"width": WIDTH, "z_bottom_contact_plane": Z_BOTTOM_PLANE, "z_top_contact_plane": Z_TOP_PLANE,
                           "wall_top_shear_stress": tau, "wall_top_shear_stress_err": 0.5, "wall_speed": V})
    out = folder / f"{run}.nc"
    out.parent.mkdir(parents=True, exist_ok=True)
    ds.to_netcdf(out)
    return out


def model_file(folder: Path, scene: str, tau: float = TAU, inside: float = 0.0) -> Path:
    """A model's fields on 2 cells per d: the DEM's profile outside the rod, ``inside`` in it."""
    h = D / 2
    x = np.arange(-0.5 * LX + 0.5 * h, 0.5 * LX, h)
    z = Z_BOTTOM_PLANE + np.arange(0.5 * h, Z_TOP_PLANE - Z_BOTTOM_PLANE, h)
    xx, zz = np.meshgrid(x, z, indexing="ij")
    solid = np.hypot(xx, zz - ROD_Z) < 0.5 * ROD_D
    ds = xr.Dataset({"u_x": (("x", "z"), np.where(solid, inside, profile(zz))),
                     "sigma_xz": (("x", "z"), np.full(xx.shape, -tau)),
                     "solid": (("x", "z"), solid.astype(np.int8))},
                    coords={"x": x, "z": z}, attrs={"nx": x.size, "nz": z.size})
    out = folder / f"{scene}.nc"
    out.parent.mkdir(parents=True, exist_ok=True)
    ds.to_netcdf(out)
    return out


def scores(tmp_path: Path, dem_shifts: list[float], taus: list[float], model_tau: float = TAU) -> dict[str, dict]:
    files = [dem_file(tmp_path / "fields", f"D5-r{k + 1}", du, tau) for k, (du, tau) in enumerate(zip(dem_shifts, taus))]
    model_file(tmp_path / "model_fields" / "ngf", "D5", model_tau, inside=5 * V)
    out = bed.score_intruder_bed(files, [tmp_path / "model_fields" / "ngf"])
    return {r["metric"]: r for r in out.rows}


def test_a_model_equal_to_the_dem_scores_zero_and_its_rod_is_left_out(tmp_path: Path) -> None:
    rows = scores(tmp_path, [0.0], [TAU])
    # Left: the model's cell-centre profile linearly interpolated onto the DEM's z, (h / 2 d)^2 / 8
    # = 2e-3 V of an exponential of length 2 d at h = d / 2. The rod's cells move at 5 V: averaged in,
    # they would put about 0.6 V into the RMS (a third of the cells of 6 of 48 rows at 5 V).
    assert rows[bed.VELOCITY]["value"] < 3e-3
    assert rows[bed.WALL_STRESS]["value"] == pytest.approx(0.0, abs=1e-12)


def test_known_offsets_score_their_size(tmp_path: Path) -> None:
    # two replicas at -0.05 and +0.05 V around the model's - 0.1 V: the mean is 0.1 V off
    rows = scores(tmp_path, [0.05, 0.15], [TAU / 1.1, TAU / 1.1])
    assert rows[bed.VELOCITY]["value"] == pytest.approx(0.1, abs=2e-3)
    assert rows[bed.WALL_STRESS]["value"] == pytest.approx(0.1, rel=1e-9)
    # the replicas differ by 0.1 V: their pair scores 0.1, and the mean's error is 0.05 V
    assert rows[bed.VELOCITY]["dem_noise"] == pytest.approx(0.1, abs=2e-3)
    assert rows[bed.VELOCITY]["u_dem"] == pytest.approx(0.05, rel=0.2)
    assert rows[bed.VELOCITY]["dem_dof"] == 1.0


def test_a_missing_scene_gives_no_row(tmp_path: Path) -> None:
    files = [dem_file(tmp_path / "fields", "D7-r1")]
    model_file(tmp_path / "model_fields" / "ngf", "D5")
    out = bed.score_intruder_bed(files, [tmp_path / "model_fields" / "ngf"])
    assert out.rows == [] and not math.isnan(len(out.scene_rows))
