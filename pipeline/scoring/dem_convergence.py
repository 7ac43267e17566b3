"""DEM field noise against cost: system size and averaging time (``dem_convergence/{case}.csv``).

The noise of a DEM field is measured as the scores measure a model: the metric between two
independent replicas (``pipeline.scoring.scores.dem_noise``, mean over pairs), inside the layer. Two
sweeps, each read against the core-seconds one replica cost (LIGGGHTS wall-clock seconds times
MPI ranks):

* **averaging time**: the case's replicas, coarse-grained over the first 1/8, 1/4, 1/2 and all of
  their production snapshots (block errors from the same per-snapshot sums). The cost of a
  shorter average is the run's transient plus that share of its production;
* **system size**: the case's ``size_study`` runs (square cells of other lengths, same grains
  per area) next to the case's own replicas, all averaged over their whole production.

Noise is expected to fall as 1/sqrt(averaging time) and as 1/L (the independent samples of a
profile bin grow with the cell's area), until the replicas' difference is no longer noise but a
systematic effect of size. ``noise_per_sqrt_cost`` = noise * sqrt(core-seconds) compares the two
ways of spending CPU: the sweep with the lower value buys noise more cheaply.

Usage: ``python -m pipeline.scoring.dem_convergence --config C --case shear_gravity --runs RESULTS/dem/
shear_gravity/r1/run.json ... --fields RESULTS/fields/shear_gravity/L4-r1.nc ... --out F.csv``
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

from pipeline.common import atomic
from pipeline.coarse_graining.coarse_grain import block_average
from pipeline.common.config import load_config, size_study_cell
from pipeline.coarse_graining.displacement import displacement_velocity
from pipeline.coarse_graining.fields import load_tables, run_fields, settings, steady_snapshots
from pipeline.coarse_graining.kernels import Kernel
from pipeline.common.formats import open_fields
from pipeline.scoring.scores import DEM_VARIABLE, align_replicas, dem_noise, interior, metric_table

#: Shares of the production snapshots in the averaging-time sweep.
AVERAGING_FRACTIONS = (0.125, 0.25, 0.5, 1.0)
#: The metrics the noise is given in: the velocity and packing scores of the report's table.
NOISE_METRICS = ("log_velocity_rmse", "velocity_rmse_rel", "nu_rmse", "mu_rmse")
COLUMNS = ["case", "study", "cell_over_d", "n_grains", "n_replicas", "averaging_fraction", "averaging_strain",
           "core_seconds", "metric", "noise", "noise_per_sqrt_cost"]


def run_cost(run: dict[str, Any]) -> tuple[float, float]:
    """(transient, production) core-seconds of one run, split by their share of the steps."""
    total = float(run["wall_clock_seconds"]) * int(run.get("mpi_ranks") or 1)
    share = run["production_chunks"] * run["chunk_steps"] / run["steps"]
    return total * (1.0 - share), total * share


def production_strain(run: dict[str, Any]) -> float:
    """Wall displacement over depth during production (the averaging window's strain)."""
    t0, t1 = run["production_window"]
    return (t1 - t0) * float(run["wall_speed"]) / float(run["settled_gap"])


def noise_rows(reps: list[xr.Dataset]) -> dict[str, float]:
    """Each noise metric between the replicas (interpolated onto the first one's z)."""
    aligned = align_replicas(reps)
    mask = interior(aligned[0])
    table = metric_table(aligned[0].z.values[mask], float(aligned[0].attrs["wall_speed"]))
    out = {}
    for metric in NOISE_METRICS:
        variable, fn = table[metric]
        out[metric] = dem_noise(aligned, DEM_VARIABLE.get(metric, variable), fn, mask)
    return out


def truncated_fields(result_ds: xr.Dataset, sums: np.ndarray, n: int, blocks: int) -> xr.Dataset:
    """The profile fields of the first ``n`` snapshots (same grid and attributes).

    Errors as the fields file's: the time error of the shorter window, and for nu not below the
    frozen structure's error of ``result_ds`` (``nu_err_structure``), which no averaging time
    lowers; so at ``n`` = all snapshots the errors, and what they mask, are the scored ones.
    """
    d, rho_s = float(result_ds.attrs["d"]), float(result_ds.attrs["rho_s"])
    fields, errors, _ = block_average(sums[:n], blocks, d, rho_s)
    ds = xr.Dataset(coords={"z": result_ds.z}, attrs=dict(result_ds.attrs))
    for name in ("u_x", "nu", "mu"):
        ds[name] = ("z", fields[name])
        err = np.asarray(errors[name], dtype=float)
        if f"{name}_err_structure" in result_ds:
            err = np.fmax(err, result_ds[f"{name}_err_structure"].values)
        ds[f"{name}_err"] = ("z", err)
    return ds


def averaging_sweep(config: dict[str, Any], case: str, run_dirs: list[Path]) -> list[dict[str, Any]]:
    """Noise against averaging time over the case's replicas."""
    opts = settings(config)
    blocks = int(opts["blocks"])
    results, runs, tracks = [], [], []
    for run_dir in run_dirs:
        result, _ = run_fields(config, run_dir, checks=False)
        results.append(result)
        run = json.loads((run_dir / "run.json").read_text())
        runs.append(run)
        particles, _ = load_tables(run_dir, run)
        tracks.append((particles, steady_snapshots(particles, run), float(run["time_step"]),
                       Kernel(opts["kernel"], opts["width_over_d"] * float(run["d"]))))
    rows = []
    for fraction in AVERAGING_FRACTIONS:
        # The fraction is of each replica's own production: with production to a target precision
        # replicas may stop at different lengths, and at fraction 1 the sweep is the scored fields.
        reps, used = [], []
        for result, (particles, chosen, dt, kernel) in zip(results, tracks):
            n_snap = result.sums.shape[0]
            n = max(2, int(round(fraction * n_snap)))
            used.append(n / n_snap)
            ds = truncated_fields(result.dataset, result.sums, n, blocks)
            # The displacement-based creep speed over the same shorter window (the creep metrics use it).
            u, err = displacement_velocity(particles, chosen[:n], particles.timesteps[chosen[:n]] * dt, kernel,
                                           ds.z.values, blocks)
            if "u_x_disp_err_structure" in result.dataset:
                err = np.fmax(err, result.dataset["u_x_disp_err_structure"].values)
            reps.append(ds.assign(u_x_disp=("z", u), u_x_disp_err=("z", err)))
        costs = [t + share * p for share, (t, p) in zip(used, map(run_cost, runs))]
        strain = float(np.mean([production_strain(r) * share for r, share in zip(runs, used)]))
        used = float(np.mean(used))
        for metric, value in noise_rows(reps).items():
            rows.append(_row(case, "averaging_time", runs[0], len(runs), used, strain, float(np.mean(costs)), metric, value))
    return rows


def size_sweep(case: str, groups: dict[float, list[tuple[dict[str, Any], xr.Dataset]]]) -> list[dict[str, Any]]:
    """Noise against system size: one row per (cell length, metric), whole production averaged."""
    rows = []
    for cell, members in sorted(groups.items()):
        if len(members) < 2:
            raise ValueError(f"{case}: cell {cell:g} d has {len(members)} replica; the noise needs two or more")
        runs = [r for r, _ in members]
        cost = float(np.mean([sum(run_cost(r)) for r in runs]))
        strain = float(np.mean([production_strain(r) for r in runs]))
        for metric, value in noise_rows([ds for _, ds in members]).items():
            rows.append(_row(case, "system_size", runs[0], len(runs), 1.0, strain, cost, metric, value))
    return rows


def _row(case: str, study: str, run: dict[str, Any], n_rep: int, fraction: float, strain: float, cost: float,
         metric: str, value: float) -> dict[str, Any]:
    return {"case": case, "study": study, "cell_over_d": run["cell"][0] / run["d"], "n_grains": run["flowing_grains"],
            "n_replicas": n_rep, "averaging_fraction": fraction, "averaging_strain": strain, "core_seconds": cost,
            "metric": metric, "noise": value, "noise_per_sqrt_cost": value * np.sqrt(cost)}


def convergence_table(config: dict[str, Any], case: str, run_jsons: list[Path], fields: list[Path]) -> pd.DataFrame:
    """Both sweeps of one case. ``run_jsons`` and ``fields`` list the same runs in the same order:
    the case's replicas (``r<k>``) and its size-study runs (``L<cell>-r<k>``)."""
    runs = [json.loads(p.read_text()) for p in run_jsons]
    replicas = [p.parent for p, r in zip(run_jsons, runs, strict=True) if size_study_cell(r["run"]) is None]
    if len(replicas) < 2:
        raise ValueError(f"{case}: {len(replicas)} replica; the DEM noise needs two or more (cases.{case}.replicas)")
    groups: dict[float, list[tuple[dict[str, Any], xr.Dataset]]] = {}
    for run, path in zip(runs, fields, strict=True):
        if run["run"] != Path(path).stem:
            raise ValueError(f"{path}: fields file does not belong to run {run['case']}/{run['run']}")
        groups.setdefault(round(run["cell"][0] / run["d"], 6), []).append((run, open_fields(path)))
    rows = averaging_sweep(config, case, replicas) + size_sweep(case, groups)
    return pd.DataFrame(rows, columns=COLUMNS)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="DEM field noise against cost: system size and averaging time.")
    parser.add_argument("--config", required=True)
    parser.add_argument("--case", required=True)
    parser.add_argument("--runs", nargs="+", required=True, type=Path, help="run.json of the replicas and size-study runs")
    parser.add_argument("--fields", nargs="+", required=True, type=Path, help="their fields files, same order")
    parser.add_argument("--out", required=True, type=Path)
    args = parser.parse_args(argv)
    config = load_config(args.config)
    table = convergence_table(config, args.case, args.runs, args.fields)
    atomic.write_csv(table, args.out)
    pd.set_option("display.width", 200)
    print(table.to_string(index=False))
    return 0
