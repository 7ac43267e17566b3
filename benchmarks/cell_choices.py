"""What the model cell's two choices change (issue 15, items 2 and 3): tau / P_wall and the creep.

For each planar case with gravity, the calibrated NGF model (the local law does not creep) is
solved on four cells:
walls at the wall grains' centres or at the contact planes, and p = sigma_zz (r = 1) or p =
sigma_zz / r with r = sigma_zz / p measured on the rheometer. Printed: the wall shear stress over
the wall load, tau / P_wall, and u / V at 5, 7 and 9 d below the top wall grains' centres (the
DEM heights the scores compare at), with the shift of each choice against the workflow's
(contact planes, measured r).

Usage: ``python benchmarks/cell_choices.py --root results``
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

import continuum  # noqa: E402
from pipeline.calibration.parameter_sets import model_parameters, normal_stress_ratio, slip_length  # noqa: E402
from pipeline.common.planar_cell import planar_cell  # noqa: E402

DEPTHS_OVER_D = (5.0, 7.0, 9.0)
#: The model whose creep is compared: NGF creeps below the yield plane.
MODEL = "ngf"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--root", type=Path, required=True, help="output root of a finished workflow")
    args = parser.parse_args(argv)
    params_path = args.root / "calibration" / "params.json"
    if not params_path.is_file():
        raise SystemExit(f"{params_path}: not found: --root must be the output root of a finished workflow")
    params = json.loads(params_path.read_text())
    r = normal_stress_ratio(params)
    rows = []
    for folder in sorted((args.root / "fields").iterdir()):
        files = sorted(f for f in folder.glob("r*.nc") if f.stem[1:].isdigit())
        if not files:
            continue
        fields = [xr.open_dataset(f) for f in files]
        if float(fields[0].attrs.get("gravity", 0.0)) <= 0:
            continue
        for planes in ("grain_centres", "contact"):
            for ratio in (1.0, r):
                geometry, z0 = planar_cell(fields, ratio, planes, slip_length=slip_length(params))
                sol = continuum.solve(MODEL, geometry, model_parameters(params, MODEL), n_grid=400)
                # The scores compare at the DEM's heights: depth below the top wall grains' centres.
                z_top = float(np.mean([float(ds.attrs["z_top_wall"]) for ds in fields]))
                row = {"case": folder.name, "walls": planes, "sigma_zz/p": ratio, "depth/d": geometry.depth / geometry.d,
                       "tau/P_wall": float(sol.attrs["tau"]) / geometry.wall_pressure}
                for k in DEPTHS_OVER_D:
                    z_model = z_top - k * geometry.d - z0
                    row[f"u/V at {k:g} d"] = float(np.interp(z_model, sol.z.values, sol.u_x.values)) / geometry.wall_speed
                rows.append(row)
        for ds in fields:
            ds.close()
    table = pd.DataFrame(rows)
    pd.set_option("display.width", 200)
    print(f"sigma_zz / p on the rheometer: r = {r:.4f}")
    print(table.to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    for case, part in table.groupby("case"):
        chosen = (part.walls == "contact") & (part["sigma_zz/p"] == r)
        ref = part[chosen].iloc[0]
        for _, row in part[~chosen].iterrows():
            shifts = ", ".join(f"{c}: x{row[c] / ref[c]:.3g}" for c in part.columns if c.startswith("u/V"))
            print(f"{case}: {row.walls}, r = {row['sigma_zz/p']:.3f}: tau/P_wall {row['tau/P_wall'] - ref['tau/P_wall']:+.4f} "
                  f"against contact planes and measured r; creep {shifts}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
