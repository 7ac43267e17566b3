"""Solve one continuum model on the geometry of a DEM case: ``models/{case}/{model}.nc``.

The geometry (wall-to-wall depth, wall speed, load, gravity, grain size and density) is the
mean over the case's DEM replicas (read from their fields files); the parameters come from
``calibration/params.json``. The model is solved on its own uniform grid of ``n_grid`` nodes and
interpolated (linearly) onto the z of the DEM fields, so the two can be compared point by point;
``z`` is the DEM's (absolute) height and ``z_model`` the height above the bottom wall.

Usage: ``python -m pipeline.models.planar --config CONFIG --params params.json --case shear_gravity
--model ngf --fields F1.nc [F2.nc ...] --out models/shear_gravity/ngf.nc``
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

import continuum
from continuum.geometry import PlanarShear
from pipeline.common import atomic
from pipeline.calibration.calibrate import model_parameters, normal_stress_ratio
from pipeline.common.config import load_config
from pipeline.common.formats import FormatError, open_fields
from pipeline.common.planar_cell import planar_cell
from pipeline.common.provenance import provenance_attrs

MODELS_DEFAULTS: dict[str, Any] = {"n_grid": 400}


class ModelRunError(RuntimeError):
    """A model could not be solved on a case; the message names model, case and cause."""


def case_geometry(fields: list[xr.Dataset], params: dict[str, Any]) -> tuple[PlanarShear, float]:
    """Mean model cell of the replicas (contact planes, the calibration's sigma_zz / p) and the
    height of its bottom plane (m): :func:`pipeline.common.planar_cell.planar_cell`."""
    return planar_cell(fields, normal_stress_ratio(params))


def calibrated_range(solution: xr.Dataset, geometry: PlanarShear, params: dict[str, Any]) -> dict[str, Any]:
    """The largest inertial number the solution reaches against the largest the rheometer measured:
    above it the local laws are extrapolated (``outside_calibrated_range`` = 1)."""
    measured = max(float(s["I"]) for s in params["rheometer_states"])
    if "shear_rate" not in solution or "p" not in solution:
        return {"I_max_calibrated": measured}
    p = np.maximum(solution["p"].values, 1e-300)
    inertial = np.abs(solution["shear_rate"].values) * geometry.d / np.sqrt(p / geometry.rho_s)
    reached = float(np.nanmax(inertial)) if np.isfinite(inertial).any() else float("nan")
    return {"I_max_solution": reached, "I_max_calibrated": measured, "outside_calibrated_range": int(reached > measured)}


def solve_on_case(model: str, case: str, params: dict[str, Any], fields: list[xr.Dataset], n_grid: int) -> xr.Dataset:
    """The model's solution on the case, on the fields' z (see module docstring)."""
    geometry, z0 = case_geometry(fields, params)
    try:
        solution = continuum.solve(model, geometry, model_parameters(params, model), n_grid=n_grid, case=case)
    except continuum.ContinuumError as exc:
        raise ModelRunError(f"model {model} on case {case}: {exc}") from exc
    if not solution.attrs.get("converged", 0):
        raise ModelRunError(f"model {model} on case {case}: solver reports no convergence "
                            f"(residual {solution.attrs.get('residual')})")
    z_dem = fields[0].z.values
    z_model = np.clip(z_dem - z0, 0.0, geometry.depth)
    out = xr.Dataset(coords={"z": ("z", z_dem, {"units": "m", "long_name": "height (DEM frame)"})})
    out["z_model"] = ("z", z_model, {"units": "m", "long_name": "height above the bottom wall (model frame)"})
    for name, var in solution.data_vars.items():
        out[name] = ("z", np.interp(z_model, solution.z.values, var.values), dict(var.attrs))
    out.attrs.update(solution.attrs)
    out.attrs.update(calibrated_range(solution, geometry, params))
    out.attrs.update({"case": case, "depth": geometry.depth, "wall_speed": geometry.wall_speed,
                      "wall_pressure": geometry.wall_pressure, "gravity": geometry.gravity,
                      "z_bottom_wall": z0, "wall_planes": "contact", "d": geometry.d, "rho_s": geometry.rho_s,
                      "interpolation": "linear from the model grid onto the DEM fields' z"})
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Solve one continuum model on a DEM case's geometry.")
    parser.add_argument("--config", required=True)
    parser.add_argument("--params", required=True, type=Path)
    parser.add_argument("--case", required=True)
    parser.add_argument("--model", required=True, choices=continuum.MODEL_NAMES)
    parser.add_argument("--fields", nargs="+", required=True, type=Path)
    parser.add_argument("--out", required=True, type=Path)
    args = parser.parse_args(argv)
    config = load_config(args.config)
    params = json.loads(args.params.read_text())
    n_grid = int((MODELS_DEFAULTS | (config.get("models") or {}))["n_grid"])
    try:
        fields = [open_fields(f) for f in args.fields]
        solution = solve_on_case(args.model, args.case, params, fields, n_grid)
    except (ModelRunError, FormatError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    solution.attrs.update(provenance_attrs(config))
    atomic.write_netcdf(solution, args.out)
    print(f"{args.model} on {args.case}: n_grid {n_grid}, {solution.attrs['solve_seconds'] * 1e3:.2f} ms, "
          f"tau {solution.attrs.get('tau', float('nan')):.4g} Pa")
    return 0
