"""The intruder's speed against its push at one depth: ``validation/force_sweep.csv`` and two scores.

The force sweep's runs (``D<depth>-F<push>-r<k>``, ``force_sweep`` in run.json) push the rod with
fractions of the yield force at its depth. Secondary rheology shows in the shape of U(F): an
activated creep rises faster than linearly (Reddy, Forterre & Pouliquen 2011), NGF's small-force
2D solve is linear in F above the drift of the surrounding creep, the volume-averaged model's rod is
carried by the creep whatever F, local mu(I) slides a layer. Two scores per model:

- ``intruder_force_log_err``: the RMS over the pushes of log10(U_model / U_dem), U_dem the mean of
  the replicas at a push (pushes where that mean is not above twice its error are left out);
- ``intruder_force_slope_err``: ``|s_model - s_dem|``, s the least-squares slope of log10 U against
  F / F_y over the pushes.

The DEM's uncertainty comes from the replicas (the pooled scatter of log10 U at one push, as the
depth sweep's, :func:`pipeline.scoring.uncertainty.rod_noise`), the calibration's from the model
draws. ``validation/force_sweep.csv`` holds per push the DEM speeds and each model's, and per model
the slope, its difference from the DEM's with ``u_val`` and whether the slope excludes the model
(``|s_model - s_dem| > k u_val``, k Student's t at 95 % for the Welch-Satterthwaite degrees of freedom).

Steadiness (issue 55): each push's DEM row says how many of its replicas are steady, unsteady or at
rest (``steady_replicas``, ``unsteady_replicas``, ``at_rest_replicas``; the rule of
:mod:`pipeline.scoring.rod_steadiness`, each rod in ``validation/rod_steadiness.csv``). The sweep's
scores still use every replica: the shape of U(F) needs its pushes, and at the creeping pushes no
rod of the default travels a grain; the labels say which points are not steady states.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

from pipeline.common.config import derived_seed
from pipeline.scoring.intruder_scores import intruder_noise_terms
from pipeline.scoring.rod_steadiness import classify
from pipeline.scoring.uncertainty import ScoreSamples, coverage_factor, rod_noise, welch_satterthwaite

LOG_METRIC = "intruder_force_log_err"
SLOPE_METRIC = "intruder_force_slope_err"


def sweep_speeds(runs: list[dict]) -> dict[float, list[tuple[float, float]]]:
    """(speed, stated error) of the sheared force-sweep rods, by push over the yield force."""
    out: dict[float, list[tuple[float, float]]] = {}
    for r in runs:
        rod = r["intruder"]
        if rod.get("force_sweep") and not rod["control"]:
            out.setdefault(round(float(rod["push_over_yield"]), 6), []).append((float(rod["speed"]), float(rod["speed_err"])))
    return dict(sorted(out.items()))


def sweep_steadiness(runs: list[dict]) -> dict[float, dict[str, int]]:
    """Per push (as :func:`sweep_speeds` keys it), how many sheared force-sweep rods are in each
    class of :func:`pipeline.scoring.rod_steadiness.classify` (``steady``, ``unsteady``,
    ``at_rest``, ``unknown``)."""
    out: dict[float, dict[str, int]] = {}
    for r in runs:
        rod = r["intruder"]
        if rod.get("force_sweep") and not rod["control"]:
            counts = out.setdefault(round(float(rod["push_over_yield"]), 6), {})
            kind = classify(r)["rod_class"]
            counts[kind] = counts.get(kind, 0) + 1
    return out


def slope(push: np.ndarray, log_speed: np.ndarray) -> float:
    """Least-squares slope of log10 U against F / F_y over the finite points (NaN with fewer than 2)."""
    ok = np.isfinite(log_speed)
    return float(np.polyfit(push[ok], log_speed[ok], 1)[0]) if ok.sum() >= 2 else math.nan


def push_index(model_pushes: np.ndarray, push: float, among: np.ndarray | None = None) -> int | None:
    """Index of the first of ``model_pushes`` (F / F_y; only where ``among`` is True) within 1e-6
    of ``push``, or None. A lookup, not an interpolation: the model's pushes are the DEM runs' own
    (run.json's ``push_over_yield``, 0.8999999999999999 where the DEM's groups round it to 0.9), and
    a speed between two pushes is no scene either of them solved."""
    match = np.isclose(np.asarray(model_pushes, dtype=float), push, rtol=0.0, atol=1e-6)
    hits = np.flatnonzero(match if among is None else match & among)
    return int(hits[0]) if hits.size else None


def at_pushes(model_pushes: np.ndarray, model_speeds: np.ndarray, pushes: np.ndarray) -> np.ndarray:
    """The model's speed (m s-1) at each of the DEM's ``pushes`` (:func:`push_index`), NaN where
    the model's file has no scene there."""
    speeds = np.asarray(model_speeds, dtype=float)
    return np.array([speeds[j] if j is not None else np.nan
                     for j in (push_index(model_pushes, p) for p in np.asarray(pushes, dtype=float))])


def _log(u: np.ndarray) -> np.ndarray:
    u = np.asarray(u, dtype=float)
    out = np.full(u.shape, np.nan)
    np.log10(u, out=out, where=u > 0)
    return out


def score_force_sweep(runs: list[dict], model_files: dict[str, Path], draw_files: dict[str, Path] | None,
                      settings: Any) -> tuple[list[dict], dict, pd.DataFrame]:
    """Rows of the two metrics, their resamples, and the ``force_sweep.csv`` table (module docstring)."""
    groups = sweep_speeds(runs)
    if len(groups) < 2:
        return [], {}, pd.DataFrame()
    pushes = np.array(list(groups))
    speeds = {p: np.array([s for s, _ in g]) for p, g in groups.items()}
    mean = np.array([speeds[p].mean() for p in pushes])
    sem = np.array([speeds[p].std(ddof=1) / math.sqrt(speeds[p].size) if speeds[p].size > 1 else groups[p][0][1]
                    for p in pushes])
    resolved = mean > 2.0 * sem
    labels = [f"F{p:g}" for p in pushes]
    noise = rod_noise({p: list(speeds[p]) for p in pushes}, {p: [e for _, e in groups[p]] for p in pushes})
    rng = np.random.default_rng(derived_seed(getattr(settings, "seed", 0), "scoring", "force_sweep"))
    n_resamples = getattr(settings, "dem_resamples", 200)
    counts = np.array([speeds[p].size for p in pushes], dtype=float)
    shift = (noise.log_sd / np.sqrt(counts))[None, :] * rng.standard_normal((n_resamples, pushes.size))
    dem_log = np.where(resolved, _log(mean), np.nan)
    dem_resampled = dem_log[None, :] + np.where(np.isfinite(shift), shift, 0.0)
    dem_slope = slope(pushes, dem_log)
    pair_terms = intruder_noise_terms({p: list(speeds[p]) for p in pushes})
    pair_noise = float(np.sqrt(np.mean(np.square(pair_terms)))) if pair_terms else math.nan
    dem_slopes = np.array([slope(pushes, row) for row in dem_resampled])
    rows, samples, table = [], {}, []
    classes = sweep_steadiness(runs)
    for p, m, e, ok in zip(pushes, mean, sem, resolved):
        kinds = classes.get(p, {})
        table.append({"push_over_yield": p, "source": "dem", "speed": m, "speed_err": e, "replicas": speeds[p].size,
                      "resolved": bool(ok), "steady_replicas": kinds.get("steady", 0),
                      "unsteady_replicas": kinds.get("unsteady", 0), "at_rest_replicas": kinds.get("at_rest", 0)})
    table.append({"source": "dem", "slope": dem_slope, "slope_u": float(np.nanstd(dem_slopes, ddof=1)),
                  "dem_dof": noise.dof})
    for model, path in sorted(model_files.items()):
        with xr.open_dataset(path) as sol:
            if "sweep_speed" not in sol:
                continue
            model_u = at_pushes(sol.push_over_yield.values, sol.sweep_speed.values, pushes)
            n_grid, seconds = int(sol.attrs["n_grid"]), float(sol.attrs["solve_seconds"])
        model_log = _log(model_u)
        draws_log = np.full((0, pushes.size), np.nan)
        refined_log = np.full(pushes.size, np.nan)
        method = ""
        if draw_files and model in draw_files:
            with xr.open_dataset(draw_files[model]) as ens:
                method = str(ens.attrs.get("u_input_method", "draws"))
                sweep = ens["force_sweep"].values.astype(bool)
                first = [push_index(ens["push_over_yield"].values, p, among=sweep) for p in pushes]
                draws_log = np.array([[float(_log(ens["speed"].values[k, j])) if j is not None else np.nan for j in first]
                                      for k in range(ens.sizes["draw"])])
                refined_log = np.array([float(_log(ens["speed_refined"].values[j])) if j is not None else np.nan for j in first])
        keep = resolved & np.isfinite(model_log)
        terms = np.where(resolved, model_log - dem_log, np.nan)
        terms = np.where(resolved & (model_u <= 0), np.inf, terms)  # a rod at rest where the DEM rod moves
        full = ScoreSamples(math.nan, np.array([]), np.array([]), math.nan, noise.dof, labels, terms,
                            model_log[None, :] - dem_resampled, draws_log - dem_log[None, :], refined_log - dem_log)
        covered = [lab for lab, t in zip(labels, terms) if not np.isnan(t)]
        one = full.on_points(covered) if covered else None
        if one is not None:
            samples[("intruder", model, LOG_METRIC)] = full
            rows.append(_row(model, LOG_METRIC, one, n_grid, seconds, noise.dof, " ".join(covered)) | {
                "dem_noise": pair_noise, "dem_noise_pairs": len(pair_terms), "u_input_method": method})
        s_model = slope(pushes[keep], model_log[keep])
        if math.isfinite(s_model):
            draws_s = np.array([slope(pushes[keep], row[keep]) for row in draws_log]) if draws_log.size else np.array([])
            value = abs(s_model - dem_slope)
            one = ScoreSamples(value, np.abs(s_model - dem_slopes), np.abs(draws_s - dem_slope),
                               abs(slope(pushes[keep], refined_log[keep]) - dem_slope), noise.dof,
                               [" ".join(lab for lab, k in zip(labels, keep) if k)])
            samples[("intruder", model, SLOPE_METRIC)] = one
            rows.append(_row(model, SLOPE_METRIC, one, n_grid, seconds, noise.dof, one.points[0])
                        | {"u_input_method": method})
            error = s_model - dem_slope
            u_dem, u_input = float(np.nanstd(dem_slopes, ddof=1)), float(np.nanstd(draws_s, ddof=1)) if draws_s.size > 1 else math.nan
            u_val = math.sqrt(sum(x * x for x in (u_dem, u_input, one.u_num) if math.isfinite(x)))
            dof = welch_satterthwaite([(u_dem, noise.dof), (u_input, float(max(draws_s.size - 1, 1)))])
            k = coverage_factor(dof, getattr(settings, "confidence", 0.95))
            table.append({"source": model, "slope": s_model, "slope_minus_dem": error, "slope_u": u_input,
                          "u_val": u_val, "dof": dof, "excluded_by_slope": bool(abs(error) > k * u_val)})
        for p, u in zip(pushes, model_u):
            table.append({"push_over_yield": p, "source": model, "speed": u})
    return rows, samples, pd.DataFrame(table)


def _row(model: str, metric: str, one: ScoreSamples, n_grid: int, seconds: float, dof: float, points: str) -> dict:
    finite = math.isfinite(one.value)
    return {"case": "intruder", "model": model, "metric": metric, "value": one.value, "dem_noise": math.nan,
            "n_grid": n_grid, "solve_seconds": seconds, "u_dem": one.u_dem if finite else math.nan,
            "u_input": one.u_input if finite else math.nan, "u_num": one.u_num if finite else math.nan,
            "u_val": one.u_val if finite else math.nan, "dem_dof": dof, "draws_solved": int(one.draws.size),
            "draws_finite": one.draws_finite_fraction, "dem_noise_err": math.nan, "dem_noise_pairs": 0, "points": points}
