"""Each model's intruder speed at the DEM's depths: ``models/intruder/{model}.nc``.

For every sheared intruder run (the controls are DEM checks, not predictions) the geometry comes
from the run's fields file (wall-to-wall depth, load, gravity, wall speed) and its run.json (rod
diameter, depth below the top wall, push force); the model parameters from params.json.
``continuum.intruder.intruder_speed`` does the solve: NGF in 2D (far-field fluidity, small-force
limit), the local models by a yield-force check, the volume-averaged model from its 1D creep
(docs/intruder.md). A depth the model refuses (rod in its flowing layer, push above its yield
force) is not written as a number: it is listed in the ``refused`` attribute with the reason.

Usage: ``python -m pipeline.models.intruder --config C --params params.json --model ngf
--runs RESULTS/dem/intruder/D4-r1/run.json ... --fields RESULTS/fields/intruder/D4-r1.nc ... --out F.nc``
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

import continuum
from continuum.intruder import GridOptions, RodIntruder, intruder_speed
from pipeline.common.formats import open_fields
from pipeline.common import atomic
from pipeline.calibration.calibrate import model_parameters, normal_stress_ratio
from pipeline.common.planar_cell import planar_cell
from pipeline.common.config import load_config
from pipeline.common.provenance import provenance_attrs


def predict(model: str, params: dict[str, Any], runs: list[dict[str, Any]], fields: list[xr.Dataset],
            cells_per_d: float = 4.0) -> xr.Dataset:
    """The model's speed at each sheared run's depth (see module docstring)."""
    depths, speeds, seconds, grids, refused, bounded = [], [], [], [], [], []
    parameters = model_parameters(params, model)
    for run, ds in zip(runs, fields, strict=True):
        rod = run["intruder"]
        geometry, z0 = planar_cell([ds], normal_stress_ratio(params))
        # run.json gives the rod's depth below the top wall's grain centres; the cell's top is its contact plane.
        rod_z = float(ds.attrs["z_top_wall"]) - rod["depth"]
        intruder = RodIntruder.below_top(geometry, rod["diameter"], z0 + geometry.depth - rod_z, rod["force"] / rod["length"])
        label = f"{run['case']}/{run['run']}"
        try:
            result = intruder_speed(model, geometry, parameters, intruder, float(run["cell"][0]),
                                    GridOptions(cells_per_d=cells_per_d), case=label)
        except continuum.OutOfRangeError as exc:
            refused.append(f"{rod['depth_over_d']:.2f} d: {exc}")
            continue
        if not result.converged:
            raise continuum.ConvergenceError(model, result.residual, "intruder solve did not converge", label)
        if not np.isfinite(result.speed) or abs(result.speed) > geometry.wall_speed:
            # A rod pushed below its yield force in the creeping zone cannot outrun the wall: such a
            # number comes from an ill-conditioned solve (e.g. a fluidity that underflows), not physics.
            refused.append(f"{rod['depth_over_d']:.2f} d: solve failed: speed {result.speed:.3g} m/s exceeds the wall "
                           f"speed {geometry.wall_speed:g} m/s (ill-conditioned 2D solve)")
            continue
        depths.append(rod["depth_over_d"])
        speeds.append(result.speed)
        seconds.append(result.solve_seconds)
        grids.append(result.n_grid)
        bounded.append(bool(result.attrs.get("floor_at_rod", False)))
    order = np.argsort(depths)
    out = xr.Dataset(coords={"depth_over_d": ("depth_over_d", np.asarray(depths)[order],
                                              {"units": "1", "long_name": "rod axis below the top wall, in d"})})
    out["speed"] = ("depth_over_d", np.asarray(speeds, dtype=float)[order],
                    {"units": "m s-1", "long_name": "steady rod speed along +x"})
    out["speed_is_upper_bound"] = ("depth_over_d", np.asarray(bounded, dtype=np.int8)[order],
                                   {"units": "1", "long_name": "1 where the NGF fluidity floor reaches the rod: "
                                    "the speed is an upper bound (continuum/intruder/ngf2d.py FLUIDITY_FLOOR)"})
    out["solve_seconds"] = ("depth_over_d", np.asarray(seconds, dtype=float)[order],
                            {"units": "s", "long_name": "solve time of the scene"})
    out.attrs.update({"model": model, "case": "intruder", "refused": json.dumps(refused),
                      "n_grid": int(max(grids)) if grids else 0,
                      "solve_seconds": float(np.sum(seconds)) if seconds else 0.0,
                      "converged": 1, "cells_per_d": cells_per_d})
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Each model's intruder speed at the DEM's depths.")
    parser.add_argument("--config", required=True)
    parser.add_argument("--params", required=True, type=Path)
    parser.add_argument("--model", required=True)
    parser.add_argument("--runs", nargs="+", required=True, type=Path, help="run.json of the intruder runs")
    parser.add_argument("--fields", nargs="+", required=True, type=Path, help="their fields files, same order")
    parser.add_argument("--out", required=True, type=Path)
    args = parser.parse_args(argv)
    config = load_config(args.config)
    params = json.loads(args.params.read_text())
    records = [json.loads(p.read_text()) for p in args.runs]
    pairs = [(r, open_fields(f)) for r, f in zip(records, args.fields, strict=True) if not r["intruder"]["control"]]
    result = predict(args.model, params, [r for r, _ in pairs], [f for _, f in pairs])
    result.attrs.update(provenance_attrs(config))
    atomic.write_netcdf(result, args.out)
    print(f"{args.model}: speeds {result.speed.values} m/s at depths {result.depth_over_d.values} d; "
          f"refused {json.loads(result.attrs['refused'])}")
    return 0
