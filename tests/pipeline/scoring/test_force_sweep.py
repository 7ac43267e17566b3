"""The force sweep's scores pair each model's speed with the DEM's at every push."""
from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import xarray as xr

from pipeline.scoring.force_sweep import LOG_METRIC, SLOPE_METRIC, at_pushes, score_force_sweep

#: run.json's push for 0.9 F_y as the DEM stage writes it (0.3 x 3), which the sweep groups round.
PUSHES = (0.3, 0.6, 0.3 * 3)
DEM_SPEEDS = {0.3: (2.0e-4, 3.0e-4, 2.5e-4), 0.6: (4.0e-3, 5.0e-3, 4.5e-3), PUSHES[2]: (3.0e-2, 4.0e-2, 3.5e-2)}


def runs() -> list[dict]:
    return [{"intruder": {"force_sweep": True, "control": False, "push_over_yield": p, "speed": u, "speed_err": 0.1 * u}}
            for p in PUSHES for u in DEM_SPEEDS[p]]


def model_file(tmp_path: Path, speeds: list[float]) -> Path:
    path = tmp_path / "model.nc"
    xr.Dataset({"sweep_speed": ("push_over_yield", np.asarray(speeds))},
               coords={"push_over_yield": list(PUSHES)}, attrs={"n_grid": 100, "solve_seconds": 1.0}).to_netcdf(path)
    return path


def test_the_push_of_run_json_is_paired_with_its_rounded_group() -> None:
    assert PUSHES[2] != 0.9
    assert at_pushes(np.array(PUSHES), np.array([1.0, 2.0, 3.0]), np.array([0.3, 0.6, 0.9])).tolist() == [1.0, 2.0, 3.0]
    # a push no scene solved is not interpolated
    assert np.isnan(at_pushes(np.array(PUSHES), np.array([1.0, 2.0, 3.0]), np.array([0.45]))).all()


def test_a_model_equal_to_the_dem_means_scores_zero_on_every_push(tmp_path: Path) -> None:
    means = [float(np.mean(DEM_SPEEDS[p])) for p in PUSHES]
    rows, _, table = score_force_sweep(runs(), {"m": model_file(tmp_path, means)}, None,
                                       SimpleNamespace(seed=1, dem_resamples=50, confidence=0.95))
    by_metric = {r["metric"]: r for r in rows}
    assert by_metric[LOG_METRIC]["points"] == "F0.3 F0.6 F0.9"
    assert by_metric[LOG_METRIC]["value"] == pytest.approx(0.0, abs=1e-12)
    assert by_metric[SLOPE_METRIC]["value"] == pytest.approx(0.0, abs=1e-12)
    speeds = table[(table.source == "m") & table.push_over_yield.notna()].speed.to_numpy()
    np.testing.assert_allclose(speeds, means)


def test_a_model_a_decade_fast_at_every_push_scores_one_decade(tmp_path: Path) -> None:
    fast = [10.0 * float(np.mean(DEM_SPEEDS[p])) for p in PUSHES]
    rows, _, _ = score_force_sweep(runs(), {"m": model_file(tmp_path, fast)}, None,
                                   SimpleNamespace(seed=1, dem_resamples=50, confidence=0.95))
    by_metric = {r["metric"]: r for r in rows}
    assert by_metric[LOG_METRIC]["value"] == pytest.approx(1.0, abs=1e-12)
    assert by_metric[SLOPE_METRIC]["value"] == pytest.approx(0.0, abs=1e-12)
