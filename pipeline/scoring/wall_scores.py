"""The top wall's scores of a planar case: its shear stress and its slip (issue 54).

In steady planar shear sigma_xz is uniform, so the top wall's shear stress is every plane's: a
model whose wall stress misses the DEM's misses mu(z) = tau / p(z) by the same fraction at every
depth. Two scalar scores per case and model (rows of ``scores.csv``):

- ``wall_shear_stress_rel_err``: |tau_model / tau_DEM - 1|, tau_DEM the replicas' mean of the top
  wall's |<f_x>| / A over the production (``wall_top_shear_stress`` of the fields files), tau_model
  the model's own uniform shear stress (its ``tau``);
- ``wall_slip_err``: |s_model - s_DEM| / V, s the top wall's speed less the grains' at its contact
  plane (``wall_top_slip``; the model's Navier slip b gammadot(H), 0 without slip).

Uncertainty as every score's (:class:`pipeline.scoring.uncertainty.ScoreSamples`): u_dem from
resamples of the replica mean (Student t with n - 1 degrees of freedom and the replicas' standard
error; with one replica its own stated error), u_input over the parameter draws' own values
(``model_draws/{case}/{model}.nc`` ``wall_shear_stress``, ``top_wall_slip``), u_num from the refined
grid's. ``dem_noise``: the same score between pairs of replicas.

:func:`wall_table` writes ``validation/wall.csv``: per case the DEM's wall (stress, slip, slip
length, effective plane, with the replicas' errors) and each model's signed stress and slip.
"""
from __future__ import annotations

import itertools
import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

from pipeline.common.config import derived_seed
from pipeline.scoring.uncertainty import ScoreSamples

#: metric -> (fields attribute of the DEM, draws variable of the model, solution attribute)
METRICS = {"wall_shear_stress_rel_err": ("wall_top_shear_stress", "wall_shear_stress", "tau"),
           "wall_slip_err": ("wall_top_slip", "top_wall_slip", "top_wall_slip")}

#: The DEM wall's attributes the table carries (replica mean and error).
DEM_WALL = ("wall_top_shear_stress", "wall_top_normal_stress", "wall_top_slip", "wall_top_shear_rate",
            "wall_top_slip_length", "wall_bottom_slip", "wall_friction")


def replica_mean(values: list[float], errors: list[float]) -> tuple[float, float, float]:
    """Mean, its standard error and degrees of freedom: the replicas' scatter with two or more,
    the run's own stated error with one."""
    v, e = np.asarray(values, dtype=float), np.asarray(errors, dtype=float)
    finite = np.isfinite(v)
    v, e = v[finite], e[finite]
    if v.size == 0:
        return math.nan, math.nan, 0.0
    if v.size == 1:
        return float(v[0]), float(e[0]), math.inf
    return float(v.mean()), float(v.std(ddof=1) / math.sqrt(v.size)), float(v.size - 1)


def _score(metric: str, model_value: float, dem_value: float, wall_speed: float) -> float:
    if metric == "wall_shear_stress_rel_err":
        return abs(model_value / dem_value - 1.0)
    return abs(model_value - dem_value) / wall_speed


def dem_wall(field_files: list[Path]) -> tuple[dict[str, list[float]], dict[str, Any]]:
    """Per-replica values of every wall attribute (and its error where one exists) and the shared attributes."""
    per: dict[str, list[float]] = {}
    shared: dict[str, Any] = {}
    for path in field_files:
        with xr.open_dataset(path) as ds:
            for name in DEM_WALL:
                per.setdefault(name, []).append(float(ds.attrs.get(name, math.nan)))
                per.setdefault(f"{name}_err", []).append(float(ds.attrs.get(f"{name}_err", math.nan)))
            shared = {"wall_speed": float(ds.attrs["wall_speed"]), "d": float(ds.attrs["d"])}
    return per, shared


def score_wall(case: str, field_files: list[Path], model_files: dict[str, Path], draw_files: dict[str, Path],
               resamples: int, seed: int) -> tuple[list[dict[str, Any]], dict[tuple[str, str, str], ScoreSamples]]:
    """The wall's score rows of one planar case (``scores.csv`` columns less ``role``) and their resamples."""
    per, shared = dem_wall(field_files)
    if not np.isfinite(per["wall_top_shear_stress"]).any():
        return [], {}  # fields files from before the wall was measured: no wall scores, and no guess
    wall_speed = shared["wall_speed"]
    rows, samples = [], {}
    for metric, (dem_attr, draw_var, sol_attr) in METRICS.items():
        mean, sem, dof = replica_mean(per[dem_attr], per[f"{dem_attr}_err"])
        if not (math.isfinite(mean) and math.isfinite(sem)):
            continue
        rng = np.random.default_rng(derived_seed(seed, "scoring", case, metric))
        t = rng.standard_t(dof, resamples) if math.isfinite(dof) else rng.standard_normal(resamples)
        dem_draws = mean + sem * t
        pairs = [_score(metric, a, b, wall_speed) for a, b in itertools.combinations(per[dem_attr], 2)
                 if math.isfinite(a) and math.isfinite(b)]
        for model, path in sorted(model_files.items()):
            with xr.open_dataset(path) as sol:
                predicted = float(sol.attrs.get(sol_attr, math.nan))
                n_grid, seconds = int(sol.attrs["n_grid"]), float(sol.attrs["solve_seconds"])
            if not math.isfinite(predicted):
                continue
            value = _score(metric, predicted, mean, wall_speed)
            draws, refined, solved = np.array([]), math.nan, 0
            if model in draw_files:
                with xr.open_dataset(draw_files[model]) as ens:
                    if draw_var in ens:
                        ok = ens["solved"].values.astype(bool)
                        draws = np.array([_score(metric, v, mean, wall_speed) if s else math.nan
                                          for v, s in zip(ens[draw_var].values, ok)])
                        refined = _score(metric, float(ens[f"{draw_var}_refined"].values), mean, wall_speed)
                        solved = int(ok.sum())
            one = ScoreSamples(value, np.array([_score(metric, predicted, d, wall_speed) for d in dem_draws]),
                               draws, refined, dof, points=["top wall"])
            samples[(case, model, metric)] = one
            rows.append({"case": case, "model": model, "metric": metric, "value": value,
                         "dem_noise": float(np.mean(pairs)) if pairs else math.nan, "n_grid": n_grid,
                         "solve_seconds": seconds, "u_dem": one.u_dem, "u_input": one.u_input, "u_num": one.u_num,
                         "u_val": one.u_val, "dem_dof": dof, "draws_solved": solved,
                         "u_input_method": "draws" if solved else "",
                         "draws_finite": one.draws_finite_fraction,
                         "dem_noise_err": float(np.std(pairs, ddof=1) / math.sqrt(len(pairs))) if len(pairs) >= 2 else math.nan,
                         "dem_noise_pairs": len(pairs), "points": "top wall"})
    return rows, samples


def wall_table(case: str, role: str, field_files: list[Path], model_files: dict[str, Path]) -> pd.DataFrame:
    """``validation/wall.csv`` rows of one planar case: the DEM's wall (``source`` = dem) and each
    model's (signed: the model less the DEM, relative for the stress, over V for the slip)."""
    per, shared = dem_wall(field_files)
    d, wall_speed = shared["d"], shared["wall_speed"]
    dem = {name: replica_mean(per[name], per[f"{name}_err"])[:2] for name in DEM_WALL}
    row: dict[str, Any] = {"case": case, "role": role, "source": "dem", "replicas": len(field_files)}
    for name, (mean, err) in dem.items():
        row[name] = mean
        row[f"{name}_err"] = err
    row["wall_top_slip_over_v"] = dem["wall_top_slip"][0] / wall_speed
    row["wall_top_slip_length_over_d"] = dem["wall_top_slip_length"][0] / d
    rows = [row]
    tau_dem, tau_err = dem["wall_top_shear_stress"]
    for model, path in sorted(model_files.items()):
        with xr.open_dataset(path) as sol:
            tau = float(sol.attrs.get("tau", math.nan))
            slip = float(sol.attrs.get("top_wall_slip", math.nan))
            b = float(sol.attrs.get("slip_length", math.nan))
        rows.append({"case": case, "role": role, "source": model, "wall_top_shear_stress": tau,
                     "wall_top_slip": slip, "wall_top_slip_over_v": slip / wall_speed,
                     "wall_top_slip_length": b, "wall_top_slip_length_over_d": b / d,
                     "stress_minus_dem_rel": tau / tau_dem - 1.0,
                     "stress_minus_dem_over_dem_err": (tau - tau_dem) / tau_err if tau_err > 0 else math.nan,
                     "slip_minus_dem_over_v": (slip - dem["wall_top_slip"][0]) / wall_speed})
    return pd.DataFrame(rows)
