"""Solve one continuum model on the geometry of a DEM case: ``models/{case}/{model}.nc``.

The geometry (wall-to-wall depth, wall speed, load, gravity, grain size and density) is the
mean over the case's DEM replicas (read from their fields files); the parameters come from
``calibration/params.json``. The model is solved on its own uniform grid of ``n_grid`` nodes and
interpolated (linearly) onto the z of the DEM fields, so the two can be compared point by point;
``z`` is the DEM's (absolute) height and ``z_model`` the height above the bottom wall.

With ``--draws calibration/draws.json --draws-out model_draws/{case}/{model}.nc`` the model is also
solved once per parameter draw of the calibration's uncertainty (:mod:`pipeline.calibration.draws`)
and, with the calibration's own values, on a grid twice as fine (the ``*_refined`` variables: the
grid's share of a score's uncertainty, ``u_num``); :func:`solve_draws`.

Usage: ``python -m pipeline.models.planar --config CONFIG --params params.json --case shear_gravity
--model ngf --fields F1.nc [F2.nc ...] --out models/shear_gravity/ngf.nc [--draws D --draws-out F]``
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
from pipeline.calibration.parameter_sets import model_parameters, normal_stress_ratio, params_of_draw, slip_length
from pipeline.common.config import load_config
from pipeline.common.formats import FormatError, open_fields
from pipeline.common.planar_cell import planar_cell
from pipeline.common.provenance import provenance_attrs

MODELS_DEFAULTS: dict[str, Any] = {"n_grid": 400}

#: The wall's scalars of a solution (its attribute names) that the draws files carry per draw.
WALL_SCALARS = {"wall_shear_stress": "tau", "top_wall_slip": "top_wall_slip"}
WALL_UNITS = {"wall_shear_stress": "Pa", "top_wall_slip": "m s-1"}
WALL_NAMES = {"wall_shear_stress": "the top wall's shear stress (the model's uniform sigma_xz)",
              "top_wall_slip": "the top wall's speed less the grains' at its plane (Navier slip)"}


class ModelRunError(RuntimeError):
    """A model could not be solved on a case; the message names model, case and cause."""


def case_geometry(fields: list[xr.Dataset], params: dict[str, Any]) -> tuple[PlanarShear, float]:
    """Mean model cell of the replicas (contact planes, the calibration's sigma_zz / p) and the
    height of its bottom plane (m): :func:`pipeline.common.planar_cell.planar_cell`."""
    return planar_cell(fields, normal_stress_ratio(params), slip_length=slip_length(params))


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
    # The scores compare at equal depth below the top contact plane (pipeline.scoring.replicas):
    # the first replica's z, measured down from its own top plane, placed below the model's top.
    top = float(fields[0].attrs.get("z_top_contact_plane", z0 + geometry.depth))
    z_model = np.clip(geometry.depth - (top - z_dem), 0.0, geometry.depth)
    out = xr.Dataset(coords={"z": ("z", z_dem, {"units": "m", "long_name": "height (DEM frame)"})})
    out["z_model"] = ("z", z_model, {"units": "m", "long_name": "height above the bottom wall (model frame): the "
                                     "model's depth less the depth below the first replica's top contact plane"})
    for name, var in solution.data_vars.items():
        out[name] = ("z", np.interp(z_model, solution.z.values, var.values), dict(var.attrs))
    out.attrs.update(solution.attrs)
    out.attrs.update(calibrated_range(solution, geometry, params))
    out.attrs.update({"case": case, "depth": geometry.depth, "wall_speed": geometry.wall_speed,
                      "wall_pressure": geometry.wall_pressure, "gravity": geometry.gravity,
                      "z_bottom_wall": z0, "wall_planes": "contact", "d": geometry.d, "rho_s": geometry.rho_s,
                      "interpolation": "linear from the model grid onto the DEM fields' z"})
    return out


def solve_draws(model: str, case: str, params: dict[str, Any], ensemble: dict[str, Any], fields: list[xr.Dataset],
                n_grid: int) -> xr.Dataset:
    """The model on the case for every parameter draw (dims ``draw``, ``z``: the fields' z) and, with
    the calibration's values, on ``2 n_grid - 1`` nodes (``<name>_refined``: the nominal grid's nodes
    halved). A draw the model cannot be solved for (``solved`` = 0) keeps NaN and its reason in the
    ``failures`` attribute (JSON: draw -> reason)."""
    nominal = solve_on_case(model, case, params, fields, n_grid)
    try:
        refined = solve_on_case(model, case, params, fields, 2 * n_grid - 1)
        refined_failure = ""
    except ModelRunError as exc:
        # The grid's share of the uncertainty is then unknown: said in the file, not replaced.
        refined, refined_failure = nominal.copy(deep=True), str(exc)[:300]
        refined.attrs.update({attr: np.nan for attr in WALL_SCALARS.values()})
        for name, var in refined.data_vars.items():
            if np.issubdtype(var.dtype, np.floating):
                refined[name] = var * np.nan
    names = [n for n, v in nominal.data_vars.items() if v.dims == ("z",) and n != "z_model"]
    draws = ensemble["draws"]
    data = {n: np.full((len(draws), nominal.sizes["z"]), np.nan) for n in names}
    solved = np.zeros(len(draws), dtype=np.int8)
    seconds = np.full(len(draws), np.nan)
    walls = {n: np.full(len(draws), np.nan) for n in WALL_SCALARS}
    failures: dict[int, str] = {}
    for k, draw in enumerate(draws):
        if model in draw.get("failed", {}):
            failures[k] = draw["failed"][model]
            continue
        try:
            sol = solve_on_case(model, case, params_of_draw(params, draw), fields, n_grid)
        except (ModelRunError, ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
            # A draw the model cannot be solved for is a property of the model over the calibration's
            # uncertainty: recorded with its reason, not a failure of the step.
            failures[k] = f"{type(exc).__name__}: {exc}"[:300]
            continue
        for n in names:
            if n in sol:
                data[n][k] = sol[n].values
        solved[k] = 1
        seconds[k] = float(sol.attrs["solve_seconds"])
        for n, attr in WALL_SCALARS.items():
            walls[n][k] = float(sol.attrs.get(attr, np.nan))
    out = xr.Dataset(coords={"draw": ("draw", np.arange(len(draws)), {"units": "1", "long_name": "parameter draw"}),
                             "z": nominal.z})
    for n in names:
        out[n] = (("draw", "z"), data[n], dict(refined[n].attrs))
        out[f"{n}_refined"] = ("z", refined[n].values, dict(nominal[n].attrs) | {
            "long_name": f"{nominal[n].attrs.get('long_name', n)}, calibration's values on the refined grid"})
    for n, attr in WALL_SCALARS.items():
        out[n] = ("draw", walls[n], {"units": WALL_UNITS[n], "long_name": WALL_NAMES[n]})
        out[f"{n}_refined"] = ((), float(refined.attrs.get(attr, np.nan)),
                               {"units": WALL_UNITS[n], "long_name": f"{WALL_NAMES[n]}, refined grid"})
    out["solved"] = ("draw", solved, {"units": "1", "long_name": "1 where the draw was solved"})
    out["solve_seconds"] = ("draw", seconds, {"units": "s", "long_name": "solve time of the draw"})
    out.attrs.update({"model": model, "case": case, "n_grid": n_grid, "n_grid_refined": 2 * n_grid - 1,
                      "refined_failure": refined_failure,
                      "n_draws": len(draws), "n_solved": int(solved.sum()), "failures": json.dumps(failures),
                      "draws_seed": int(ensemble.get("seed", -1))})
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Solve one continuum model on a DEM case's geometry.")
    parser.add_argument("--config", required=True)
    parser.add_argument("--params", required=True, type=Path)
    parser.add_argument("--case", required=True)
    parser.add_argument("--model", required=True, choices=continuum.MODEL_NAMES)
    parser.add_argument("--fields", nargs="+", required=True, type=Path)
    parser.add_argument("--out", required=True, type=Path)
    parser.add_argument("--draws", type=Path, help="calibration/draws.json: also solve every parameter draw")
    parser.add_argument("--draws-out", type=Path, help="where the draws' solutions go (model_draws/CASE/MODEL.nc)")
    args = parser.parse_args(argv)
    if (args.draws is None) != (args.draws_out is None):
        parser.error("--draws and --draws-out go together")
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
    if args.draws is not None:
        try:
            ensemble = solve_draws(args.model, args.case, params, json.loads(args.draws.read_text()), fields, n_grid)
        except ModelRunError as exc:
            print(f"error: {exc} (refined grid)", file=sys.stderr)
            return 1
        ensemble.attrs.update(provenance_attrs(config))
        atomic.write_netcdf(ensemble, args.draws_out)
        print(f"{args.model} on {args.case}: {ensemble.attrs['n_solved']} of {ensemble.attrs['n_draws']} draws solved")
    atomic.write_netcdf(solution, args.out)
    print(f"{args.model} on {args.case}: n_grid {n_grid}, {solution.attrs['solve_seconds'] * 1e3:.2f} ms, "
          f"tau {solution.attrs.get('tau', float('nan')):.4g} Pa")
    return 0
