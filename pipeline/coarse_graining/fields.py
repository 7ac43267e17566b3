"""Workflow step: one DEM run's dumps into its time-averaged fields file ``fields/{case}/{run}.nc``.

Reads ``run.json`` and the dump store (``dumps.nc``, written by ``python -m pipeline.dumps.store``;
the text dumps are parsed when the store is absent), averages over the snapshots inside the
steady-state window, and writes the contract NetCDF atomically (temporary name, then rename).
x-z fields (``--plane xz``, or cases listed in ``coarse_grain.plane_cases``) also get a VTK file
``{run}.vts`` next to the NetCDF for ParaView.

Settings come from the optional config section ``coarse_grain`` (defaults in
:data:`DEFAULTS`): kernel, width over d, grid spacing over width, number of error blocks.

The profile grid runs from the mean height of the bottom-wall grains to that of the top-wall
grains. The physical checks of :mod:`pipeline.coarse_graining.field_checks` (momentum balance in the bulk, wall
stress against the wall series) are computed for profiles and stored as ``check_*`` attributes.

Usage: ``python -m pipeline.coarse_graining.fields --config CONFIG --run-dir RESULTS/dem/CASE/RUN
--out RESULTS/fields/CASE/RUN.nc [--plane xz]``
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

from pipeline.coarse_graining import field_checks, structure, wall
from pipeline.coarse_graining.coarse_grain import (CoarseGrainError, Grid, Result, block_average, coarse_grain, plane_grid,
                                                   profile_grid, write_netcdf)
from pipeline.coarse_graining.pairing import check_contacts_match, contact_index
from pipeline.dumps.store import STORE_NAME, parse_run, read_run_json, read_store
from pipeline.dumps.reader import Dump, DumpError, shift_periodic_x
from pipeline.coarse_graining.displacement import displacement_structural_error, displacement_velocity
from pipeline.coarse_graining.kernels import Kernel
from pipeline.coarse_graining.vtk import write_fields_vtk, write_particles_vtu
from pipeline.common import atomic
from pipeline.common.formats import FIELDS_FORMAT_VERSION
from pipeline.common.provenance import provenance_attrs
from pipeline.common.statistics import autocorrelated_mean_error
from pipeline.dem.wall_series import read_wall_series

DEFAULTS: dict[str, Any] = {
    "kernel": "gaussian",
    "width_over_d": 0.5,
    "spacing_over_width": 0.5,
    "blocks": 5,
    "bulk_margin_over_d": 3.0,
    "plane_cases": [],
}


def settings(config: dict[str, Any]) -> dict[str, Any]:
    """Coarse-graining settings: the config's ``coarse_grain`` section over :data:`DEFAULTS`."""
    out = dict(DEFAULTS)
    out.update(config.get("coarse_grain", {}) or {})
    return out


def load_tables(run_dir: Path, run: dict[str, Any]) -> tuple[Dump, Dump | None]:
    """The run's particle and contact tables: from the store if present, else parsed."""
    store = run_dir / STORE_NAME
    if store.is_file():
        return read_store(store)
    return parse_run(run_dir, run)


def steady_snapshots(particles: Dump, run: dict[str, Any]) -> np.ndarray:
    """Indices of the particle snapshots inside the steady-state window of run.json."""
    t0, t1 = run["steady_state_window"]
    times = particles.timesteps * run["time_step"]
    # Half a time step of slack: times are step * dt, rounded in run.json.
    dt = run["time_step"]
    chosen = np.nonzero((times >= t0 - 0.5 * dt) & (times <= t1 + 0.5 * dt))[0]
    if chosen.size == 0:
        raise CoarseGrainError(f"no dump snapshot inside run.json steady_state_window [{t0}, {t1}] s "
                               f"(dumps span {times.min()}-{times.max()} s)")
    check_dump_coverage(particles, run)
    return chosen


def check_dump_coverage(particles: Dump, run: dict[str, Any]) -> None:
    """Refuse particle dumps with snapshots missing inside or at the end of the window.

    A dump cut exactly between two snapshots parses cleanly; only run.json's ``dump_every`` (LIGGGHTS
    dumps on multiples of it) tells that snapshots are missing. Runs without it are not checked.
    """
    every = run.get("dump_every")
    if not every:
        return
    steps = particles.timesteps
    gaps = np.nonzero(np.diff(steps) > every)[0]
    files = ", ".join(particles.sources)
    if gaps.size:
        raise CoarseGrainError(f"{files}: no snapshot between steps {int(steps[gaps[0]])} and {int(steps[gaps[0] + 1])} "
                               f"(run.json dump_every = {every}): a truncated or missing dump file?")
    t_end = run["steady_state_window"][1]
    if (steps[-1] + every) * run["time_step"] < t_end:
        raise CoarseGrainError(f"{files}: the last snapshot (step {int(steps[-1])}) is more than dump_every = {every} "
                               f"steps before the end of run.json steady_state_window ({t_end} s): a truncated dump?")


def production_series(run_dir: Path, run: dict[str, Any]) -> pd.DataFrame:
    """The wall series over run.json's ``production_window`` (s), in time order: the production
    chunks', which since 2026-12-02 may begin with the steady window's shear chunks
    (``dem.precision.steady_window_is_production``)."""
    files = sorted((run_dir / "series").glob("shear_*.txt")) + sorted((run_dir / "series").glob("production_*.txt"))
    t_start, t_end = run["production_window"]
    frames = [frame for frame in (read_wall_series(f) for f in files)
              if frame["time"].iloc[-1] >= t_start and frame["time"].iloc[0] <= t_end]
    if not frames:
        raise CoarseGrainError(f"{run_dir / 'series'}: no wall series over run.json production_window {t_start}-{t_end} s")
    data = pd.concat(frames, ignore_index=True).sort_values("time")
    return data[(data["time"] >= t_start) & (data["time"] <= t_end)].reset_index(drop=True)


def run_fields(config: dict[str, Any], run_dir: Path, plane: bool = False,
               width: float | None = None, checks: bool = True,
               x_shift: Callable[[Dump, np.ndarray], np.ndarray] | None = None,
               z: np.ndarray | None = None) -> tuple[Result, dict[str, Any]]:
    """Coarse-grain one run; return the result (dataset with attributes) and the checks
    (none with ``checks=False``, for studies that only need the fields).

    ``x_shift(particles, snapshots)`` gives a shift along the periodic x (m) per steady snapshot:
    the snapshots are moved by it before averaging (a moving frame, e.g. an intruder's). ``z``
    (m), for profiles: the heights to evaluate at instead of the grid between the walls' mean
    heights (another file's nodes, so that the two compare point by point).
    """
    run_dir = Path(run_dir)
    run = read_run_json(run_dir)
    opts = settings(config)
    particles, contacts = load_tables(run_dir, run)
    chosen = steady_snapshots(particles, run)
    if contacts is not None:
        check_contacts_match(particles, contacts, chosen)
    if x_shift is not None:
        shifts = x_shift(particles, chosen)
        if contacts is not None:
            contacts = shift_periodic_x(contacts, contact_index(particles, contacts, chosen), shifts, ("x1", "x2", "cx"))
        particles = shift_periodic_x(particles, chosen, shifts, ("x",))
        chosen = np.arange(len(particles))
    d = float(run["d"])
    kernel = Kernel(opts["kernel"], width if width is not None else opts["width_over_d"] * d)
    walls = field_checks.wall_geometry(particles, chosen)
    spacing = opts["spacing_over_width"] * kernel.width
    lx, ly = run["cell"]
    if plane:
        box = particles.boxes[chosen[0]]
        grid = plane_grid(float(box[0, 0]), float(lx), walls.bottom_mean, walls.top_mean, spacing)
    elif z is not None:
        grid = Grid(np.asarray(z, dtype=float))
    else:
        grid = profile_grid(walls.bottom_mean, walls.top_mean, dz=spacing)
    result = coarse_grain(particles, contacts, kernel, grid, snapshots=chosen, d=d, rho_s=float(run["density"]),
                          blocks=int(opts["blocks"]), time_step=float(run["time_step"]))
    ds = result.dataset
    ds.attrs.update(provenance_attrs(config))
    ds.attrs.update({
        "format_version": FIELDS_FORMAT_VERSION,
        "case": run.get("case", ""), "run": run.get("run", ""),
        "dem_provenance_json": json.dumps(run.get("provenance", {}), sort_keys=True),
        "steady_state_window": np.asarray(run["steady_state_window"], dtype=float),
        "wall_pressure": float(run["wall_pressure"]), "gravity": float(run["gravity"]),
        "wall_speed": float(run["wall_speed"]), "cell": np.asarray(run["cell"], dtype=float),
        "z_bottom_wall": walls.bottom_mean, "z_top_wall": walls.top_mean,
        "dump_source": STORE_NAME if (run_dir / STORE_NAME).is_file() else "text dumps",
    })
    if contacts is not None and not plane and x_shift is None:
        z_bottom_plane, z_top_plane = field_checks.contact_planes(particles, contacts, chosen)
        ds.attrs.update({"z_bottom_contact_plane": z_bottom_plane, "z_top_contact_plane": z_top_plane})
        times = particles.timesteps[chosen] * float(run["time_step"])
        u_disp, u_disp_err = displacement_velocity(particles, chosen, times, kernel, ds.z.values, int(opts["blocks"]))
        ds["u_x_disp"] = ("z", u_disp, {"units": "m s-1", "long_name": "velocity along x from the grains' mean "
                                        "displacement over the window (pipeline.coarse_graining.displacement)"})
        ds["u_x_disp_err"] = ("z", u_disp_err, {"units": "m s-1", "long_name": "standard error of u_x_disp from "
                                                f"{min(int(opts['blocks']), chosen.size - 1)} sub-window batch means"})
        add_half_windows(ds, particles, chosen, times, kernel, int(opts["blocks"]))
    if not plane and x_shift is None:
        ds.attrs.update(bulk_means(result, ds, walls, opts, d, float(run["density"])))
        add_structural_error(ds, particles, chosen, kernel, d, opts["bulk_margin_over_d"] * d)
    if not plane and x_shift is None:
        series = production_series(run_dir, run)
        ds.attrs.update(wall_friction(series))
        if "u_x_disp" in ds:
            ds.attrs.update(wall.wall_attrs(ds, series, run))
    found: dict[str, Any] = {}
    if checks and not plane:
        found = physical_checks(ds, run, run_dir, particles, contacts, chosen, kernel, walls, opts, result.sums)
        for key, value in found.items():
            ds.attrs[f"check_{key}"] = value
    return result, found


def wall_friction(series: pd.DataFrame, blocks: int = 8) -> dict[str, float]:
    """The top wall's friction ``|<f_x>| / <f_z>`` over the production window and its standard
    error: the larger of the batch-means error of ``blocks`` blocks' ratios and the autocorrelation-
    time estimate of the per-sample ratio's mean (the wall's slip events correlate the samples)."""
    fx, fz = series["ftop_x"].to_numpy(), series["ftop_z"].to_numpy()
    value = float(abs(fx.mean()) / fz.mean())
    ratios = np.array([abs(bx.mean()) / bz.mean() for bx, bz in zip(np.array_split(fx, blocks), np.array_split(fz, blocks))])
    block_err = float(ratios.std(ddof=1) / math.sqrt(blocks))
    sample = np.abs(fx) / np.where(fz > 0, fz, np.nan)
    auto_err = autocorrelated_mean_error(sample[np.isfinite(sample)])
    return {"wall_friction": value, "wall_friction_err": float(np.nanmax([block_err, auto_err]))}


def add_half_windows(ds: xr.Dataset, particles: Dump, chosen: np.ndarray, times: np.ndarray, kernel: Kernel,
                     blocks: int) -> None:
    """``u_x_disp`` over the first and the second half of the window (``u_x_disp_first_half``,
    ``u_x_disp_second_half``, each with its time error): creep still relaxing shows as a second half
    slower than the first beyond their errors (validation/creep_halves.csv). The halves share the
    packing, so the structural error, common to both, is left out of their difference.

    Each half's error comes from ``blocks`` sub-windows of its own (as many as the whole window's):
    with half as many, each half's error had one degree of freedom and the halves' z two, whose
    Student t puts 18 % of steady runs' points beyond 2 (16 of 86 on the 2026-12-02 default, read
    as errors understated by 1.8). The blocks used are ``half_window_blocks``."""
    used = min(int(blocks), (chosen.size - 1) // 2)
    if used < 2:
        return
    middle = chosen.size // 2
    for name, part in (("first_half", slice(0, middle + 1)), ("second_half", slice(middle, None))):
        u, err = displacement_velocity(particles, chosen[part], times[part], kernel, ds.z.values, used)
        ds[f"u_x_disp_{name}"] = ("z", u, {"units": "m s-1", "long_name": f"u_x_disp over the {name.replace('_', ' ')} "
                                           "of the window"})
        ds[f"u_x_disp_{name}_err"] = ("z", err, {"units": "m s-1", "long_name": f"standard error of u_x_disp_{name} "
                                                 "from its sub-window batch means"})
    ds.attrs["half_window_split_time"] = float(times[middle])
    ds.attrs["half_window_blocks"] = used


def add_structural_error(ds: xr.Dataset, particles: Dump, chosen: np.ndarray, kernel: Kernel, d: float,
                         margin: float) -> None:
    """``nu_err`` becomes the larger of the time error and the packing's structural error
    (:mod:`pipeline.coarse_graining.structure`); both are kept as ``nu_err_time`` and
    ``nu_err_structure``; ``margin`` (m) from the walls bounds the points the exponent is fitted on."""
    z = ds.z.values
    bulk = (z >= float(ds.attrs["z_bottom_wall"]) + margin) & (z <= float(ds.attrs["z_top_wall"]) - margin)
    frozen, alpha, (nx, ny) = structure.structural_error(particles, chosen, kernel, z, d, bulk)
    ds["nu_err_time"] = ("z", ds["nu_err"].values.copy(),
                         {"units": "1", "long_name": "standard error of nu from the time blocks"})
    ds["nu_err_structure"] = ("z", frozen, {"units": "1", "long_name": (
        f"standard error of nu from the packing's frozen structure: scatter of {nx} x {ny} patches, "
        f"extrapolated to the cell with variance ~ area^-{alpha:.2f}")})
    ds.attrs["nu_structure_alpha"] = alpha
    ds["nu_err"] = ("z", np.fmax(ds["nu_err"].values, frozen), dict(ds["nu_err"].attrs))
    if "u_x_disp" in ds:
        times = particles.timesteps[chosen] * float(ds.attrs["time_step"])
        frozen, alpha = displacement_structural_error(particles, chosen, times, kernel, z, d, bulk)
        ds["u_x_disp_err_time"] = ("z", ds["u_x_disp_err"].values.copy(), dict(ds["u_x_disp_err"].attrs))
        ds["u_x_disp_err_structure"] = ("z", frozen, {"units": "m s-1", "long_name": (
            "standard error of u_x_disp from the creep's frozen structure: scatter of patches of the cell, "
            f"extrapolated to the cell with variance ~ area^-{alpha:.2f}")})
        ds.attrs["u_x_disp_structure_alpha"] = alpha
        ds["u_x_disp_err"] = ("z", np.fmax(ds["u_x_disp_err"].values, frozen), dict(ds["u_x_disp_err"].attrs))


#: Fields whose bulk mean (and its error) the fields file carries as ``bulk_<name>`` attributes.
BULK_FIELDS = ("nu", "p", "mu", "I", "shear_rate", "sigma_xx", "sigma_yy", "sigma_zz", "sigma_xz", "fluidity",
               "granular_temperature")


def bulk_means(result: Result, ds: xr.Dataset, walls: field_checks.WallGeometry, opts: dict[str, Any], d: float,
               rho_s: float) -> dict[str, float]:
    """Bulk means (``bulk_margin_over_d`` from both walls' mean heights) with their own errors.

    The per-snapshot sums are averaged over the bulk points first and the fields derived from
    those, then block-averaged like the profiles (:func:`block_average`): the error of a bulk mean
    then counts the points' correlations (kernel overlap, a wall oscillation shared by the whole
    layer) as they are, where the mean of the pointwise errors would count them as total.
    """
    margin = opts["bulk_margin_over_d"] * d
    z = ds.z.values
    inside = (z >= walls.bottom_mean + margin) & (z <= walls.top_mean - margin)
    if inside.sum() < 3:
        return {}
    sums = result.sums[..., inside].mean(axis=-1, keepdims=True)
    fields, errors, _ = block_average(sums, int(opts["blocks"]), d, rho_s)
    out: dict[str, float] = {"bulk_margin_over_d": float(opts["bulk_margin_over_d"])}
    for name in BULK_FIELDS:
        out[f"bulk_{name}"] = float(fields[name][0])
        out[f"bulk_{name}_err"] = float(errors[name][0])
    return out


def physical_checks(ds: xr.Dataset, run: dict[str, Any], run_dir: Path, particles: Dump, contacts: Dump | None,
                    chosen: np.ndarray, kernel: Kernel, walls: field_checks.WallGeometry,
                    opts: dict[str, Any], sums: np.ndarray | None = None) -> dict[str, float]:
    """Momentum balance and wall stress (see :mod:`pipeline.coarse_graining.field_checks`);
    ``sums``, the per-snapshot sums of the fields, add the slope's error from its own time series."""
    d, g = float(run["d"]), float(run["gravity"])
    area = float(run["cell"][0] * run["cell"][1])
    margin = opts["bulk_margin_over_d"] * d
    out = {f"balance_{k}": v for k, v in
           field_checks.momentum_balance(ds, g, walls.bottom_max + margin, walls.top_min - margin).items()}
    if sums is not None and g > 0:
        out.update({f"balance_{k}": v for k, v in field_checks.slope_series_check(
            sums, ds.z.values, walls.bottom_max + margin, walls.top_min - margin, g, d, float(run["density"]),
            int(opts["blocks"])).items()})
    below, _ = field_checks.body_mass_below(particles, chosen, kernel, walls.bottom_max + kernel.cutoff)
    _, above = field_checks.body_mass_below(particles, chosen, kernel, walls.top_min - kernel.cutoff)
    series = production_series(run_dir, run)
    fb = series[["fbot_x", "fbot_x", "fbot_z"]].mean().to_numpy() * [1, 0, 1]
    ft = series[["ftop_x", "ftop_x", "ftop_z"]].mean().to_numpy() * [1, 0, 1]
    for key, value in field_checks.wall_stress(ds, kernel, walls, area, g, below, above, fb, ft).items():
        out[f"wall_series_{key}"] = value
    # Standard errors of the series means from 5 blocks, to judge the comparison.
    for col in ("fbot_x", "fbot_z", "ftop_x", "ftop_z"):
        means = np.array([b.mean() for b in np.array_split(series[col].to_numpy(), 5)])
        out[f"series_{col}_err_over_area"] = float(means.std(ddof=1) / math.sqrt(len(means)) / area)
    if contacts is not None:
        forces = field_checks.contact_wall_forces(particles, contacts, chosen)
        same = field_checks.wall_stress(ds, kernel, walls, area, g, below, above,
                                        forces["bottom"].mean(axis=0), forces["top"].mean(axis=0))
        for key, value in same.items():
            if key.endswith(("_expected", "_residual", "_residual_over_normal")):
                out[f"wall_dump_{key}"] = value
        identity = field_checks.contact_stress_identity(particles, contacts, chosen, kernel, walls, g)
        out.update({f"identity_{k}": float(v) for k, v in identity.items()})
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--config", type=Path, required=True)
    parser.add_argument("--run-dir", type=Path, required=True, help="RESULTS/dem/CASE/RUN")
    parser.add_argument("--out", type=Path, required=True, help="RESULTS/fields/CASE/RUN.nc")
    parser.add_argument("--plane", choices=("xz",), default=None, help="x-z fields (also writes a .vts)")
    parser.add_argument("--particles-vtk", type=Path, default=None, metavar="DIR",
                        help="also write the grains of every averaged snapshot as DIR/particles_*.vtu and "
                             "DIR/particles.pvd (radius, velocity, type) for ParaView")
    args = parser.parse_args(argv)
    from pipeline.common.config import load_config

    atomic.clear_stale(args.out.with_suffix(".vts"), temporaries_of=(args.out,))
    try:
        config = load_config(args.config)
        run = read_run_json(args.run_dir)
        plane = args.plane == "xz" or run.get("case") in settings(config)["plane_cases"]
        result, checks = run_fields(config, args.run_dir, plane=plane)
    except (DumpError, CoarseGrainError, ValueError, KeyError) as err:
        print(f"error: {args.run_dir}: {err}", file=sys.stderr)
        return 1
    if plane:
        write_fields_vtk(result.dataset, args.out.with_suffix(".vts"))
    write_netcdf(result.dataset, args.out)
    if args.particles_vtk is not None:
        particles, _ = load_tables(args.run_dir, run)
        collection = write_particles_vtu(particles, steady_snapshots(particles, run), args.particles_vtk,
                                         time_step=float(run["time_step"]))
        print(f"{collection}: the grains of the averaged snapshots")
    summary = ", ".join(f"{k}={v:.4g}" for k, v in checks.items()
                        if k in ("balance_residual_xz", "balance_residual_zz") or k.endswith("_residual"))
    print(f"{args.out}: {result.dataset.attrs['number_of_snapshots']} snapshots in {result.seconds:.2f} s; {summary}")
    return 0
