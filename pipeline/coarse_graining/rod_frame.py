"""x-z coarse-grained fields around the intruder, in its frame: ``fields_xz/{case}/{run}.nc`` + ``.vts``.

Every snapshot is shifted along the periodic x so that the rod's centre sits at the middle of the
cell (its grains, type 4, located by their circular mean over the period), then the flowing grains
and their contacts are coarse-grained on an x-z grid (integrated over the periodic y, along which
the rod lies). Velocities stay those of the lab frame; ``u_x_rel`` is u_x minus the rod's mean
speed over the averaging window (the flow the rod sees). Shifting within a periodic cell does not
change x averages: the x mean of these fields is the run's profile (``fields/{case}/{run}.nc``),
which the tests check.

Usage: ``python -m pipeline.coarse_graining.rod_frame --config C --run-dir RESULTS/dem/intruder/RUN
--out RESULTS/fields_xz/intruder/RUN.nc``
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from pipeline.common import atomic
from pipeline.coarse_graining.coarse_grain import CoarseGrainError
from pipeline.common.config import load_config
from pipeline.dumps.store import read_run_json
from pipeline.dumps.reader import Dump, DumpError
from pipeline.coarse_graining.fields import run_fields
from pipeline.coarse_graining.vtk import write_fields_vtk

#: LIGGGHTS atom type of the rod's grains (liggghts_inputs/common_settings.in).
ROD_TYPE = 4


def rod_centres(particles: Dump, snapshots: np.ndarray) -> np.ndarray:
    """x of the rod's centre (m) in each snapshot: the circular mean of its grains over the period."""
    x, kind = particles.index("x"), particles.index("type")
    out = np.empty(snapshots.size)
    for k, s in enumerate(snapshots):
        rows = particles.rows(int(s))
        lo, hi = particles.boxes[s, 0]
        rod = rows[rows[:, kind] == ROD_TYPE, x]
        if rod.size == 0:
            raise CoarseGrainError(f"{', '.join(particles.sources)}: snapshot {s} has no rod grains (type {ROD_TYPE})")
        angle = 2.0 * math.pi * (rod - lo) / (hi - lo)
        mean = math.atan2(np.sin(angle).mean(), np.cos(angle).mean()) % (2.0 * math.pi)
        out[k] = lo + mean / (2.0 * math.pi) * (hi - lo)
    return out


def centre_rod(particles: Dump, snapshots: np.ndarray) -> np.ndarray:
    """Shift (m) per snapshot that brings the rod's centre to the middle of the periodic cell."""
    box = particles.boxes[snapshots]
    return box[:, 0, 0] + 0.5 * (box[:, 0, 1] - box[:, 0, 0]) - rod_centres(particles, snapshots)


def rod_frame_fields(config: dict[str, Any], run_dir: Path) -> xr.Dataset:
    """The x-z fields of one intruder run in the rod's frame (module docstring)."""
    result, _ = run_fields(config, run_dir, plane=True, checks=False, x_shift=centre_rod)
    ds = result.dataset
    if not ds.attrs["contacts_included"]:
        raise CoarseGrainError(f"{run_dir}: the rod-frame fields need the contact dumps (stress)")
    rod = read_run_json(Path(run_dir))["intruder"]
    ds["u_x_rel"] = ds["u_x"] - rod["speed"]
    ds["u_x_rel"].attrs.update({"units": "m s-1", "long_name": "velocity along x relative to the rod's mean speed"})
    lo, lx = float(ds.x.values[0]) - 0.5 * float(ds.x.values[1] - ds.x.values[0]), float(ds.attrs["cell"][0])
    ds.attrs.update({
        "frame": "rod: x shifted per snapshot so the rod's centre is at the middle of the cell",
        "rod_centre_x": lo + 0.5 * lx, "rod_depth_over_d": float(rod["depth_over_d"]),
        "rod_diameter": float(rod["diameter"]), "rod_speed": float(rod["speed"]),
        "rod_arrested": int(bool(rod["arrested"])),
    })
    return ds


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="x-z fields around the intruder, in its frame (NetCDF + VTK).")
    parser.add_argument("--config", type=Path, required=True)
    parser.add_argument("--run-dir", type=Path, required=True)
    parser.add_argument("--out", type=Path, required=True, help="RESULTS/fields_xz/CASE/RUN.nc (a .vts is written beside it)")
    args = parser.parse_args(argv)
    atomic.clear_stale(args.out.with_suffix(".vts"), temporaries_of=(args.out,))
    try:
        ds = rod_frame_fields(load_config(args.config), args.run_dir)
    except (DumpError, CoarseGrainError, ValueError, KeyError) as err:
        print(f"error: {args.run_dir}: {err}", file=sys.stderr)
        return 1
    write_fields_vtk(ds, args.out.with_suffix(".vts"))
    atomic.write_netcdf(ds, args.out)
    print(f"{args.out}: {ds.attrs['number_of_snapshots']} snapshots, rod at x = {ds.attrs['rod_centre_x']:.4g} m")
    return 0
