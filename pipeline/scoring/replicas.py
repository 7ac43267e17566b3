"""The DEM replicas a case is scored against: aligned profiles, the interior, the replica mean.

Reference for every score: the mean of the case's DEM replicas (each interpolated onto the first
replica's z), with the standard error of that mean. Profiles are compared inside the layer, at
least ``WALL_MARGIN_OVER_D`` d from both walls (the wall grains themselves are not the material the
models describe).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from pipeline.calibration.calibrate import microscopic_fluidity
from pipeline.common.observables import creep_speed

WALL_MARGIN_OVER_D = 1.0


def replica_profiles(files: list[Path]) -> list[xr.Dataset]:
    """The replicas' fields, each interpolated onto the first replica's z."""
    if not files:
        raise FileNotFoundError("no DEM fields files to score against")
    return align_replicas([xr.open_dataset(f) for f in files])


def top_plane(ds: xr.Dataset) -> float:
    """Height (m, DEM frame) of the top wall's contact plane, the moving wall the creep decays from
    (the wall grains' centres where a fields file has no contact planes)."""
    return float(ds.attrs.get("z_top_contact_plane", ds.attrs["z_top_wall"]))


def bottom_plane(ds: xr.Dataset) -> float:
    """Height (m) of the bottom wall's contact plane (its grains' centres without contact planes)."""
    return float(ds.attrs.get("z_bottom_contact_plane", ds.attrs["z_bottom_wall"]))


def align_replicas(sets: list[xr.Dataset]) -> list[xr.Dataset]:
    """Replica profiles on the first one's z, each placed by its depth below its own top contact
    plane (the frame of the models and the scores: the replicas' walls differ by a fraction of a
    grain), with the creep speed ``u_creep`` (:func:`pipeline.common.observables.creep_speed`) added."""
    ref = top_plane(sets[0])
    aligned = [sets[0]] + [ds.assign_coords(z=ds.z.values - top_plane(ds) + ref).interp(z=sets[0].z).assign_attrs(ds.attrs)
                           for ds in sets[1:]]
    out = []
    for ds in aligned:
        u, err, _ = creep_speed(ds)
        out.append(ds.assign(u_creep=("z", u, {"units": "m s-1", "long_name": "creep speed (u_x or u_x_disp)"}),
                             u_creep_err=("z", err, {"units": "m s-1", "long_name": "its standard error"})))
    return out


def interior(ds: xr.Dataset) -> np.ndarray:
    """Mask of the points at least ``WALL_MARGIN_OVER_D`` grain diameters of bed from both walls'
    contact planes (the models' walls).

    The wall layer is excluded from every profile score: there the grains touch a rigid rough wall,
    a boundary layer none of the bulk laws describes (its stress ratio is far above the rheometer
    bulk's at the same I). Before 2026-12-02 the margin was counted from the wall grains' centres,
    about 0.42 d outside the contact planes, so it held about half a grain of bed.
    """
    d = float(ds.attrs["d"])
    z = ds.z.values
    return (z >= bottom_plane(ds) + WALL_MARGIN_OVER_D * d) & (z <= top_plane(ds) - WALL_MARGIN_OVER_D * d)


def mean_profile(reps: list[xr.Dataset], name: str) -> tuple[np.ndarray, np.ndarray]:
    """Replica mean of a variable and its standard error (from the replicas' own errors)."""
    values = np.array([ds[name].values for ds in reps])
    errors = np.array([ds[f"{name}_err"].values for ds in reps])
    return values.mean(axis=0), np.sqrt((errors**2).sum(axis=0)) / len(reps)


def with_microscopic_fluidity(reps: list[xr.Dataset], params: dict | None) -> list[xr.Dataset]:
    """Replicas with ``fluidity_micro`` (Zhang & Kamrin 2017, F(nu) from the calibration) added."""
    if params is None or "microscopic_fluidity" not in params:
        return reps
    out = []
    for ds in reps:
        g, err = microscopic_fluidity(params, ds["nu"].values, ds["granular_temperature"].values,
                                      ds["granular_temperature_err"].values)
        out.append(ds.assign(fluidity_micro=("z", g, {"units": "s-1", "long_name": "microscopic fluidity"}),
                             fluidity_micro_err=("z", err, {"units": "s-1", "long_name": "its standard error"})))
    return out
