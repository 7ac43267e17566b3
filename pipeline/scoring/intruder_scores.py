"""The intruder's score: ``intruder_speed_log_err``, the RMS of log10(U_model / U_dem) over depths.

The DEM speed at a depth is the mean of the **steady** sheared rods at that target depth
(:func:`pipeline.scoring.rod_steadiness.classify`: a travel of at least a grain over the production
and halves that agree; issue 55); a model's speed there is the one it gives at the runs' mean
actual depth. A depth none of whose rods is steady gets no point (the row's ``points`` names the
depths used). The moving rods that are not steady are scored apart, the same way, under
``intruder_speed_log_err_unsteady`` (:data:`METRIC_UNSTEADY`), and listed with the reason in
``validation/rod_steadiness.csv``: labelled, not dropped. A depth the model
refuses (the rod in its flowing layer, a push above its yield force) is not scored, and each row
lists the depths it covers (``points``): two models are compared on the depths both cover
(:mod:`pipeline.scoring.verdict`). A model that predicts the rod at rest where the DEM rod moves
scores ``inf`` there.

Uncertainty (:mod:`pipeline.scoring.uncertainty`): the DEM mean at each depth is resampled from the
replicas' pooled scatter of log10 U (:func:`rod_noise`), the parameter draws come from
``model_draws/intruder/{model}.nc`` and the refined grid from its ``speed_refined``.
"""
from __future__ import annotations

import itertools
import math
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from pipeline.common.config import derived_seed
from pipeline.scoring.metrics import MetricError
from pipeline.scoring.rod_steadiness import is_steady
from pipeline.scoring.uncertainty import ScoreSamples, rod_noise

METRIC = "intruder_speed_log_err"
#: The same score on the moving rods whose speed is not steady (scored apart, labelled so).
METRIC_UNSTEADY = "intruder_speed_log_err_unsteady"


def _moving(runs: list[dict], steady: bool | None) -> list[dict]:
    """The depth sweep's sheared rods that move; only the steady ones (``steady`` True), only the
    others (False) or all (None)."""
    out = [r for r in depth_sweep(runs) if not r["intruder"]["control"] and not r["intruder"]["arrested"]]
    return out if steady is None else [r for r in out if is_steady(r) == steady]


def moving_rod_speeds(runs: list[dict], steady: bool | None = None) -> dict[float, list[float]]:
    """Speeds (m/s) of the sheared rods that move (not arrested), by target depth (in d); with
    ``steady`` True only the steady rods', False only the others' (:func:`pipeline.scoring.
    rod_steadiness.is_steady`), None all."""
    by_depth: dict[float, list[float]] = {}
    for r in _moving(runs, steady):
        by_depth.setdefault(round(r["intruder"]["depth_target_over_d"], 6), []).append(r["intruder"]["speed"])
    return by_depth


def depth_sweep(runs: list[dict]) -> list[dict]:
    """The runs of the depth sweep (the case's one push; not the force sweep's)."""
    return [r for r in runs if not r["intruder"].get("force_sweep")]


def moving_rod_errors(runs: list[dict], steady: bool | None = None) -> dict[float, list[float]]:
    """Stated speed errors (m/s) of the same rods, in the same order."""
    by_depth: dict[float, list[float]] = {}
    for r in _moving(runs, steady):
        by_depth.setdefault(round(r["intruder"]["depth_target_over_d"], 6), []).append(
            float(r["intruder"].get("speed_err", math.nan)))
    return by_depth


def intruder_noise_terms(by_depth: dict[float, list[float]]) -> list[float]:
    """``|log10(U_a / U_b)|`` for each pair of replicas' rods at one depth (moving forward)."""
    return [abs(math.log10(a / b)) for v in by_depth.values() for a, b in itertools.combinations(v, 2) if a > 0 and b > 0]


def _log_term(model_speed: float, dem_speed: float) -> float:
    if not math.isfinite(model_speed):
        return math.nan  # refused
    return math.inf if model_speed <= 0.0 else math.log10(model_speed / dem_speed)


def _match(depths: np.ndarray, depth: float) -> int | None:
    hit = np.nonzero(np.isclose(depths, depth, atol=0.5))[0]
    return int(hit[0]) if hit.size else None


def score_intruder(runs: list[dict], model_files: dict[str, Path], draw_files: dict[str, Path] | None = None,
                   settings: Any = None) -> tuple[list[dict[str, Any]], dict[tuple[str, str, str], ScoreSamples]]:
    """Rows (dicts of the scores.csv columns) and resamples of the intruder metrics, one per model
    and metric: :data:`METRIC` on the steady rods, :data:`METRIC_UNSTEADY` on the moving rods that
    are not steady (module docstring). Raises ``MetricError`` when no rod moves."""
    if not moving_rod_speeds(runs):
        raise MetricError("no intruder run moves: nothing to score")
    sheared = [r for r in depth_sweep(runs) if not r["intruder"]["control"]]
    actual: dict[float, list[float]] = {}
    for r in sheared:
        actual.setdefault(round(r["intruder"]["depth_target_over_d"], 6), []).append(r["intruder"]["depth_over_d"])
    rows, samples = [], {}
    for metric, steady in ((METRIC, True), (METRIC_UNSTEADY, False)):
        by_depth = moving_rod_speeds(runs, steady)
        if by_depth:
            more_rows, more = _score_depths(metric, by_depth, moving_rod_errors(runs, steady), actual, model_files,
                                            draw_files, settings)
            rows += more_rows
            samples |= more
    return rows, samples


def _score_depths(metric: str, by_depth: dict[float, list[float]], errors: dict[float, list[float]],
                  actual: dict[float, list[float]], model_files: dict[str, Path], draw_files: dict[str, Path] | None,
                  settings: Any) -> tuple[list[dict[str, Any]], dict[tuple[str, str, str], ScoreSamples]]:
    """One metric's rows and resamples from the rods' speeds ``by_depth`` (their stated ``errors``),
    the models' speeds at the depths' mean actual depths ``actual``."""
    targets = sorted(by_depth)
    labels = [f"D{t:g}" for t in targets]
    dem_speed = np.array([float(np.mean(by_depth[t])) for t in targets])
    noise = rod_noise(by_depth, errors)
    pairs = intruder_noise_terms(by_depth)
    floor = float(np.sqrt(np.mean(np.square(pairs)))) if pairs else math.nan
    n_resamples = getattr(settings, "dem_resamples", 200)
    # The steady rods' metric keeps the seed it always had; the unsteady rods' draws their own.
    rng = np.random.default_rng(derived_seed(getattr(settings, "seed", 0), "scoring", "intruder",
                                             *(() if metric == METRIC else (metric,))))
    counts = np.array([len(by_depth[t]) for t in targets], dtype=float)
    shift = (noise.log_sd / np.sqrt(counts))[None, :] * rng.standard_normal((n_resamples, len(targets)))
    dem_resampled = dem_speed[None, :] * 10.0 ** np.where(np.isfinite(shift), shift, 0.0)
    rows, samples = [], {}
    for model, path in sorted(model_files.items()):
        with xr.open_dataset(path) as sol:
            index = [_match(sol.depth_over_d.values, float(np.mean(actual[t]))) for t in targets]
            nominal = np.array([float(sol.speed.values[i]) if i is not None else math.nan for i in index])
            n_grid, seconds = int(sol.attrs["n_grid"]), float(sol.attrs["solve_seconds"])
        terms = np.array([_log_term(u, v) for u, v in zip(nominal, dem_speed)])
        covered = np.isfinite(terms) | np.isinf(terms)
        if not covered.any():
            continue
        terms_dem = np.array([[_log_term(u, v) for u, v in zip(nominal, row)] for row in dem_resampled])
        terms_draws, terms_refined = np.full((0, len(targets)), np.nan), np.full(len(targets), np.nan)
        method = ""
        if draw_files and model in draw_files:
            with xr.open_dataset(draw_files[model]) as ens:
                method = str(ens.attrs.get("u_input_method", "draws"))
                # The force sweep's runs share a depth with the depth sweep's: matched out.
                sweep = ens["force_sweep"].values.astype(bool) if "force_sweep" in ens else np.zeros(ens.sizes["run"], bool)
                run_depths = np.where(sweep, np.nan, ens["depth_over_d"].values)
                run_index = [_match(run_depths, float(np.mean(actual[t]))) for t in targets]
                speeds = ens["speed"].values
                terms_draws = np.array([[_log_term(float(speeds[k, j]), v) if j is not None else math.nan
                                         for j, v in zip(run_index, dem_speed)] for k in range(ens.sizes["draw"])])
                terms_refined = np.array([_log_term(float(ens["speed_refined"].values[j]), v) if j is not None else math.nan
                                          for j, v in zip(run_index, dem_speed)])
        full = ScoreSamples(math.nan, np.array([]), np.array([]), math.nan, noise.dof, labels, terms, terms_dem,
                            terms_draws, terms_refined)
        one = full.on_points([lab for lab, c in zip(labels, covered) if c])
        samples[("intruder", model, metric)] = full
        value = one.value
        finite = math.isfinite(value)
        rows.append({"case": "intruder", "model": model, "metric": metric, "value": value, "dem_noise": floor,
                     "n_grid": n_grid, "solve_seconds": seconds,
                     "u_dem": one.u_dem if finite else math.nan, "u_input": one.u_input if finite else math.nan,
                     "u_num": one.u_num if finite else math.nan, "u_val": one.u_val if finite else math.nan,
                     "dem_dof": noise.dof, "draws_solved": int(terms_draws.shape[0]),
                     "draws_finite": one.draws_finite_fraction,
                     "dem_noise_err": (float(np.std(pairs, ddof=1) / math.sqrt(len(pairs))) if len(pairs) >= 2 else math.nan),
                     "dem_noise_pairs": len(pairs), "points": " ".join(one.points), "u_input_method": method})
    return rows, samples
