"""Score every model against the DEM fields: ``scores.csv``.

Reference: the mean of the case's DEM replicas (each interpolated onto the first replica's z),
with the standard error of that mean. ``dem_noise``: the same metric between two independent
replicas (mean over the pairs), the floor below which no model can be said to do better.
Profiles are compared inside the layer, at least ``wall_margin_over_d`` d from both walls (the
wall grains themselves are not the material the models describe).

Usage: ``python -m pipeline.scoring.scores --fields RESULTS/fields/CASE/RUN.nc ... --models
RESULTS/models/CASE/MODEL.nc ... --out RESULTS/scores.csv`` (files are grouped by their folder,
the case name).
"""
from __future__ import annotations

import argparse
import itertools
import json
import math
from pathlib import Path
from typing import Callable

import numpy as np
import pandas as pd
import xarray as xr

from pipeline.calibration.calibrate import microscopic_fluidity
from pipeline.common import atomic
from pipeline.common.observables import creep_speed
from pipeline.scoring import metrics
from pipeline.scoring.metrics import MetricError, Profile

COLUMNS = ["case", "model", "metric", "value", "dem_noise", "n_grid", "solve_seconds", "role"]

#: ``role`` of a case: a fit where any of its runs fed the calibration, else a prediction.
ROLES = ("calibration", "held_out")
WALL_MARGIN_OVER_D = 1.0


def replica_profiles(files: list[Path]) -> list[xr.Dataset]:
    """The replicas' fields, each interpolated onto the first replica's z."""
    if not files:
        raise FileNotFoundError("no DEM fields files to score against")
    return align_replicas([xr.open_dataset(f) for f in files])


def align_replicas(sets: list[xr.Dataset]) -> list[xr.Dataset]:
    """Replica profiles, each interpolated onto the first one's z (their walls differ slightly),
    with the creep speed ``u_creep`` (:func:`pipeline.common.observables.creep_speed`) added."""
    aligned = [sets[0]] + [ds.interp(z=sets[0].z) for ds in sets[1:]]
    out = []
    for ds in aligned:
        u, err, _ = creep_speed(ds)
        out.append(ds.assign(u_creep=("z", u, {"units": "m s-1", "long_name": "creep speed (u_x or u_x_disp)"}),
                             u_creep_err=("z", err, {"units": "m s-1", "long_name": "its standard error"})))
    return out


def interior(ds: xr.Dataset) -> np.ndarray:
    """Mask of the points at least the wall margin from both walls' grain centres.

    The wall layer (within ``WALL_MARGIN_OVER_D`` d of a wall's grain centres) is excluded from
    every profile score: there the grains touch a rigid rough wall, a boundary layer none of the
    bulk laws describes (its stress ratio is far above the rheometer bulk's at the same I).
    """
    d = float(ds.attrs["d"])
    z0, z1 = float(ds.attrs["z_bottom_wall"]), float(ds.attrs["z_top_wall"])
    z = ds.z.values
    return (z >= z0 + WALL_MARGIN_OVER_D * d) & (z <= z1 - WALL_MARGIN_OVER_D * d)


def mean_profile(reps: list[xr.Dataset], name: str) -> tuple[np.ndarray, np.ndarray]:
    """Replica mean of a variable and its standard error (from the replicas' own errors)."""
    values = np.array([ds[name].values for ds in reps])
    errors = np.array([ds[f"{name}_err"].values for ds in reps])
    return values.mean(axis=0), np.sqrt((errors**2).sum(axis=0)) / len(reps)


Metric = Callable[[np.ndarray, dict[str, np.ndarray], Profile, float], float]


def metric_table(z: np.ndarray, wall_speed: float) -> dict[str, tuple[str, Callable[..., float]]]:
    """metric name -> (variable it needs, function(model_values, dem_values, dem_err))."""

    def vel_rmse(m, dem, err):
        return metrics.velocity_rmse_rel(z, m, dem, wall_speed)

    def log_rmse(m, dem, err):
        prof = Profile(z, dem, err)
        return metrics.log_velocity_rmse(m, prof, metrics.creeping_mask(prof, wall_speed))

    def decay(m, dem, err):
        prof = Profile(z, dem, err)
        return metrics.decay_length_rel_err(z, m, prof, metrics.creeping_mask(prof, wall_speed))

    def band(m, dem, err):
        return metrics.shear_band_width_rel_err(z, m, dem, wall_speed)

    def plain(m, dem, err):
        return metrics.rmse(m, dem)

    def log_fluidity(m, dem, err):
        return metrics.log_rmse_resolved(m, dem, err)

    return {
        "velocity_rmse_rel": ("u_x", vel_rmse),
        "log_velocity_rmse": ("u_x", log_rmse),
        "decay_length_rel_err": ("u_x", decay),
        "shear_band_width_rel_err": ("u_x", band),
        "nu_rmse": ("nu", plain),
        "mu_rmse": ("mu", plain),
        "fluidity_log_rmse": ("fluidity", log_fluidity),
        "fluidity_micro_log_rmse": ("fluidity", log_fluidity),
    }


#: The DEM variable a metric compares the model's variable with, where the two differ: the
#: creep metrics use the creep speed (u_x or, deeper, the displacement-based u_x_disp).
DEM_VARIABLE = {"log_velocity_rmse": "u_creep", "decay_length_rel_err": "u_creep",
                "fluidity_micro_log_rmse": "fluidity_micro"}


#: Variables compared in log: between two replicas only where both resolve them (a replica's
#: unresolved, possibly negative, creep is not a prediction of zero).
LOG_VARIABLES = ("u_creep", "fluidity", "fluidity_micro")


def dem_noise(reps: list[xr.Dataset], variable: str, fn: Callable[..., float], mask: np.ndarray) -> float:
    """Mean of the metric between pairs of replicas (nan with a single replica)."""
    finite = pair_values(reps, variable, fn, mask)
    return float(np.mean(finite)) if finite else float("nan")


def pair_values(reps: list[xr.Dataset], variable: str, fn: Callable[..., float], mask: np.ndarray) -> list[float]:
    """The metric between each pair of replicas (replica a as the model, b as the DEM), finite ones only."""
    values = []
    for a, b in itertools.combinations(reps, 2):
        err = b[f"{variable}_err"].values
        if variable in LOG_VARIABLES:
            # Where replica a does not resolve the value, b's point is left out (as unresolved).
            err = np.where(metrics.resolved(a[variable].values, a[f"{variable}_err"].values), err, np.inf)
        try:
            values.append(fn(a[variable].values[mask], b[variable].values[mask], err[mask]))
        except MetricError:
            continue
    return [v for v in values if math.isfinite(v)]


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


def score_case(case: str, field_files: list[Path], model_files: dict[str, Path], params: dict | None = None) -> pd.DataFrame:
    """All metric rows of one case (``params``: the calibration, for the microscopic fluidity)."""
    reps = with_microscopic_fluidity(replica_profiles(field_files), params)
    mask = interior(reps[0])
    z = reps[0].z.values[mask]
    wall_speed = float(reps[0].attrs["wall_speed"])
    rows = []
    table = metric_table(z, wall_speed)
    for model, path in sorted(model_files.items()):
        sol = xr.open_dataset(path)
        if not np.allclose(sol.z.values, reps[0].z.values):
            raise ValueError(f"{path}: model z does not match the DEM fields of {case} (solve it on those fields)")
        for metric, (variable, fn) in table.items():
            observed = DEM_VARIABLE.get(metric, variable)
            if variable not in sol or observed not in reps[0]:
                continue  # the model does not predict this quantity (or the DEM does not measure it): no row
            dem, err = mean_profile(reps, observed)
            try:
                value = fn(sol[variable].values[mask], dem[mask], err[mask])
            except MetricError:
                continue
            rows.append({
                "case": case, "model": model, "metric": metric, "value": value,
                "dem_noise": dem_noise(reps, observed, fn, mask),
                "n_grid": int(sol.attrs["n_grid"]), "solve_seconds": float(sol.attrs["solve_seconds"]),
            })
        sol.close()
    return pd.DataFrame(rows, columns=COLUMNS)


def moving_rod_speeds(runs: list[dict]) -> dict[float, list[float]]:
    """Speeds (m/s) of the sheared rods that move (not arrested), by target depth (in d)."""
    by_depth: dict[float, list[float]] = {}
    for r in runs:
        if not r["intruder"]["control"] and not r["intruder"]["arrested"]:
            by_depth.setdefault(round(r["intruder"]["depth_target_over_d"], 6), []).append(r["intruder"]["speed"])
    return by_depth


def intruder_noise_terms(by_depth: dict[float, list[float]]) -> list[float]:
    """``|log10(U_a / U_b)|`` for each pair of replicas' rods at one depth (moving forward)."""
    return [abs(math.log10(a / b)) for v in by_depth.values() for a, b in itertools.combinations(v, 2) if a > 0 and b > 0]


def score_intruder(runs: list[dict], model_files: dict[str, Path]) -> pd.DataFrame:
    """``intruder_speed_log_err``: RMS of log10(U_model / U_dem) over the depths where the DEM rod
    moves (not arrested) and the model gives a speed; inf where the model predicts no motion.

    DEM speeds at one depth are averaged over replicas; ``dem_noise`` is the same metric between
    two replicas at the same depth (nan with one replica).
    """
    sheared = [r for r in runs if not r["intruder"]["control"]]
    by_depth = moving_rod_speeds(runs)
    if not by_depth:
        raise MetricError("no intruder run moves: nothing to score")
    actual = {}
    for r in sheared:
        actual.setdefault(round(r["intruder"]["depth_target_over_d"], 6), []).append(r["intruder"]["depth_over_d"])
    noise_terms = intruder_noise_terms(by_depth)
    noise = float(np.sqrt(np.mean(np.square(noise_terms)))) if noise_terms else float("nan")
    rows = []
    for model, path in sorted(model_files.items()):
        sol = xr.open_dataset(path)
        errors = []
        for target, speeds in by_depth.items():
            depth = float(np.mean(actual[target]))
            match = np.nonzero(np.isclose(sol.depth_over_d.values, depth, atol=0.5))[0]
            if match.size == 0:
                continue  # the model refused this depth (listed in its file)
            u = float(sol.speed.values[match[0]])
            errors.append(math.inf if u <= 0.0 else math.log10(u / float(np.mean(speeds))))
        if errors:
            value = math.inf if any(math.isinf(e) for e in errors) else float(np.sqrt(np.mean(np.square(errors))))
            rows.append({"case": "intruder", "model": model, "metric": "intruder_speed_log_err", "value": value,
                         "dem_noise": noise, "n_grid": int(sol.attrs["n_grid"]),
                         "solve_seconds": float(sol.attrs["solve_seconds"])})
        sol.close()
    return pd.DataFrame(rows, columns=COLUMNS)


def calibration_cases(params: dict) -> set[str]:
    """Cases any of whose runs the calibration read (``params.json`` ``calibration_runs``)."""
    if "calibration_runs" not in params:
        raise ValueError("params.json has no calibration_runs: written by an older calibration, rerun it")
    return {label.split("/")[0] for label in params["calibration_runs"]}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Score the continuum models against the DEM fields.")
    parser.add_argument("--fields", nargs="+", required=True, type=Path, help="fields/CASE/RUN.nc files")
    parser.add_argument("--models", nargs="+", required=True, type=Path, help="models/CASE/MODEL.nc files")
    parser.add_argument("--intruder-runs", nargs="*", default=[], type=Path, help="run.json of the intruder runs")
    parser.add_argument("--intruder-models", nargs="*", default=[], type=Path, help="models/intruder/MODEL.nc files")
    parser.add_argument("--params", required=True, type=Path,
                        help="calibration/params.json: its calibration_runs decide each case's role")
    parser.add_argument("--out", required=True, type=Path)
    args = parser.parse_args(argv)
    frames = []
    if args.intruder_models:
        runs = [json.loads(p.read_text()) for p in args.intruder_runs]
        frames.append(score_intruder(runs, {p.stem: p for p in args.intruder_models}))
    params = json.loads(args.params.read_text())
    for case in sorted({p.parent.name for p in args.models}):
        field_files = sorted(p for p in args.fields if p.parent.name == case)
        model_files = {p.stem: p for p in args.models if p.parent.name == case}
        frames.append(score_case(case, field_files, model_files, params))
    scores = pd.concat(frames, ignore_index=True)
    calibrated = calibration_cases(params)
    scores["role"] = np.where(scores["case"].isin(calibrated), ROLES[0], ROLES[1])
    atomic.write_csv(scores, args.out)
    print(scores.to_string(index=False))
    return 0
