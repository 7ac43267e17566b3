"""Accuracy against cost: every model's error against the DEM over sweeps of grid resolution and
of solver tolerance.

For each planar scored case and model, the model is solved on grids of ``N_GRIDS`` nodes (at the
solver's default tolerance), and on ``TOLERANCE_GRID`` nodes at each of ``TOLERANCES`` (the
``tolerance`` of ``continuum.solve``: the relative residual of the wall condition, or of the
yield iteration; empty = the solver's default, machine precision); each
solution is compared with the replica-mean DEM profile (``velocity_rmse_rel`` and
``log_velocity_rmse``, as in ``scores.csv``) and timed (best of ``REPEATS`` solves, so that
the time is the solver's, not the machine's load). Written to ``cost_accuracy.csv``.

Usage: ``python -m pipeline.scoring.cost_accuracy --params params.json --fields F1.nc F2.nc ... --out cost_accuracy.csv``
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
import pandas as pd

import continuum
from pipeline.common import atomic
from pipeline.scoring import metrics
from pipeline.calibration.parameter_sets import model_parameters
from pipeline.scoring.metrics import MetricError, Profile
from pipeline.scoring.replicas import interior, mean_profile, replica_profiles
from pipeline.models.planar import case_geometry

N_GRIDS = (16, 32, 64, 128, 256, 512, 1024)
TOLERANCE_GRID = 256
TOLERANCES = (1e-1, 1e-2, 1e-4, 1e-8)
REPEATS = 3
COLUMNS = ["case", "model", "sweep", "n_grid", "tolerance", "solve_seconds", "velocity_rmse_rel", "log_velocity_rmse",
           "error"]


def sweep(case: str, field_files: list[Path], params: dict, models: list[str]) -> pd.DataFrame:
    """Error and solve time of each model on each grid of ``N_GRIDS``."""
    reps = replica_profiles(field_files)
    geometry, z0 = case_geometry(reps, params)
    mask = interior(reps[0])
    z = reps[0].z.values
    dem_u, dem_err = mean_profile(reps, "u_x")
    dem = Profile(z[mask], dem_u[mask], dem_err[mask])
    creeping = metrics.creeping_mask(dem, geometry.wall_speed)
    rows = []
    plan = [("grid", n, None) for n in N_GRIDS] + [("tolerance", TOLERANCE_GRID, t) for t in TOLERANCES]
    for model in models:
        parameters = model_parameters(params, model)
        for sweep_name, n_grid, tolerance in plan:
            row = {"case": case, "model": model, "sweep": sweep_name, "n_grid": n_grid,
                   "tolerance": np.nan if tolerance is None else tolerance, "error": ""}
            try:
                best = np.inf
                for _ in range(REPEATS):
                    t0 = time.perf_counter()
                    sol = continuum.solve(model, geometry, parameters, n_grid=n_grid, case=case, tolerance=tolerance)
                    best = min(best, time.perf_counter() - t0)
            except continuum.ContinuumError as exc:
                rows.append(row | {"solve_seconds": np.nan, "velocity_rmse_rel": np.nan, "log_velocity_rmse": np.nan,
                                   "error": str(exc)})
                continue
            if "u_x" not in sol:
                continue  # no velocity predicted (rate-independent model without gravity)
            u = np.interp(np.clip(z - z0, 0.0, geometry.depth), sol.z.values, sol.u_x.values)[mask]
            row["solve_seconds"] = best
            row["velocity_rmse_rel"] = metrics.velocity_rmse_rel(dem.z, u, dem.u, geometry.wall_speed)
            try:
                row["log_velocity_rmse"] = metrics.log_velocity_rmse(u, dem, creeping)
            except MetricError:
                row["log_velocity_rmse"] = np.nan
            rows.append(row)
    return pd.DataFrame(rows, columns=COLUMNS)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Model error against DEM over a sweep of grid resolution.")
    parser.add_argument("--params", required=True, type=Path)
    parser.add_argument("--fields", nargs="+", required=True, type=Path, help="fields/CASE/RUN.nc files")
    parser.add_argument("--models", nargs="+", default=list(continuum.MODEL_NAMES))
    parser.add_argument("--out", required=True, type=Path)
    args = parser.parse_args(argv)
    params = json.loads(args.params.read_text())
    frames = []
    for case in sorted({p.parent.name for p in args.fields}):
        frames.append(sweep(case, [p for p in args.fields if p.parent.name == case], params, args.models))
    table = pd.concat(frames, ignore_index=True)
    atomic.write_csv(table, args.out)
    print(table.to_string(index=False))
    return 0
