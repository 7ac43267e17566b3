"""Mesh dependence of every continuum model: ``stability/mesh_convergence.csv``.

Two cases, both on the shear_gravity DEM geometry (depth, wall speed, load, grain size and
density: the mean over the replicas' fields files, :func:`pipeline.models.planar.case_geometry`):

* ``shear_gravity``: the DEM case itself, each model with its default initial state (the
  rate-independent models start from a critical packing, as left by earlier shearing).
* ``weak_plane``: the same layer without gravity, with an initial packing denser than critical
  by 0.005 except a smooth dip (half-width 2 d) at 0.4142 H
  (:func:`continuum.mesh_study.weak_plane_packing`). Why this localisation case: without gravity
  the pressure is uniform and nothing but the packing selects where a rate-independent material
  yields, so it exposes whether a model's band has a width of its own (set by a material length)
  or one set by the grid; the rate-dependent models (local mu(I), NGF, Cosserat here) ignore the
  packing and shear homogeneously or smoothly, and must converge.

Columns: ``case, model, n_grid, dx, band_width, u_x_rmse_vs_finest, converged, solve_seconds,
error`` (definitions in :mod:`continuum.mesh_study`; dx and band_width in m, rmse relative to the
wall speed). Rows whose solve raised keep the solver's message in ``error``.

Usage: ``python -m pipeline.stability.mesh_convergence --params calibration/params.json
--fields fields/shear_gravity/r1.nc [r2.nc ...] --out stability/mesh_convergence.csv``
"""
from __future__ import annotations

import argparse
import json
from dataclasses import replace
from pathlib import Path
from typing import Any, Sequence

import pandas as pd
import xarray as xr

import continuum
from continuum.geometry import PlanarShear
from continuum.mesh_study import N_GRIDS, mesh_study, weak_plane_packing
from pipeline.common.cli import positive_int
from pipeline.calibration.parameter_sets import CalibrationError, model_parameters
from pipeline.models.planar import case_geometry


def calibrated_parameters(params: dict[str, Any]) -> tuple[dict[str, Any], dict[str, str]]:
    """Parameter dataclasses of every model that params.json calibrates, and the reason for
    each model it cannot build (e.g. no non-local calibration)."""
    built: dict[str, Any] = {}
    missing: dict[str, str] = {}
    for model in continuum.MODEL_NAMES:
        try:
            built[model] = model_parameters(params, model)
        except CalibrationError as exc:
            missing[model] = str(exc)
    return built, missing


def study(geometry: PlanarShear, params: dict[str, Any], n_grids: Sequence[int] = N_GRIDS) -> pd.DataFrame:
    """The mesh-convergence table of both cases (see module docstring) from a params.json dict."""
    built, missing = calibrated_parameters(params)
    frames = [mesh_study(geometry, built, n_grids, case="shear_gravity")]
    layer = replace(geometry, gravity=0.0)
    if "critical_state" in built:
        packing = weak_plane_packing(layer, built["critical_state"].line)
    else:  # no critical-state line, no packing to perturb: the rate-dependent models only
        packing = None
    frames.append(mesh_study(layer, built, n_grids, case="weak_plane", nu_initial=packing))
    table = pd.concat(frames, ignore_index=True)
    extra = [{"case": case, "model": model, "error": f"not calibrated: {reason}"}
             for case in ("shear_gravity", "weak_plane") for model, reason in missing.items()]
    if extra:
        table = pd.concat([table, pd.DataFrame(extra)], ignore_index=True)
    return table


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Band width and u_x against grid spacing for every model.")
    parser.add_argument("--params", required=True, type=Path, help="calibration/params.json")
    parser.add_argument("--fields", required=True, nargs="+", type=Path, help="fields of the shear_gravity replicas")
    parser.add_argument("--out", required=True, type=Path)
    parser.add_argument("--n-grid", type=positive_int, nargs="+", default=list(N_GRIDS), help="grid sizes (default 16..4096)")
    args = parser.parse_args(argv)
    params = json.loads(args.params.read_text())
    fields = [xr.open_dataset(f) for f in args.fields]
    geometry, _ = case_geometry(fields, params)
    for ds in fields:
        ds.close()
    table = study(geometry, params, args.n_grid)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.out.with_name(args.out.name + ".tmp")
    table.to_csv(tmp, index=False)
    tmp.replace(args.out)
    d = geometry.d
    view = table.assign(dx_over_d=table.dx / d, band_width_over_d=table.band_width / d)
    print(view.pivot_table(index=["case", "model"], columns="n_grid", values="band_width_over_d").round(4).to_string())
    print(view.groupby(["case", "model"])["converged"].max().to_string())
    return 0
