"""DEM noise against cost: the sweeps' bookkeeping and their agreement with the score table."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pipeline.common.config import load_config, run_case, run_config, size_study_cell, size_study_runs
from pipeline.scoring.dem_convergence import AVERAGING_FRACTIONS, run_cost, truncated_fields
from pipeline.coarse_graining.fields import run_fields
from pipeline.common.formats import open_fields


def test_size_study_runs_keep_grains_per_area() -> None:
    case = load_config("config/studies/size.yaml")["cases"]["shear_gravity"]
    runs = size_study_runs(case)
    assert len(runs) == len(case["size_study"]["cells"]) * case["size_study"]["replicas"]
    base_density = case["n_grains"] / (case["cell_x"] * case["cell_y"])
    for run in runs:
        spec = run_case(case, run)
        cell = size_study_cell(run)
        assert spec["cell_x"] == spec["cell_y"] == cell
        # Same grains per area, hence the same bed height and pressures, to rounding of one grain.
        assert abs(spec["n_grains"] - base_density * cell**2) <= 0.5
    assert run_case(case, "r1") is case and size_study_cell("r1") is None


def test_size_study_has_its_own_production_cap() -> None:
    case = load_config("config/studies/size.yaml")["cases"]["shear_gravity"]
    study = case["size_study"] | {"production_strain": 1.5}
    case = case | {"size_study": study, "production_strain": 8.0}
    assert run_case(case, size_study_runs(case)[0])["production_strain"] == 1.5
    assert run_case(case, "r1")["production_strain"] == 8.0
    # Through the run's own DEM config (the study left out of it), as the DEM stage reads it.
    config = load_config("config/studies/size.yaml")
    config["cases"]["shear_gravity"] = case
    run = size_study_runs(case)[0]
    assert run_config(config, "shear_gravity", run)["cases"]["shear_gravity"]["production_strain"] == 1.5
    assert run_config(config, "shear_gravity", "r1")["cases"]["shear_gravity"]["production_strain"] == 8.0
    without = case | {"size_study": {k: v for k, v in study.items() if k != "production_strain"}}
    assert run_case(without, size_study_runs(without)[0])["production_strain"] == 8.0


def test_run_cost_splits_the_run_by_its_steps() -> None:
    run = {"wall_clock_seconds": 100.0, "mpi_ranks": 2, "production_chunks": 2, "chunk_steps": 1000, "steps": 8000}
    transient, production = run_cost(run)
    assert transient + production == pytest.approx(200.0)
    assert production == pytest.approx(50.0)


def test_whole_average_reproduces_the_fields_file(reduced_results: Path) -> None:
    """Re-averaging all snapshots from the per-snapshot sums gives the fields file back."""
    config = load_config(reduced_results / "config.effective.json")
    run_dir = reduced_results / "dem" / "shear_gravity" / "r1"
    result, _ = run_fields(config, run_dir, checks=False)
    ds = open_fields(reduced_results / "fields" / "shear_gravity" / "r1.nc")
    blocks = int(ds.attrs["error_blocks"])
    again = truncated_fields(result.dataset, result.sums, result.sums.shape[0], blocks)
    for name in ("u_x", "nu", "mu"):
        np.testing.assert_allclose(again[name].values, ds[name].values, rtol=1e-12, atol=1e-15)


def test_full_averaging_noise_is_the_score_tables_floor(reduced_results: Path) -> None:
    """The sweep's noise at full averaging and the default cell is the dem_noise of scores.csv:
    the same replicas, metric and mask. The other points cost less or are other cells."""
    table = pd.read_csv(reduced_results / "dem_convergence" / "shear_gravity.csv")
    scores = pd.read_csv(reduced_results / "scores.csv")
    config = json.loads((reduced_results / "config.effective.json").read_text())
    case = config["cases"]["shear_gravity"]
    full = table[(table.study == "averaging_time") & (table.averaging_fraction == 1.0)]
    for metric in ("log_velocity_rmse", "nu_rmse"):
        floor = scores[(scores.case == "shear_gravity") & (scores.metric == metric)].dem_noise.iloc[0]
        value = full[full.metric == metric].noise.iloc[0]
        assert value == pytest.approx(floor, rel=1e-9), metric
    sweep = table[(table.study == "averaging_time") & (table.metric == "nu_rmse")].sort_values("averaging_fraction")
    assert len(sweep) == len(AVERAGING_FRACTIONS)
    assert np.all(np.diff(sweep.core_seconds) > 0) and np.all(np.diff(sweep.averaging_strain) > 0)
    sizes = table[table.study == "system_size"]
    assert set(sizes.cell_over_d.round(6)) == {case["cell_x"], *case["size_study"]["cells"]}
    assert np.all(np.isfinite(sizes.noise)) and np.all(sizes.noise > 0)
