"""Predict a planar case before its DEM runs: every model's creep profile on the case's nominal cell.

Choosing a validation case is choosing where the calibrated models disagree by more than the DEM
noise; that can be seen before any DEM is run, from the config and the calibration alone. The
nominal cell of a planar case (``geometry: planar_shear``, with gravity):

- depth between the wall contact planes: the body grains (``n_grains`` less the two wall layers
  of about ``cell_x * cell_y`` grains each) at the rheometer's solid fraction ``nu_c``, over the
  cell area, times ``DEPTH_CORRECTION`` (the ratio of the measured to the nominal depth of
  ``shear_gravity``, printed with the table);
- wall load, wall speed, gravity, grain size and density as configured; sigma_zz / p from the
  calibration.

Usage: ``python -m pipeline.models predict --config CANDIDATES.yaml --params params.json
[--cases NAME ...] [--depths 4 6 8 ...] [--out table.csv]``; prints u_x / V at the depths (in d
below the top wall plane) and the local decay length there for every model and case.
"""
from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

import continuum
from continuum.geometry import PlanarShear
from pipeline.calibration.parameter_sets import model_parameters, normal_stress_ratio, slip_length
from pipeline.common import atomic
from pipeline.common.cli import positive_float
from pipeline.common.config import RHEOMETER, load_config, mean_grain_volume

MODELS = ("local_mu_i", "critical_state", "cosserat", "ngf", "volume_averaged")
#: Measured over nominal depth of the default shear_gravity (22.64 d between grain centres less
#: 0.36 + 0.41 d to the contact planes = 21.87 d, against 20.02 d nominal): the bed next to a rough
#: wall packs looser than the bulk, so the bed is a little thicker than nu_c alone gives.
DEPTH_CORRECTION = 1.09


def nominal_cell(config: dict[str, Any], case: str, params: dict[str, Any]) -> PlanarShear:
    """The planar cell a case's DEM runs will give, estimated from the config (module docstring)."""
    mat, spec = config["material"], config["cases"][case]
    d = float(mat["d"])
    area = spec["cell_x"] * spec["cell_y"] * d * d
    body = spec["n_grains"] - 2.0 * spec["cell_x"] * spec["cell_y"]
    nu_c = float(params["local"]["nu_c"]["value"])
    depth = DEPTH_CORRECTION * body * mean_grain_volume(d, mat["polydispersity"], mat["n_sizes"]) / (nu_c * area)
    return PlanarShear(depth=depth, wall_speed=float(spec["wall_speed"]), wall_pressure=float(spec["wall_pressure"]),
                       gravity=float(spec["gravity"]), d=d, rho_s=float(mat["rho_s"]),
                       normal_stress_ratio=normal_stress_ratio(params), slip_length=slip_length(params))


def predict_case(geometry: PlanarShear, params: dict[str, Any], depths_over_d: list[float],
                 n_grid: int = 800) -> list[dict[str, Any]]:
    """u_x / V and the local decay length xi / d at each depth below the top plane, per model."""
    rows = []
    d = geometry.d
    for model in MODELS:
        try:
            sol = continuum.solve(model, geometry, model_parameters(params, model), n_grid=n_grid)
        except continuum.ContinuumError as exc:
            rows.append({"model": model, "note": " ".join(str(exc).split())[:120]})
            continue
        z, u = sol.z.values, sol.u_x.values
        row: dict[str, Any] = {"model": model, "tau_over_P": float(sol.attrs.get("tau", np.nan)) / geometry.wall_pressure}
        for depth in depths_over_d:
            zc = geometry.depth - depth * d
            uc = float(np.interp(zc, z, u))
            row[f"u/V@{depth:g}d"] = uc / geometry.wall_speed
            lo, hi = float(np.interp(zc - 0.5 * d, z, u)), float(np.interp(zc + 0.5 * d, z, u))
            row[f"xi/d@{depth:g}d"] = (d / math.log(hi / lo)) / d if lo > 0 and hi > lo else float("inf")
        rows.append(row)
    return rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Every calibrated model's creep on candidate planar cases, before the DEM.")
    parser.add_argument("--config", required=True, help="config holding the candidate cases")
    parser.add_argument("--params", required=True, type=Path, help="calibration/params.json")
    parser.add_argument("--cases", nargs="*", help="cases to predict (default: every planar case with gravity)")
    parser.add_argument("--depths", nargs="*", type=positive_float, default=[3.0, 6.0, 9.0, 12.0, 15.0],
                        help="depths below the top wall plane, in d")
    parser.add_argument("--out", type=Path, help="write the table as CSV too")
    args = parser.parse_args(argv)
    config = load_config(args.config)
    params = json.loads(args.params.read_text())
    cases = args.cases or [c for c, s in config["cases"].items()
                           if c != RHEOMETER and s["geometry"] == "planar_shear" and s["gravity"] > 0]
    unknown = [c for c in cases if c not in config["cases"]]
    if unknown:
        parser.error(f"--cases: {', '.join(unknown)} not in {args.config}")
    frames = []
    for case in cases:
        geometry = nominal_cell(config, case, params)
        rows = predict_case(geometry, params, [x for x in args.depths if x * geometry.d < geometry.depth])
        frames.append(pd.DataFrame(rows).assign(case=case, depth_over_d=geometry.depth / geometry.d,
                                               P_wall=geometry.wall_pressure, V=geometry.wall_speed))
    table = pd.concat(frames, ignore_index=True)
    pd.set_option("display.width", 250)
    print(table.to_string(index=False, float_format=lambda v: f"{v:.3g}"))
    if args.out:
        atomic.write_csv(table, args.out)
    return 0
