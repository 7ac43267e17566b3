"""The non-local lengths fitted on the calibration case's replica mean, with errors from its replicas.

NGF's A and the Cosserat and volume-averaged l are each fitted, with the local laws fixed, by
least squares of log10 u_x against the creep of ``calibration.nonlocal_case``: the mean of the
replicas the config names (all of them by default), each replica aligned by its depth below its
own top contact plane, weighted by the mean's errors (:func:`pipeline.common.observables
.replica_mean`: the larger of the combined stated errors and the replicas' scatter over sqrt(n),
floored at 0.1 decade so the shear band's small relative errors do not decide a length the creep
below it measures).

Errors come from the replicas, not from the fit's curvature alone: with n >= 2 replicas each length
is refitted on the mean of every n - 1 of them (leave one replica out), and the jackknife standard
error ``sqrt((n - 1) / n * sum_i (theta_(i) - theta_(.))^2)`` is the realisation scatter a rerun
with other seeds would show. A length's ``error`` is the larger of the jackknife and the curvature
error (with 3 replicas the jackknife has 2 degrees of freedom and may by chance come out small);
``params.json`` records both, the per-replica fits and the leave-one-out values.

The deep creep is not steady over the production: it slows as the bed compacts (docs/dem.md, "The
deep creep ages"), and a length fitted on it depends on the age of the creep it was fitted on.
Where the fields carry the creep of their window's two halves, each length is also fitted on the
replicas' mean creep of the first half and of the second (:func:`age_entry`): half their log
difference, ``error_age_log``, is the length's uncertainty from the age of the creep, which the
draws combine with the replicas' (pipeline.calibration.draws); ``error_with_age`` is ``error`` and
the age error (``value x error_age_log``) in quadrature.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Sequence

import numpy as np
import xarray as xr

import continuum
from continuum import calibration as fits
from continuum.geometry import PlanarShear
from pipeline.calibration.parameter_sets import (
    CalibrationError,
    cosserat_parameters,
    ngf_parameters,
    normal_stress_ratio,
    slip_length,
    volume_averaged_parameters,
)
from pipeline.common.formats import open_fields
from pipeline.common.observables import HALVES, creep_half, creep_speed, has_halves, log_speed_error, replica_mean
from pipeline.common.planar_cell import planar_cell

#: Points faster than this fraction of the wall speed are the shear band in the fit report.
BAND_SPEED = 0.1

#: Factor inside an edge of a model's admissible window of lengths where the window is cut.
EDGE_MARGIN = 1.02

#: The non-local models and the one parameter of each that the creep fixes.
NONLOCAL_PARAMETER = {"ngf": "A", "cosserat": "l", "volume_averaged": "l"}


@dataclass(frozen=True)
class CreepData:
    """A creep profile to fit: heights ``z`` (m, above the model cell's bottom plane), speeds
    ``u`` and their errors ``err`` (m s-1), the cell, and a label of the runs it is the mean of."""

    geometry: PlanarShear
    z: np.ndarray
    u: np.ndarray
    err: np.ndarray
    where: str


@dataclass(frozen=True)
class LengthFit:
    """One fitted non-local parameter: value, curvature error, reduced chi2 and a note."""

    value: float
    error: float
    chi2_reduced: float
    note: str = ""


def _label(ds: xr.Dataset, path: str = "?") -> tuple[str, str]:
    return str(ds.attrs.get("case", "?")), str(ds.attrs.get("run", path))


def mean_creep(sets: Sequence[xr.Dataset], settings: dict[str, Any], ratio: float, slip: float) -> CreepData:
    """The replicas' mean creep profile on their mean cell (:func:`planar_cell`, contact planes).

    Each replica's creep speed (:func:`creep_speed`) is placed by its depth below its own top
    contact plane and interpolated onto the first replica's depths; the mean sits at height
    ``H - depth`` of the mean cell of depth H, its walls slipping with length ``slip`` (m). Kept: points inside the walls, above
    ``min_speed_over_wall_speed`` V and above twice their error.
    """
    geometry, _ = planar_cell(list(sets), ratio, slip_length=slip)
    tops = [float(ds.attrs["z_top_contact_plane"]) for ds in sets]
    depth = tops[0] - sets[0].z.values
    profiles = []
    for ds, top in zip(sets, tops):
        u, err, _ = creep_speed(ds)
        profiles.append((top - ds.z.values, u, err))
    if len(sets) == 1:
        u, err = profiles[0][1], profiles[0][2]
    else:
        u, err = replica_mean(depth, profiles)
    z = geometry.depth - depth
    floor = settings["min_speed_over_wall_speed"] * geometry.wall_speed
    with np.errstate(invalid="ignore"):
        keep = (z > 0.0) & (z < geometry.depth) & np.isfinite(u) & np.isfinite(err) & (u > floor) & (u > 2.0 * err)
    labels = [_label(ds) for ds in sets]
    where = f"{labels[0][0]}/{'+'.join(run for _, run in labels)}"
    if len(sets) > 1:
        where += " (replica mean)"
    return CreepData(geometry, z[keep], u[keep], err[keep], where)


def fit_errors(u: np.ndarray, err: np.ndarray) -> np.ndarray:
    """Errors (m s-1) the non-local fits weight log10 u by: the stated error, floored at
    LOG_SPEED_ERROR_FLOOR decades (pipeline.common.observables)."""
    return log_speed_error(u, err) * u * math.log(10.0)


def admissible_interval(model: str, geometry: PlanarShear, make_params: Any, lo: float, hi: float,
                        n_grid: int = 400, samples: int = 25) -> tuple[float, float]:
    """The widest interval of lengths in [lo, hi] (log-spaced samples) where the model solves.

    The Cosserat model has solutions only in a window of l for a given wall-spin condition: below
    it the couple-stress wall conditions are not met on the grid, above it the shear stress it
    needs exceeds what the top wall admits. Fitting must stay inside that window.
    """
    lengths = np.geomspace(lo, hi, samples)
    ok = []
    for length in lengths:
        try:
            continuum.solve(model, geometry, make_params(float(length)), n_grid=n_grid)
            ok.append(True)
        except continuum.ContinuumError:
            ok.append(False)
    best: tuple[int, int] | None = None
    start = None
    for k, good in enumerate([*ok, False]):
        if good and start is None:
            start = k
        if not good and start is not None:
            if best is None or k - start > best[1] - best[0]:
                best = (start, k)
            start = None
    if best is None:
        raise CalibrationError(f"model {model} has no solution on the calibration geometry for any l in "
                               f"[{lo:.3g}, {hi:.3g}] m")
    low, high = float(lengths[best[0]]), float(lengths[best[1] - 1])
    # The window's edges between the samples, by bisection in log l: a fit that ends on an edge
    # then moves with the geometry and the local laws (the parameter draws), not with the sampling.
    # A margin of EDGE_MARGIN inside an edge: the edge moves with the grid, and a length fitted onto it
    # would not solve on the refined grid that measures the numerical uncertainty (u_num).
    if best[0] > 0:
        low = _edge(model, geometry, make_params, good=low, bad=float(lengths[best[0] - 1]), n_grid=n_grid) * EDGE_MARGIN
    if best[1] < samples:
        high = _edge(model, geometry, make_params, good=high, bad=float(lengths[best[1]]), n_grid=n_grid) / EDGE_MARGIN
    return low, high


def _edge(model: str, geometry: PlanarShear, make_params: Any, good: float, bad: float, n_grid: int,
          steps: int = 8) -> float:
    """The admissible length nearest ``bad`` (to 2^-steps of the log interval) that still solves."""
    for _ in range(steps):
        middle = math.sqrt(good * bad)
        try:
            continuum.solve(model, geometry, make_params(middle), n_grid=n_grid)
            good = middle
        except continuum.ContinuumError:
            bad = middle
    return good


def builder(model: str, base: dict[str, float], settings: dict[str, Any]) -> Any:
    """Parameter value -> the model's parameter dataclass, the local laws ``base`` fixed."""
    if model == "ngf":
        start = ngf_parameters(base, A=0.48)
        return lambda a: replace(start, A=a)
    build = {"cosserat": cosserat_parameters, "volume_averaged": volume_averaged_parameters}[model]
    start = build(base, l=1.0, settings=settings)
    return lambda length: replace(start, l=length)


def fit_length(model: str, base: dict[str, float], data: CreepData, settings: dict[str, Any]) -> LengthFit:
    """Fit the model's non-local parameter to one creep profile (:data:`NONLOCAL_PARAMETER`)."""
    if data.z.size < 4:
        raise CalibrationError(f"{data.where}: only {data.z.size} resolved creep points to fit the non-local lengths")
    make = builder(model, base, settings)
    weights = fit_errors(data.u, data.err)
    name = NONLOCAL_PARAMETER[model]
    if model == "ngf":
        fit = fits.fit_nonlocal_length("ngf", data.geometry, make, data.z, data.u, weights,
                                       initial=0.48, bounds=(0.01, 10.0), name=name, case=data.where)
        value = fit.values[name]
        note = "the fit sits at a bound of [0.01, 10]: the DEM creep is not NGF-shaped here" if (
            value < 0.0101 or value > 9.99) else ""
        return LengthFit(value, fit.errors[name], fit.chi2_reduced, note)
    d = data.geometry.d
    lo, hi = admissible_interval(model, data.geometry, make, 0.05 * d, 20.0 * d)
    fit = fits.fit_nonlocal_length(model, data.geometry, make, data.z, data.u, weights, initial=math.sqrt(lo * hi),
                                   bounds=(lo, hi), name=name, case=data.where)
    value = fit.values[name]
    note = ""
    if lo > 0.05 * d or hi < 20.0 * d:
        note = f"the model solves on this geometry only for l in [{lo / d:.3g}, {hi / d:.3g}] d; fitted there"
    if value > 0.99 * hi or value < 1.01 * lo:
        note += "; the fit sits at a bound of that interval"
    return LengthFit(value, fit.errors[name], fit.chi2_reduced, note.strip("; "))


def region_residuals(model: str, geometry: PlanarShear, parameters: Any, z: np.ndarray, u: np.ndarray,
                     n_grid: int = 400) -> dict[str, float]:
    """RMS of log10(u_model / u_dem) (decades) in the shear band (u > BAND_SPEED V) and in the creep below."""
    sol = continuum.solve(model, geometry, parameters, n_grid=n_grid)
    model_u = np.interp(z, sol.z.values, sol.u_x.values)
    r = np.log10(np.maximum(model_u, np.finfo(float).tiny)) - np.log10(u)
    band = u > BAND_SPEED * geometry.wall_speed
    rms = lambda m: float(np.sqrt(np.mean(r[m] ** 2))) if m.any() else float("nan")  # noqa: E731
    return {"band_rms_decades": rms(band), "creep_rms_decades": rms(~band),
            "band_points": int(band.sum()), "creep_points": int((~band).sum())}


def age_entry(model: str, base: dict[str, float], halves: dict[str, CreepData], settings: dict[str, Any]
              ) -> dict[str, Any]:
    """The length fitted on the replicas' mean creep of each half of the production window
    (``halves``: "first", "second") and ``error_age_log = |ln(second / first)| / 2``: the window's
    value sits between the two, and the creep of no age in reach is the steady one. A half whose fit
    fails is recorded with its reason and no age error."""
    entry: dict[str, Any] = {}
    for half, data in halves.items():
        try:
            entry[f"{half}_half"] = fit_length(model, base, data, settings).value
        except (CalibrationError, continuum.ContinuumError, ValueError, RuntimeError) as exc:
            entry[f"{half}_half_failed"] = str(exc)[:300]
    first, second = entry.get("first_half"), entry.get("second_half")
    if first is not None and second is not None and first > 0 and second > 0:
        entry["error_age_log"] = 0.5 * abs(math.log(second / first))
    return entry


def jackknife_error(leave_one_out: Sequence[float]) -> float:
    """Jackknife standard error from the n leave-one-out estimates (n >= 2)."""
    theta = np.asarray(leave_one_out, dtype=float)
    n = theta.size
    return float(math.sqrt((n - 1) / n * np.sum((theta - theta.mean()) ** 2)))


def calibrate_nonlocal(params: dict[str, Any], paths: Sequence[Path], settings: dict[str, Any]
                       ) -> tuple[dict[str, Any], dict[str, dict[str, float]]]:
    """``params.json``'s ``nonlocal`` entries of the fields files ``paths`` (:func:`fit_replicas`)."""
    sets = [open_fields(p) for p in paths]
    try:
        for ds, p in zip(sets, paths):
            ds.attrs.setdefault("run", Path(p).stem)
        return fit_replicas(params, sets, settings)
    finally:
        for ds in sets:
            ds.close()


def fit_replicas(params: dict[str, Any], sets: Sequence[xr.Dataset], settings: dict[str, Any],
                 models: Sequence[str] = tuple(NONLOCAL_PARAMETER)) -> tuple[dict[str, Any], dict[str, dict[str, float]]]:
    """The non-local entries (module docstring) and each fit's log10 residuals in the shear band and
    in the creep (:func:`region_residuals`) on the replica mean, from the replicas' fields ``sets``."""
    ratio = normal_stress_ratio(params)
    base = {name: entry["value"] for name, entry in (params["local"] | params["critical_state"]).items()}
    runs = [_label(ds)[1] for ds in sets]
    slip = slip_length(params)
    full = mean_creep(sets, settings, ratio, slip)
    single = {run: mean_creep([ds], settings, ratio, slip) for run, ds in zip(runs, sets)}
    left_out = ({run: mean_creep([o for o in sets if o is not ds], settings, ratio, slip) for run, ds in zip(runs, sets)}
                if len(sets) >= 2 else {})
    halves = ({half: mean_creep([creep_half(ds, half) for ds in sets], settings, ratio, slip) for half in HALVES}
              if all(has_halves(ds) for ds in sets) else {})
    out: dict[str, Any] = {}
    residuals: dict[str, dict[str, float]] = {}
    for model in models:
        name = NONLOCAL_PARAMETER[model]
        fit = fit_length(model, base, full, settings)
        per_replica = {run: fit_length(model, base, data, settings).value for run, data in single.items()}
        loo = ({run: fit_length(model, base, data, settings).value for run, data in left_out.items()}
               if len(sets) > 2 else per_replica)  # with two replicas, leaving one out leaves the other
        entry: dict[str, Any] = {"value": fit.value, "fitted_on": full.where,
                                 "error_fit_curvature": fit.error, "chi2_reduced": fit.chi2_reduced,
                                 "per_replica": per_replica, "n_replicas": len(sets)}
        if left_out:
            jack = jackknife_error(list(loo.values()))
            # In log too: the draws multiply the length by a log-normal factor of this width.
            jack_log = jackknife_error([math.log(v) for v in loo.values() if v > 0]) if all(v > 0 for v in loo.values()) else math.nan
            entry |= {"leave_one_out": loo, "error_jackknife": jack, "error_jackknife_log": jack_log,
                      "error": max(jack, fit.error),
                      "error_method": f"the larger of the jackknife over {len(sets)} replicas (leave one out) "
                                      "and the fit's curvature"}
        else:
            entry |= {"error": fit.error,
                      "error_method": "the fit's curvature only: one replica, no realisation scatter measured"}
        if halves:
            entry["age"] = age_entry(model, base, halves, settings)
            if "error_age_log" in entry["age"]:
                # Linearised: the draws multiply by a log-normal factor of the combined log width.
                entry["error_with_age"] = math.hypot(entry["error"], fit.value * entry["age"]["error_age_log"])
        if fit.note:
            entry["note"] = fit.note
        out[model] = {name: entry}
        residuals[model] = region_residuals(model, full.geometry, builder(model, base, settings)(fit.value),
                                            full.z, full.u)
    return out, residuals
