"""Each intruder model's 2D fields around the rod, one file per scene (issue 55, item 4):
``model_fields/intruder/{model}/{scene}.nc`` (CF NetCDF) and ``.vts`` (VTK, as the DEM's
``fields_xz/``), with ``scenes.json`` beside them (the scenes written and those the model refused).

The fields are the nominal solves' own (``models/intruder/{model}.states.npz``, the states the
intruder stage stores): each scene's converged state is turned back into its flow on its grid
(``continuum.intruder.api.intruder_fields``: the same numbers as the solve's, without solving again).
A scene is named as its runs without the replica suffix (``D7-r1`` -> ``D7``); its cell, rod and
push are the first replica's (``pipeline.models.intruder.scenes_of``).

Coordinates, in the rod's frame as the DEM's ``fields_xz/`` (``pipeline.coarse_graining.rod_frame``):
``x`` (m) along the flow from the rod's axis (the model's periodic cell, ``-L_x/2 .. L_x/2``), ``z``
(m) the DEM's height (the model's height above its bottom contact plane plus that plane's z in the
DEM, so the rod sits at the DEM rod's z). Dims (x, z) like the DEM's files. Variables (cell
centres): ``u_x`` (lab frame, m s-1), ``u_x_rel`` = u_x - U (the velocity along x relative to the
rod, as the DEM's ``u_x_rel``), ``u_z`` (the rod is held: the same in both frames), ``p`` (Pa, the
models' pressure pi / normal_stress_ratio, as the DEM's trace / 3), ``mu`` (tau / p, the model's own
stress ratio: tau the in-plane deviatoric stress magnitude), ``mu_xz`` (|sigma_xz| / p, the DEM
fields' ``mu``), ``sigma_xx``, ``sigma_zz``, ``sigma_xz`` (Pa, compressive positive, the DEM's
signs), ``shear_rate``, ``solid`` (1 inside the rod) and where the model has them ``nu``
(attribute ``nu_method`` says how), ``fluidity`` (NGF), ``spin`` (Cosserat). Inside the rod
u_x_rel = u_z = 0 (its rigid motion) and the stresses are NaN.

Usage: ``python -m pipeline.models.intruder_fields --config C --params calibration/params.json
--model ngf --runs RESULTS/dem/intruder/*/run.json --fields RESULTS/fields/intruder/*.nc
--states RESULTS/models/intruder/ngf.states.npz --out-dir RESULTS/model_fields/intruder/ngf``
"""
from __future__ import annotations

import argparse
import json
import re
import time
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from continuum.intruder import GridOptions, IntruderSpeed
from continuum.intruder.api import INTRUDER_MODELS, intruder_fields
from pipeline.calibration.parameter_sets import model_parameters, normal_stress_ratio, slip_length
from pipeline.coarse_graining.vtk import write_fields_vtk
from pipeline.common import atomic
from pipeline.common.config import load_config
from pipeline.common.planar_cell import planar_cell
from pipeline.common.provenance import provenance_attrs
from pipeline.models.intruder import Scene, pushed_runs, scenes_of
from pipeline.models.intruder_states import load_states

#: A replica's run name: the scene's name and ``-r<k>``.
_REPLICA = re.compile(r"-r\d+$")
#: The index of the scenes written and refused, beside the fields files.
INDEX = "scenes.json"


def scene_name(run: str) -> str:
    """A run's scene: its name without the replica suffix (``D4-F0.4-r2`` -> ``D4-F0.4``)."""
    return _REPLICA.sub("", run)


def bottom_plane(scene: Scene, fields: list[xr.Dataset], runs: list[dict[str, Any]], params: dict[str, Any]) -> float:
    """z (m, DEM frame) of the scene's bottom contact plane: the model's z = 0 (as ``scene_of``
    places the cell: the first replica's fields file)."""
    for run, ds in zip(runs, fields, strict=True):
        if run["run"] == scene.run["run"] and run["case"] == scene.run["case"]:
            _, z0 = planar_cell([ds], normal_stress_ratio(params), slip_length=slip_length(params))
            return z0
    raise ValueError(f"no fields file for the scene of {scene.label}")


def scene_dataset(model: str, scene: Scene, z0: float, fields: xr.Dataset, speed: float, cells_per_d: float) -> xr.Dataset:
    """One scene's 2D solution (``continuum.intruder.api.intruder_fields``'s Dataset on the model's
    grid) in the rod's frame with the DEM's coordinates (module docstring)."""
    lx = scene.cell_length_x
    rod_speed = float(fields.attrs["rod_speed"])
    solid = fields["solid"].values.astype(bool)
    ds = fields.transpose("x", "z")
    ds = ds.assign_coords(
        x=("x", ds.x.values - 0.5 * lx, {"units": "m", "long_name": "position along the flow from the rod's axis "
                                         "(periodic)"}),
        z=("z", ds.z.values + z0, {"units": "m", "long_name": "height (gradient direction, up), the DEM's frame"}))
    ds["u_x"].attrs.update({"long_name": "velocity along x (flow), lab frame; the rod's speed inside it"})
    rel = np.where(solid, 0.0, fields["u_x"].values - rod_speed).T
    ds["u_x_rel"] = (("x", "z"), rel, {"units": "m s-1", "long_name": "velocity along x relative to the rod "
                                       "(0 inside it)"})
    ds["u_z"] = (("x", "z"), np.where(solid, 0.0, fields["u_z"].values).T,
                 {"units": "m s-1", "long_name": "velocity along z (gradient, up); the rod is held (0 inside it)"})
    ds["solid"] = ds["solid"].astype(np.int8)
    ds["solid"].attrs.update({"units": "1", "long_name": "1 inside the rod (cell centre within its radius)"})
    rod = scene.rod
    ds.attrs = {
        "model": model, "case": scene.run["case"], "scene": scene_name(scene.run["run"]), "run": scene.run["run"],
        "geometry": "plane_xz", "source_of_fields": f"{model}: nominal 2D solve, rebuilt from its converged state",
        "frame": "rod: x from the rod's axis; z the DEM's height; u_x_rel relative to the rod's speed",
        "conventions": "compressive stress positive; x flow, z gradient (up), y vorticity; sigma_xz the x force "
                       "across z planes; mu_xz = |sigma_xz| / p as the DEM's mu, mu = tau / p the model's own",
        "rod_centre_x": 0.0, "rod_z": z0 + rod.depth_from_bottom, "rod_diameter": rod.diameter,
        "rod_depth_over_d": scene.depth_over_d, "rod_speed": rod_speed, "speed": float(speed),
        "push_over_yield": scene.push_over_yield, "force_per_length": rod.force_per_length,
        "force_sweep": int(scene.force_sweep), "cell": lx, "d": scene.geometry.d,
        "wall_speed": scene.geometry.wall_speed, "wall_pressure": scene.geometry.wall_pressure,
        "z_bottom_contact_plane": z0, "z_top_contact_plane": z0 + scene.geometry.depth,
        "normal_stress_ratio": scene.geometry.normal_stress_ratio, "cells_per_d": cells_per_d,
        "nx": int(fields.attrs["nx"]), "nz": int(fields.attrs["nz"]),
        "rod_diameter_units": "m", "rod_speed_units": "m s-1", "speed_units": "m s-1",
        "force_per_length_units": "N m-1", "rod_centre_x_units": "m", "nx_units": "1", "nz_units": "1",
        "force_sweep_units": "1",
    }
    if "nu_method" in fields.attrs:
        ds.attrs["nu_method"] = fields.attrs["nu_method"]
    return ds


def model_fields(model: str, params: dict[str, Any], runs: list[dict[str, Any]], fields: list[xr.Dataset],
                 states: list[IntruderSpeed | None], cells_per_d: float) -> tuple[dict[str, xr.Dataset], list[str]]:
    """Every scene's fields (scene name -> Dataset, ``scene_dataset``) from the nominal solves'
    states (``load_states``, in ``scenes_of``'s order), and the scenes without any (refused or not
    converged by the nominal solve)."""
    scenes = scenes_of(runs, fields, params)
    if len(states) != len(scenes):
        raise ValueError(f"{len(states)} states for {len(scenes)} scenes")
    parameters = model_parameters(params, model)
    out, missing = {}, []
    for scene, result in zip(scenes, states):
        name = scene_name(scene.run["run"])
        if name in out or name in missing:
            raise ValueError(f"two scenes named {name}: their runs differ in more than the replica suffix")
        if result is None or result.state is None:
            missing.append(name)
            continue
        z0 = bottom_plane(scene, fields, runs, params)
        raw = intruder_fields(model, scene.geometry, parameters, scene.rod, scene.cell_length_x,
                              GridOptions(cells_per_d=cells_per_d), result.state, case=scene.label)
        out[name] = scene_dataset(model, scene, z0, raw, result.speed, cells_per_d)
    return out, missing


def write_scene_fields(ds: xr.Dataset, path: Path) -> Path:
    """``ds`` as CF NetCDF at ``path`` and VTK (``.vts``) beside it, each under a temporary name and
    renamed when complete; the NetCDF last, so a complete ``.nc`` has its ``.vts``."""
    path = Path(path)
    atomic.clear_stale(path.with_suffix(".vts"), temporaries_of=(path,))
    write_fields_vtk(ds, path.with_suffix(".vts"))
    atomic.write_netcdf(ds, path, title=f"granular-validate {ds.attrs.get('model', 'model')} 2D fields around the rod")
    return path


def write_model_fields(datasets: dict[str, xr.Dataset], missing: list[str], out_dir: Path,
                       provenance: dict[str, Any] | None = None) -> list[Path]:
    """Each scene's file in ``out_dir`` and the index ``scenes.json`` (written last)."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, ds in sorted(datasets.items()):
        ds = ds.copy()
        ds.attrs.update(provenance or {})
        paths.append(write_scene_fields(ds, out_dir / f"{name}.nc"))
    atomic.write_json({"scenes": sorted(datasets), "not_solved": sorted(missing)}, out_dir / INDEX)
    return paths


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="An intruder model's 2D fields per scene (CF NetCDF and VTK).")
    parser.add_argument("--config", required=True)
    parser.add_argument("--params", required=True, type=Path)
    parser.add_argument("--model", required=True, choices=sorted(k for k, v in INTRUDER_MODELS.items() if v.solver))
    parser.add_argument("--runs", nargs="+", required=True, type=Path, help="run.json of the intruder runs")
    parser.add_argument("--fields", nargs="+", required=True, type=Path, help="their fields files, same order")
    parser.add_argument("--states", required=True, type=Path, help="models/intruder/MODEL.states.npz")
    parser.add_argument("--out-dir", required=True, type=Path, help="model_fields/intruder/MODEL")
    args = parser.parse_args(argv)
    t0 = time.perf_counter()
    config = load_config(args.config)
    params = json.loads(args.params.read_text())
    runs, fields = pushed_runs(args.runs, args.fields)
    n_scenes = len(scenes_of(runs, fields, params))
    states, cells_per_d = load_states(args.states, args.model, n_scenes)
    datasets, missing = model_fields(args.model, params, runs, fields, states, cells_per_d)
    write_model_fields(datasets, missing, args.out_dir, provenance_attrs(config))
    print(f"{args.model}: fields of {sorted(datasets)} in {args.out_dir}; not solved {missing}; "
          f"{time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
