"""Scores on synthetic profiles with known differences give the known values."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from pipeline.scoring import metrics
from pipeline.scoring.metrics import MetricError, Profile
from pipeline.scoring.scores import score_case

V = 0.1
Z = np.linspace(0.0, 0.04, 201)


def creep(z: np.ndarray, length: float) -> np.ndarray:
    """Exponential creep below a moving wall at z = 0.04 m."""
    return V * np.exp((z - Z[-1]) / length)


def test_velocity_rmse_of_a_constant_offset() -> None:
    assert metrics.velocity_rmse_rel(Z, creep(Z, 0.004) + 0.01, creep(Z, 0.004), V) == pytest.approx(0.1)


def test_log_rmse_of_a_constant_factor() -> None:
    dem = Profile(Z, creep(Z, 0.004), np.full_like(Z, 1e-12))
    mask = metrics.creeping_mask(dem, V)
    assert mask.sum() > 20
    assert metrics.log_velocity_rmse(3.0 * dem.u, dem, mask) == pytest.approx(math.log10(3.0), rel=1e-12)


def test_zero_prediction_in_the_creeping_zone_scores_infinite() -> None:
    dem = Profile(Z, creep(Z, 0.004), np.full_like(Z, 1e-12))
    mask = metrics.creeping_mask(dem, V)
    model = np.where(Z > 0.035, dem.u, 0.0)
    assert metrics.log_velocity_rmse(model, dem, mask) == math.inf
    assert metrics.decay_length_rel_err(Z, model, dem, mask) == math.inf


def test_decay_length_error_of_a_longer_creep() -> None:
    dem = Profile(Z, creep(Z, 0.004), np.full_like(Z, 1e-12))
    mask = metrics.creeping_mask(dem, V)
    assert metrics.decay_length(Z, dem.u, mask) == pytest.approx(0.004, rel=1e-9)
    assert metrics.decay_length_rel_err(Z, creep(Z, 0.005), dem, mask) == pytest.approx(0.25, rel=1e-9)


def test_band_width_of_a_linear_profile_and_a_jump() -> None:
    linear = V * Z / Z[-1]
    assert metrics.shear_band_width(Z, linear, V) == pytest.approx(0.8 * Z[-1], rel=1e-9)
    jump = np.where(Z > 0.02, V, 0.0)
    assert metrics.shear_band_width(Z, jump, V) <= Z[1] - Z[0]
    assert metrics.shear_band_width_rel_err(Z, V * (Z / Z[-1]) ** 2, linear, V) == pytest.approx(
        abs((math.sqrt(0.9) - math.sqrt(0.1)) - 0.8) / 0.8, rel=1e-3)


def test_unresolved_dem_creep_is_an_error_not_a_score() -> None:
    dem = Profile(Z, creep(Z, 0.004), np.full_like(Z, 1.0))  # errors larger than every value
    with pytest.raises(MetricError):
        metrics.log_velocity_rmse(dem.u, dem, metrics.creeping_mask(dem, V))


def fields_file(path: Path, u: np.ndarray, nu: float, rng: np.random.Generator | None = None) -> Path:
    ds = xr.Dataset(coords={"z": Z})
    for name, values in (("u_x", u), ("nu", np.full_like(Z, nu)), ("mu", np.full_like(Z, 0.3))):
        ds[name] = ("z", values)
        ds[f"{name}_err"] = ("z", np.full_like(Z, 1e-12))
    ds.attrs.update({"d": 0.002, "z_bottom_wall": 0.0, "z_top_wall": float(Z[-1]), "wall_speed": V})
    ds.to_netcdf(path)
    return path


def test_score_case_rows_and_noise_floor(tmp_path: Path) -> None:
    (tmp_path / "f").mkdir()
    reps = [fields_file(tmp_path / "f" / f"r{k}.nc", creep(Z, 0.004) * (1 + 0.01 * k), 0.6 + 0.001 * k) for k in (1, 2)]
    model = xr.Dataset(coords={"z": Z})
    model["u_x"] = ("z", 2.0 * creep(Z, 0.004))
    model.attrs.update({"n_grid": 100, "solve_seconds": 0.001})
    model.to_netcdf(tmp_path / "m.nc")
    table, _ = score_case("shear_gravity", reps, {"toy": tmp_path / "m.nc"})
    rows = table.set_index("metric")
    # The model predicts u only: no nu or mu rows, never a placeholder.
    assert "nu_rmse" not in rows.index and "mu_rmse" not in rows.index
    # Against the replica mean (factor 1.015): log10(2 / 1.015).
    assert rows.loc["log_velocity_rmse", "value"] == pytest.approx(math.log10(2.0 / 1.015), rel=1e-9)
    # Replica against replica: log10(1.02 / 1.01).
    assert rows.loc["log_velocity_rmse", "dem_noise"] == pytest.approx(abs(math.log10(1.01 / 1.02)), rel=1e-9)
