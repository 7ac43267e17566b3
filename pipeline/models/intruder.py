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
from pipeline.calibration.parameter_sets import model_parameters, normal_stress_ratio, params_of_draw
from pipeline.common.planar_cell import planar_cell
from pipeline.common.config import load_config
from pipeline.common.provenance import provenance_attrs


#: Parameter draws solved per intruder model when the config's ``models.intruder_draws`` is absent:
#: NGF's 2D solve takes about 0.3 s a depth, against milliseconds for a planar profile.
DEFAULT_INTRUDER_DRAWS = 32


def run_speed(model: str, parameters: Any, params: dict[str, Any], run: dict[str, Any], ds: xr.Dataset,
              cells_per_d: float) -> tuple[Any, str | None]:
    """The model's result for one sheared run (``IntruderSpeed``) or None and why it was refused."""
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
        return None, f"{rod['depth_over_d']:.2f} d: {exc}"
    if not result.converged:
        raise continuum.ConvergenceError(model, result.residual, "intruder solve did not converge", label)
    if not np.isfinite(result.speed) or abs(result.speed) > geometry.wall_speed:
        # A rod pushed below its yield force in the creeping zone cannot outrun the wall: such a
        # number comes from an ill-conditioned solve (e.g. a fluidity that underflows), not physics.
        return None, (f"{rod['depth_over_d']:.2f} d: solve failed: speed {result.speed:.3g} m/s exceeds the wall "
                      f"speed {geometry.wall_speed:g} m/s (ill-conditioned 2D solve)")
    return result, None


def predict(model: str, params: dict[str, Any], runs: list[dict[str, Any]], fields: list[xr.Dataset],
            cells_per_d: float = 4.0) -> xr.Dataset:
    """The model's speed at each sheared run's depth (see module docstring); the force sweep's
    runs (``force_sweep`` in their run.json) on a coordinate of their own, ``push_over_yield``."""
    depths, speeds, seconds, grids, refused, bounded = [], [], [], [], [], []
    pushes, push_speeds = [], []
    parameters = model_parameters(params, model)
    for run, ds in zip(runs, fields, strict=True):
        result, reason = run_speed(model, parameters, params, run, ds, cells_per_d)
        if run["intruder"].get("force_sweep"):
            # One entry per push (the first replica's run: the model sees the same geometry in each).
            push = round(float(run["intruder"]["push_over_yield"]), 6)
            if push not in pushes:
                pushes.append(push)
                push_speeds.append(result.speed if result is not None else np.nan)
                if result is None:
                    refused.append(f"push {push:g} of the yield force: {reason}")
            continue
        if result is None:
            refused.append(reason)
            continue
        depths.append(run["intruder"]["depth_over_d"])
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
    if pushes:
        by = np.argsort(pushes)
        out = out.assign_coords(push_over_yield=("push_over_yield", np.asarray(pushes)[by],
                                                 {"units": "1", "long_name": "the force sweep's push over the yield force at its depth"}))
        out["sweep_speed"] = ("push_over_yield", np.asarray(push_speeds, dtype=float)[by],
                              {"units": "m s-1", "long_name": "steady rod speed of the force sweep (NaN: refused)"})
    out.attrs.update({"model": model, "case": "intruder", "refused": json.dumps(refused),
                      "n_grid": int(max(grids)) if grids else 0,
                      "solve_seconds": float(np.sum(seconds)) if seconds else 0.0,
                      "converged": 1, "cells_per_d": cells_per_d})
    return out


def predict_draws(model: str, params: dict[str, Any], ensemble: dict[str, Any], runs: list[dict[str, Any]],
                  fields: list[xr.Dataset], n_draws: int, cells_per_d: float = 4.0) -> xr.Dataset:
    """The rod speed of each scene (the first run of each target depth and push) for the first
    ``n_draws`` parameter draws (dims ``draw``, ``run``; NaN where the model refuses the depth or the
    draw has no parameters for it) and, with the calibration's values, on a grid twice as fine per d
    (``speed_refined``: ``u_num``)."""
    # One scene per target depth and push (the first replica's): the replicas' scenes differ by a
    # fraction of a grain in depth, and NGF's 2D solve costs 0.3-0.9 s a scene and draw.
    seen, keep = set(), []
    for run, ds in zip(runs, fields, strict=True):
        key = (round(float(run["intruder"]["depth_target_over_d"]), 6), round(float(run["intruder"].get("push_over_yield", -1.0)), 6)
               if run["intruder"].get("force_sweep") else None)
        if key not in seen:
            seen.add(key)
            keep.append((run, ds))
    runs, fields = [r for r, _ in keep], [f for _, f in keep]
    draws = ensemble["draws"][:n_draws]
    speed = np.full((len(draws), len(runs)), np.nan)
    refused = np.zeros((len(draws), len(runs)), dtype=np.int8)
    failures: dict[int, str] = {}
    for k, draw in enumerate(draws):
        if model in draw.get("failed", {}):
            failures[k] = draw["failed"][model]
            continue
        drawn = params_of_draw(params, draw)
        parameters = model_parameters(drawn, model)
        for j, (run, ds) in enumerate(zip(runs, fields, strict=True)):
            try:
                result, reason = run_speed(model, parameters, drawn, run, ds, cells_per_d)
            except continuum.ContinuumError as exc:
                result, reason = None, f"{exc}"
            if result is None:
                refused[k, j] = 1
                failures.setdefault(k, reason[:300])
            else:
                speed[k, j] = result.speed
    parameters = model_parameters(params, model)
    refined = np.full(len(runs), np.nan)
    for j, (run, ds) in enumerate(zip(runs, fields, strict=True)):
        result, _ = run_speed(model, parameters, params, run, ds, 2.0 * cells_per_d)
        if result is not None:
            refined[j] = result.speed
    labels = [r["run"] for r in runs]
    out = xr.Dataset(coords={"draw": ("draw", np.arange(len(draws)), {"units": "1", "long_name": "parameter draw"}),
                             "run": ("run", labels, {"long_name": "sheared intruder run"})})
    out["depth_over_d"] = ("run", np.array([r["intruder"]["depth_over_d"] for r in runs], dtype=float),
                           {"units": "1", "long_name": "rod axis below the top wall, in d"})
    out["push_over_yield"] = ("run", np.array([r["intruder"].get("push_over_yield", np.nan) for r in runs], dtype=float),
                              {"units": "1", "long_name": "push over the yield force at the rod's depth"})
    out["force_sweep"] = ("run", np.array([int(bool(r["intruder"].get("force_sweep"))) for r in runs], dtype=np.int8),
                          {"units": "1", "long_name": "1 for a run of the force sweep"})
    out["speed"] = (("draw", "run"), speed, {"units": "m s-1", "long_name": "steady rod speed along +x, per draw"})
    out["refused"] = (("draw", "run"), refused, {"units": "1", "long_name": "1 where the model refused the depth"})
    out["speed_refined"] = ("run", refined, {"units": "m s-1", "long_name": "calibration's values, grid twice as fine"})
    out.attrs.update({"model": model, "case": "intruder", "n_draws": len(draws), "cells_per_d": cells_per_d,
                      "cells_per_d_refined": 2.0 * cells_per_d, "failures": json.dumps(failures),
                      "draws_seed": int(ensemble.get("seed", -1))})
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Each model's intruder speed at the DEM's depths.")
    parser.add_argument("--config", required=True)
    parser.add_argument("--params", required=True, type=Path)
    parser.add_argument("--model", required=True)
    parser.add_argument("--runs", nargs="+", required=True, type=Path, help="run.json of the intruder runs")
    parser.add_argument("--fields", nargs="+", required=True, type=Path, help="their fields files, same order")
    parser.add_argument("--out", required=True, type=Path)
    parser.add_argument("--draws", type=Path, help="calibration/draws.json: also solve the first N draws")
    parser.add_argument("--draws-out", type=Path, help="where the draws' speeds go (model_draws/intruder/MODEL.nc)")
    args = parser.parse_args(argv)
    if (args.draws is None) != (args.draws_out is None):
        parser.error("--draws and --draws-out go together")
    config = load_config(args.config)
    params = json.loads(args.params.read_text())
    records = [json.loads(p.read_text()) for p in args.runs]
    pairs = [(r, open_fields(f)) for r, f in zip(records, args.fields, strict=True) if not r["intruder"]["control"]]
    result = predict(args.model, params, [r for r, _ in pairs], [f for _, f in pairs])
    result.attrs.update(provenance_attrs(config))
    if args.draws is not None:
        n_draws = int((config.get("models") or {}).get("intruder_draws", DEFAULT_INTRUDER_DRAWS))
        ensemble = predict_draws(args.model, params, json.loads(args.draws.read_text()), [r for r, _ in pairs],
                                 [f for _, f in pairs], n_draws)
        ensemble.attrs.update(provenance_attrs(config))
        atomic.write_netcdf(ensemble, args.draws_out)
    atomic.write_netcdf(result, args.out)
    print(f"{args.model}: speeds {result.speed.values} m/s at depths {result.depth_over_d.values} d; "
          f"refused {json.loads(result.attrs['refused'])}")
    return 0
