"""The intruder field scores (pipeline.scoring.intruder_field_scores) on synthetic fields: a DEM
field equal to the model's scores 0, one shifted by a known amount scores the shift; replicas
around the model give their scatter as u_dem and dem_noise; the window leaves the rod out; a model
without nu has no nu score; a scene a model does not cover is left out of its points."""
from __future__ import annotations

import math
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import pytest
import xarray as xr

from pipeline.scoring import intruder_field_scores as fs
from pipeline.scoring.uncertainty import ScoreSamples

D = 0.002
V = 0.1
LX = 8 * D
Z_BOTTOM, Z_TOP = 0.0012, 0.0262          # the DEM's wall grains' centres
Z0 = Z_BOTTOM + 0.5 * D                    # the model's bottom contact plane
H = Z_TOP - Z_BOTTOM - D
ROD_D = 3 * D
ROD_DEPTH = 5.0                            # d below the top wall's grains
ROD_Z = Z_TOP - ROD_DEPTH * D
WIDTH = 0.5 * D                            # the DEM's kernel width


def velocity(z):
    return V * (-0.2 + 0.9 * (z - Z0) / H)   # u_x relative to the rod


def w_velocity(z):
    return 0.01 * V * (z - Z0) / H


def mu(z):
    return 0.30 + 0.1 * (z - Z0) / H


def nu(z):
    return 0.60 - 0.03 * (z - Z0) / H


def dem_file(path: Path, run: str, du: float = 0.0, dmu: float = 0.0, dnu: float = 0.0, inside: float | None = None) -> Path:
    """A fields_xz file of a replica: the fields above (linear in z) plus the shifts; ``inside``: a
    value put on nu within the rod's radius plus half the kernel width (the rod's void)."""
    x = np.arange(0.25e-3, LX, 0.5e-3)
    z = np.arange(Z_BOTTOM, Z_TOP + 1e-9, 0.5e-3)
    xx, zz = np.meshgrid(x, z, indexing="ij")
    n = nu(zz) + dnu
    if inside is not None:
        n = np.where(np.hypot(xx - 0.5 * LX, zz - ROD_Z) < 0.5 * ROD_D + 0.5 * WIDTH, inside, n)
    rod_speed = 0.01
    data = {"u_x": velocity(zz) + du * V + rod_speed, "u_x_rel": velocity(zz) + du * V, "u_z": w_velocity(zz),
            "mu": mu(zz) + dmu, "nu": n}
    ds = xr.Dataset({k: (("x", "z"), v) for k, v in data.items()}
                    | {f"{k}_err": (("x", "z"), np.full_like(v, 1e-3)) for k, v in data.items() if k != "u_x_rel"},
                    coords={"x": x, "z": z},
                    attrs={"z_top_wall": Z_TOP, "z_bottom_wall": Z_BOTTOM, "rod_depth_over_d": ROD_DEPTH, "d": D,
                           "rod_centre_x": 0.5 * LX, "rod_diameter": ROD_D, "cell": [LX, 3 * D], "width": WIDTH,
                           "wall_speed": V, "rod_speed": rod_speed})
    out = path / f"{run}.nc"
    out.parent.mkdir(parents=True, exist_ok=True)
    ds.to_netcdf(out)
    return out


def model_file(folder: Path, scene: str, run: str, with_nu: bool = True) -> Path:
    """A model's fields file (pipeline.models.intruder_fields' layout) at 2 cells per d, NaN in its rod."""
    h = D / 2
    x = np.arange(-0.5 * LX + 0.5 * h, 0.5 * LX, h)
    z = Z0 + np.arange(0.5 * h, H, h)
    xx, zz = np.meshgrid(x, z, indexing="ij")
    solid = np.hypot(xx, zz - ROD_Z) < 0.5 * ROD_D
    data = {"u_x_rel": np.where(solid, 0.0, velocity(zz)), "u_z": np.where(solid, 0.0, w_velocity(zz)),
            "mu_xz": np.where(solid, np.nan, mu(zz))}
    if with_nu:
        data["nu"] = np.where(solid, np.nan, nu(zz))
    ds = xr.Dataset({k: (("x", "z"), v) for k, v in data.items()}, coords={"x": x, "z": z},
                    attrs={"cell": LX, "nx": x.size, "nz": z.size, "run": run, "model": folder.name})
    folder.mkdir(parents=True, exist_ok=True)
    out = folder / f"{scene}.nc"
    ds.to_netcdf(out)
    return out


class Settings:
    dem_resamples = 200
    seed = 7


def rows_by(scores: fs.FieldScores, model: str) -> dict[str, dict]:
    return {r["metric"]: r for r in scores.rows if r["model"] == model}


def test_a_dem_field_equal_to_the_model_s_scores_zero_and_a_shift_scores_the_shift(tmp_path) -> None:
    model_dir = tmp_path / "model_fields" / "ngf"
    model_file(model_dir, "D5", "D5-r1")
    same = [dem_file(tmp_path / "same", "D5-r1")]
    out = fs.score_intruder_fields(same, [model_dir], Settings())
    got = rows_by(out, "ngf")
    assert set(got) == set(fs.METRICS)
    for metric, row in got.items():
        assert row["value"] == pytest.approx(0.0, abs=1e-12), metric
        assert row["points"] == "D5" and row["dem_dof"] == math.inf  # one replica: its stated errors
        assert row["u_dem"] > 0.0
    floor = {r["metric"]: r["dem_err_rms"] for r in out.scene_rows}  # the stated errors, 1e-3 each
    assert floor["intruder_field_mu_rmse"] == pytest.approx(1e-3)
    assert floor["intruder_field_velocity_rmse"] == pytest.approx(math.sqrt(2) * 1e-3 / V)
    shifted = [dem_file(tmp_path / "shifted", "D5-r1", du=0.05, dmu=0.02, dnu=-0.01)]
    got = rows_by(fs.score_intruder_fields(shifted, [model_dir], Settings()), "ngf")
    assert got["intruder_field_velocity_rmse"]["value"] == pytest.approx(0.05, rel=1e-9)
    assert got["intruder_field_mu_rmse"]["value"] == pytest.approx(0.02, rel=1e-9)
    assert got["intruder_field_nu_rmse"]["value"] == pytest.approx(0.01, rel=1e-9)


def test_replicas_around_the_model_give_their_scatter_as_u_dem_and_dem_noise(tmp_path) -> None:
    """Two replicas at +-delta: their mean is the model's (score 0), a pair differs by 2 delta
    everywhere (dem_noise 2 delta), and the resampled mean moves as a whole by delta times a unit
    Gaussian, so the score's resamples are delta |N(0, 1)|, sd delta sqrt(1 - 2 / pi)."""
    model_dir = tmp_path / "model_fields" / "local_mu_i"
    model_file(model_dir, "D5", "D5-r1")
    delta = 0.01
    dem = [dem_file(tmp_path / "xz", "D5-r1", dmu=delta), dem_file(tmp_path / "xz", "D5-r2", dmu=-delta)]
    out = fs.score_intruder_fields(dem, [model_dir], Settings())
    row = rows_by(out, "local_mu_i")["intruder_field_mu_rmse"]
    assert row["value"] == pytest.approx(0.0, abs=1e-12)
    assert row["dem_noise"] == pytest.approx(2 * delta, rel=1e-9) and row["dem_noise_pairs"] == 1
    assert row["dem_dof"] == 1.0
    assert row["u_dem"] == pytest.approx(delta * math.sqrt(1 - 2 / math.pi), rel=0.2)
    scene = [r for r in out.scene_rows if r["metric"] == "intruder_field_mu_rmse"][0]
    assert scene["replicas"] == 2 and scene["scene"] == "D5" and scene["window_points"] > 100
    assert scene["dem_err_rms"] == pytest.approx(delta, rel=1e-9)  # the mean's standard error


def test_the_window_leaves_the_rod_and_its_kernel_out(tmp_path) -> None:
    """The DEM's nu falls to the rod's void within the rod and half a kernel width around it: not
    scored (the window starts a kernel width off the rod's surface)."""
    model_dir = tmp_path / "model_fields" / "ngf"
    model_file(model_dir, "D5", "D5-r1")
    dem = [dem_file(tmp_path / "xz", "D5-r1", inside=0.0)]
    got = rows_by(fs.score_intruder_fields(dem, [model_dir], Settings()), "ngf")
    assert got["intruder_field_nu_rmse"]["value"] == pytest.approx(0.0, abs=1e-12)
    with xr.open_dataset(dem[0]) as ds:
        mask = fs.window_mask(ds)
        xx, zz = np.meshgrid(ds.x.values, ds.z.values, indexing="ij")
    r = np.hypot(xx - 0.5 * LX, zz - ROD_Z)
    assert mask.any() and r[mask].min() > 0.5 * ROD_D + WIDTH
    assert np.abs(zz[mask] - ROD_Z).max() <= 3 * ROD_D


def test_a_model_without_nu_or_a_scene_has_no_score_there(tmp_path) -> None:
    """ngf without nu: no nu row; cosserat covers D5 only: its points name D5, and its per-scene
    terms let the verdict compare it with ngf on D5."""
    ngf_dir, cos_dir = tmp_path / "mf" / "ngf", tmp_path / "mf" / "cosserat"
    for scene in ("D5", "D7"):
        model_file(ngf_dir, scene, f"{scene}-r1", with_nu=False)
    model_file(cos_dir, "D5", "D5-r1")
    dem = [dem_file(tmp_path / "xz", "D5-r1", du=0.03), dem_file(tmp_path / "xz", "D7-r1", du=0.04),
           dem_file(tmp_path / "xz", "D9-r1")]  # D9: no model, not scored
    out = fs.score_intruder_fields(dem, [ngf_dir, cos_dir], Settings())
    ngf, cos = rows_by(out, "ngf"), rows_by(out, "cosserat")
    assert "intruder_field_nu_rmse" not in ngf and "intruder_field_nu_rmse" in cos
    vel = ngf["intruder_field_velocity_rmse"]
    assert vel["points"] == "D5 D7"
    assert vel["value"] == pytest.approx(math.sqrt((0.03**2 + 0.04**2) / 2), rel=1e-9)  # scenes weigh the same
    assert cos["intruder_field_velocity_rmse"]["points"] == "D5"
    sample: ScoreSamples = out.samples[("intruder", "ngf", "intruder_field_velocity_rmse")]
    assert sample.points == ["D5", "D7"] and sample.on_points(["D5"]).value == pytest.approx(0.03, rel=1e-9)
    table = out.table(["case", "model", "metric", "value", "points"])
    assert set(table.scene) == {"D5", "D7", "all"}


def test_the_single_replica_noise_has_unit_variance_to_the_walls() -> None:
    """The stated errors' resampling field: unit variance at every point, the walls' rows included
    (a reflecting filter doubled it there), correlated over the kernel width."""
    eps = fs.correlated_field(np.random.default_rng(1), 1000, (16, 40), (0.5e-3, 0.5e-3), 1e-3)
    var = eps.var(axis=0)
    assert np.all(np.abs(var - 1.0) < 0.15)
    near = np.corrcoef(eps[:, 8, 20], eps[:, 8, 21])[0, 1]
    far = np.corrcoef(eps[:, 8, 20], eps[:, 8, 30])[0, 1]
    assert near > 0.8 and abs(far) < 0.15


def test_the_command_writes_the_table_and_the_report_draws_it(tmp_path, monkeypatch) -> None:
    """``python -m pipeline.scoring.intruder_field_scores`` writes validation/intruder_fields.csv (the
    scenes' rows and the pooled ones); the report's section draws DEM and models side by side for
    one scene and tabulates the scores."""
    from pipeline.report import intruder_fields_section as section

    root = tmp_path / "results"
    for model in ("ngf", "local_mu_i"):
        model_file(root / "model_fields" / "intruder" / model, "D5", "D5-r1", with_nu=model != "ngf")
    dem = [dem_file(root / "fields_xz" / "intruder", "D5-r1", du=0.01),
           dem_file(root / "fields_xz" / "intruder", "D5-r2", du=-0.01)]
    for model in ("ngf", "local_mu_i"):  # the model files need what the figure draws
        path = root / "model_fields" / "intruder" / model / "D5.nc"
        ds = xr.load_dataset(path)
        ds["solid"] = (("x", "z"), np.isnan(ds.mu_xz.values).astype(np.int8))
        ds.to_netcdf(path)
    assert fs.main(["--fields-xz", *map(str, dem), "--model-fields", str(root / "model_fields" / "intruder" / "ngf"),
                    str(root / "model_fields" / "intruder" / "local_mu_i"),
                    "--out", str(root / "validation" / "intruder_fields.csv")]) == 0
    table = pd.read_csv(root / "validation" / "intruder_fields.csv")
    assert set(table.scene) == {"D5", "all"} and len(table[table.scene == "all"]) == 5  # ngf: no nu

    class Figures:
        names: list[str] = []

        def add(self, name, fig, caption):
            self.names.append(name)
            plt.close(fig)
            return f"<figure>{caption}</figure>"

    monkeypatch.setattr(section, "model_names", lambda config: ["local_mu_i", "ngf"])
    figures = Figures()
    html = section.intruder_fields_section(root, {"cases": {"intruder": {"geometry": "intruder"}}}, figures)
    assert figures.names == ["intruder_fields_models"] and "Scene D5" in html
    assert "intruder_field_velocity_rmse" in html and "DEM: replica against replica" in html
    assert section.intruder_fields_section(tmp_path / "empty", {"cases": {"intruder": {"geometry": "intruder"}}},
                                           figures) == ""
