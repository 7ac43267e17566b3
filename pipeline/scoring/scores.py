"""Score every model against the DEM fields: ``scores.csv``, and the verdict built on it.

Reference: the mean of the case's DEM replicas (:mod:`pipeline.scoring.replicas`), with the
standard error of that mean. ``dem_noise``: the same metric between two independent replicas (mean
over the pairs; ``dem_noise_err`` its standard error over the pairs, ``dem_noise_pairs`` their
number), the spread a single replica would show. Each score also carries its uncertainty
(:mod:`pipeline.scoring.uncertainty`): ``u_dem`` (the DEM mean's), ``u_input`` (the calibration's,
over the parameter draws), ``u_num`` (the grid's) and ``u_val``, their root sum of squares. With
``--verdict-out`` the same run writes which models can be told apart (:mod:`pipeline.scoring.verdict`).

Usage: ``python -m pipeline.scoring.scores --config C --fields RESULTS/fields/CASE/RUN.nc ... --models
RESULTS/models/CASE/MODEL.nc ... --model-draws RESULTS/model_draws/CASE/MODEL.nc ... --params P
--out RESULTS/scores.csv`` (files are grouped by their folder, the case name).
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

from pipeline.common import atomic
from pipeline.common.config import derived_seed, load_config
from pipeline.scoring import metrics, verdict
from pipeline.scoring.force_sweep import score_force_sweep
from pipeline.scoring.intruder_bed_scores import score_intruder_bed
from pipeline.scoring.intruder_field_scores import score_intruder_fields
from pipeline.scoring.intruder_scores import score_intruder
from pipeline.scoring.metrics import MetricError, Profile
from pipeline.scoring.replicas import (WALL_MARGIN_OVER_D, align_replicas, interior, mean_profile,  # noqa: F401 (re-exported)
                                       replica_profiles, with_microscopic_fluidity)
from pipeline.scoring.score_table import COLUMNS, ROLES, ScoringSettings  # noqa: F401 (re-exported)
from pipeline.scoring.wall_scores import score_wall, wall_table
from pipeline.scoring.uncertainty import (LOG_RESAMPLED, DemNoise, OffsetNoise, ScoreSamples, dem_noise_model, offset_noise,
                                          offset_profiles, resample_profile)



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


def noise_error(values: list[float]) -> float:
    """Standard error of the mean of the pair values (NaN with fewer than two pairs). The pairs
    of n replicas share replicas, so this understates the error when n is small; it says how
    well the noise floor is known, not more."""
    return float(np.std(values, ddof=1) / math.sqrt(len(values))) if len(values) >= 2 else float("nan")


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


def _evaluate(fn: Callable[..., float], model: np.ndarray, dem: np.ndarray, err: np.ndarray) -> float:
    try:
        return float(fn(model, dem, err))
    except MetricError:
        return math.nan


def score_case(case: str, field_files: list[Path], model_files: dict[str, Path], params: dict | None = None,
               draw_files: dict[str, Path] | None = None, settings: ScoringSettings = ScoringSettings()
               ) -> tuple[pd.DataFrame, dict[tuple[str, str, str], ScoreSamples]]:
    """All metric rows of one case and their resamples (module docstring). ``params``: the
    calibration (for the microscopic fluidity); ``draw_files``: model -> ``model_draws`` file
    (without them the rows have no ``u_input`` nor ``u_num``)."""
    reps = with_microscopic_fluidity(replica_profiles(field_files), params)
    mask = interior(reps[0])
    z = reps[0].z.values[mask]
    wall_speed = float(reps[0].attrs["wall_speed"])
    rows, samples = [], {}
    table = metric_table(z, wall_speed)
    resampled: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray, DemNoise]] = {}

    def dem_of(variable: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, DemNoise, np.ndarray, OffsetNoise]:
        # One set of resamples per DEM variable, shared by every model (paired comparisons), from a
        # seed of its own so that adding a model or a metric leaves the others' numbers unchanged.
        if variable not in resampled:
            dem, err = mean_profile(reps, variable)
            noise = dem_noise_model(reps, variable)
            log = variable in LOG_RESAMPLED
            rng = np.random.default_rng(derived_seed(settings.seed, "scoring", case, variable))
            draws = resample_profile(dem[mask], err[mask], noise, settings.dem_resamples, rng, log=log)
            offset = offset_noise(np.array([ds[variable].values[mask] for ds in reps]),
                                  np.array([ds[f"{variable}_err"].values[mask] for ds in reps]), noise, log)
            shifted = offset_profiles(dem[mask], err[mask], offset, len(reps), settings.dem_resamples, rng, log)
            resampled[variable] = (dem[mask], err[mask], draws, noise, shifted, offset)
        return resampled[variable]

    for model, path in sorted(model_files.items()):
        sol = xr.open_dataset(path)
        ens = xr.open_dataset(draw_files[model]) if draw_files and model in draw_files else None
        if not np.allclose(sol.z.values, reps[0].z.values):
            raise ValueError(f"{path}: model z does not match the DEM fields of {case} (solve it on those fields)")
        for metric, (variable, fn) in table.items():
            observed = DEM_VARIABLE.get(metric, variable)
            if variable not in sol or observed not in reps[0]:
                continue  # the model does not predict this quantity (or the DEM does not measure it): no row
            dem, err, dem_draws, noise, shifted, offset = dem_of(observed)
            predicted = sol[variable].values[mask]
            value = _evaluate(fn, predicted, dem, err)
            if math.isnan(value):
                continue
            dem_samples = np.array([_evaluate(fn, predicted, d, err) for d in dem_draws])
            if ens is not None and variable in ens:
                solved = ens["solved"].values.astype(bool)
                draws = np.array([_evaluate(fn, ens[variable].values[k][mask], dem, err) if solved[k] else math.nan
                                  for k in range(ens.sizes["draw"])])
                refined = _evaluate(fn, ens[f"{variable}_refined"].values[mask], dem, err)
                n_solved = int(solved.sum())
            else:
                draws, refined, n_solved = np.array([]), math.nan, 0
            offset_samples = (np.array([_evaluate(fn, predicted, d, err) for d in shifted]) if offset.variance > 0
                              else np.array([]))
            one = ScoreSamples(value, dem_samples, draws, refined, noise.dof, points=[f"{int(mask.sum())} z points"],
                               dem_offset=offset_samples, offset_dof=offset.dof)
            pairs = pair_values(reps, observed, fn, mask)
            samples[(case, model, metric)] = one
            rows.append({
                "case": case, "model": model, "metric": metric, "value": value,
                "dem_noise": float(np.mean(pairs)) if pairs else math.nan,
                "n_grid": int(sol.attrs["n_grid"]), "solve_seconds": float(sol.attrs["solve_seconds"]),
                **uncertainty_columns(one), "draws_solved": n_solved, "u_input_method": "draws" if n_solved else "",
                "dem_noise_err": noise_error(pairs), "dem_noise_pairs": len(pairs), "points": one.points[0],
            })
        sol.close()
        if ens is not None:
            ens.close()
    wall_rows, wall_samples = score_wall(case, field_files, model_files, draw_files or {}, settings.dem_resamples,
                                         settings.seed)
    rows.extend(wall_rows)
    samples |= wall_samples
    return pd.DataFrame(rows, columns=COLUMNS), samples


def uncertainty_columns(one: ScoreSamples) -> dict[str, float]:
    """The ``u_*`` columns of a score row (NaN where the score is infinite: a model that predicts
    no creep where the DEM creeps has no spread to speak of)."""
    if not math.isfinite(one.value):
        return {"u_dem": math.nan, "u_input": math.nan, "u_num": math.nan, "u_val": math.nan,
                "dem_dof": one.dem_dof, "draws_finite": one.draws_finite_fraction}
    return {"u_dem": one.u_dem, "u_input": one.u_input, "u_num": one.u_num, "u_val": one.u_val,
            "dem_dof": one.dem_dof, "draws_finite": one.draws_finite_fraction}


def calibration_cases(params: dict) -> set[str]:
    """Cases any of whose runs the calibration read (``params.json`` ``calibration_runs``)."""
    if "calibration_runs" not in params:
        raise ValueError("params.json has no calibration_runs: written by an older calibration, rerun it")
    return {label.split("/")[0] for label in params["calibration_runs"]}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Score the continuum models against the DEM fields.")
    parser.add_argument("--config", type=Path, help="the effective config (seed, scoring section); defaults without it")
    parser.add_argument("--fields", nargs="+", required=True, type=Path, help="fields/CASE/RUN.nc files")
    parser.add_argument("--models", nargs="+", required=True, type=Path, help="models/CASE/MODEL.nc files")
    parser.add_argument("--model-draws", nargs="*", default=[], type=Path,
                        help="model_draws/CASE/MODEL.nc files (the parameter draws and the refined grid)")
    parser.add_argument("--intruder-runs", nargs="*", default=[], type=Path, help="run.json of the intruder runs")
    parser.add_argument("--intruder-models", nargs="*", default=[], type=Path, help="models/intruder/MODEL.nc files")
    parser.add_argument("--params", required=True, type=Path,
                        help="calibration/params.json: its calibration_runs decide each case's role")
    parser.add_argument("--out", required=True, type=Path)
    parser.add_argument("--verdict-out", type=Path, help="validation/verdict.csv (with the next two)")
    parser.add_argument("--differences-out", type=Path, help="validation/model_differences.csv: every pair of models")
    parser.add_argument("--scene-needs-out", type=Path, help="validation/scene_needs.csv")
    parser.add_argument("--force-sweep-out", type=Path, help="validation/force_sweep.csv: the rod's speed against its push")
    parser.add_argument("--intruder-fields-xz", nargs="*", default=[], type=Path, help="fields_xz/intruder/RUN.nc files")
    parser.add_argument("--intruder-model-fields", nargs="*", default=[], type=Path,
                        help="model_fields/intruder/MODEL folders (each model's 2D fields per scene)")
    parser.add_argument("--intruder-fields-out", type=Path, help="validation/intruder_fields.csv")
    parser.add_argument("--intruder-fields", nargs="*", default=[], type=Path,
                        help="fields/intruder/RUN.nc files (the x-averaged bed, scored like a planar case)")
    parser.add_argument("--intruder-bed-out", type=Path, help="validation/intruder_bed.csv")
    parser.add_argument("--wall-out", type=Path, help="validation/wall.csv: the planar cases' top wall, DEM and models")
    args = parser.parse_args(argv)
    rod_cases = sorted({p.parent.name for p in args.intruder_models} | {Path(p).parent.name for p in args.intruder_model_fields})
    if len(rod_cases) > 1:
        # The intruder's scores pool one case's rods by depth and push; two cells' rods would mix.
        parser.error(f"--intruder-models / --intruder-model-fields come from {len(rod_cases)} intruder cases "
                     f"({', '.join(rod_cases)}): the intruder is scored for one case; a study with a second "
                     "(config/studies/rod_cell_length.yaml) compares them with benchmarks/rod_cell_length.py")
    config = load_config(args.config) if args.config else {}
    settings = ScoringSettings.from_config(config)
    frames, samples = [], {}
    draws_of = {(p.parent.name, p.stem): p for p in args.model_draws}
    if args.intruder_models:
        runs = [json.loads(p.read_text()) for p in args.intruder_runs]
        files = {p.stem: p for p in args.intruder_models}
        ens = {m: draws_of[(p.parent.name, m)] for m, p in files.items() if (p.parent.name, m) in draws_of}
        rows, extra = score_intruder(runs, files, ens, settings)
        frames.append(pd.DataFrame(rows, columns=COLUMNS))
        samples |= extra
        rows, extra, sweep = score_force_sweep(runs, files, ens, settings)
        if rows:
            frames.append(pd.DataFrame(rows, columns=COLUMNS))
            samples |= extra
        if args.force_sweep_out is not None:
            atomic.write_csv(sweep, args.force_sweep_out)
            print(sweep.to_string(index=False))
    if args.intruder_model_fields:
        # around the rod (fields_xz) and the bed's x-average (fields), each with its own table
        for dem_files, score, out in ((args.intruder_fields_xz, score_intruder_fields, args.intruder_fields_out),
                                      (args.intruder_fields, score_intruder_bed, args.intruder_bed_out)):
            if dem_files:
                found = score(dem_files, args.intruder_model_fields, settings)
                if found.rows:
                    frames.append(pd.DataFrame(found.rows, columns=COLUMNS))
                    samples |= found.samples
                if out is not None:
                    atomic.write_csv(found.table(COLUMNS), out)
    for out in (args.intruder_fields_out, args.intruder_bed_out):
        if out is not None and not out.exists():
            atomic.write_csv(pd.DataFrame(columns=["case", "model", "metric", "scene"]), out)
    if args.force_sweep_out is not None and not args.force_sweep_out.exists():
        atomic.write_csv(pd.DataFrame(columns=["push_over_yield", "source", "speed", "note"]), args.force_sweep_out)
    params = json.loads(args.params.read_text())
    calibrated = calibration_cases(params)
    walls = []
    for case in sorted({p.parent.name for p in args.models}):
        field_files = sorted(p for p in args.fields if p.parent.name == case)
        model_files = {p.stem: p for p in args.models if p.parent.name == case}
        ens = {m: draws_of[(case, m)] for m in model_files if (case, m) in draws_of}
        frame, extra = score_case(case, field_files, model_files, params, ens, settings)
        frames.append(frame)
        samples |= extra
        walls.append(wall_table(case, ROLES[0] if case in calibrated else ROLES[1], field_files, model_files))
    if args.wall_out is not None:
        atomic.write_csv(pd.concat(walls, ignore_index=True) if walls else pd.DataFrame(columns=["case"]), args.wall_out)
    scores = pd.concat(frames, ignore_index=True)
    scores["role"] = np.where(scores["case"].isin(calibrated), ROLES[0], ROLES[1])
    if args.verdict_out is not None:
        outcome = verdict.judge(scores, samples, settings.confidence, solve_costs=verdict.solve_costs(scores))
        atomic.write_csv(outcome.verdicts, args.verdict_out)
        if args.differences_out is not None:
            atomic.write_csv(outcome.differences, args.differences_out)
        if args.scene_needs_out is not None:
            atomic.write_csv(outcome.scene_needs, args.scene_needs_out)
        print(outcome.verdicts.to_string(index=False))
        print(outcome.scene_needs.to_string(index=False))
    atomic.write_csv(scores, args.out)
    print(scores.to_string(index=False))
    return 0
