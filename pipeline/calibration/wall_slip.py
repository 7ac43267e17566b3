"""The DEM wall's slip law for the models: ``params.json``'s ``wall`` entry.

The rough DEM walls do not carry the bed's grains at their own speed: the grains at the contact
planes lag (``wall_*_slip`` of the fields files, :mod:`pipeline.coarse_graining.wall`). The models
take a Navier slip length b (``continuum.geometry.PlanarShear.slip_length``): the grains at a
wall move relative to it by b times the shear rate there.

b is calibrated on the calibration set only (``calibration.wall_slip``):

- ``rheometer`` (the default): each rheometer run's two walls, in homogeneous shear, give
  b = (s_top + s_bottom) / (2 gammadot), gammadot the bulk shear rate, s the slips (the bulk's
  straight line extrapolated to the contact planes). The runs used are those that flow
  homogeneously: I >= :data:`MIN_INERTIAL` (below it the quasi-static layer's time-averaged
  profile is intermittent, and its extrapolation to the walls no Navier slip: on the default of
  2026-12-06 b ran from -1.0 to 3.7 d at I = 0.005) and a bulk I spread under
  :data:`MAX_SPREAD` of I. Their b are averaged with equal weights, the error from their scatter
  (standard error): the runs' stated errors are 10-30 times smaller than the replicas'
  differences (the packing's realisation, not the time average, sets b), which the stated-error
  chi2 reports. Whether b depends on I is reported (a line in log10 I, its slope over its
  error), not modelled.
- ``calibration_case``: the top wall's b of the calibration case's replicas (``wall_top_slip_length``),
  their mean, the error from their scatter.
- ``none``: no slip (b = 0), the models' walls as before issue 54.

Both measurements are written whichever is chosen, with the z of their difference: whether the
rheometer's b carries to the gravity bed's wall is a result.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from pipeline.calibration.parameter_sets import CalibrationError
from pipeline.common.formats import open_fields

SOURCES = ("rheometer", "calibration_case", "none")

#: The smallest inertial number of a rheometer run whose walls calibrate b (module doc).
MIN_INERTIAL = 0.05
#: The largest bulk spread of I, over I, of a run that shears homogeneously.
MAX_SPREAD = 0.25

_NEEDED = ("wall_top_slip", "wall_top_slip_err", "wall_bottom_slip", "wall_bottom_slip_err")


def _attrs(path: Path, names: Sequence[str]) -> dict[str, float]:
    with open_fields(path) as ds:
        missing = [n for n in names if n not in ds.attrs]
        if missing:
            raise CalibrationError(f"{path}: no attribute {missing[0]} (the wall's slip, written by the "
                                   "coarse-graining since issue 54): recompute the fields file")
        return {n: float(ds.attrs[n]) for n in names} | {"d": float(ds.attrs["d"]), "run": str(ds.attrs.get("run", path))}


def rheometer_state(path: Path, state: dict[str, Any]) -> dict[str, float]:
    """b (m) of one rheometer run from both walls' slips and its bulk shear rate (``state``, the
    calibration's bulk state of the same file), with its error."""
    a = _attrs(path, _NEEDED)
    rate, rate_err = float(state["shear_rate"]), float(state["shear_rate_err"])
    slip = 0.5 * (a["wall_top_slip"] + a["wall_bottom_slip"])
    slip_err = 0.5 * math.hypot(a["wall_top_slip_err"], a["wall_bottom_slip_err"])
    b = slip / rate
    return {"run": a["run"], "I": float(state["I"]), "I_spread_over_I": float(state.get("I_spread", math.nan)) / float(state["I"]),
            "slip_top": a["wall_top_slip"], "slip_bottom": a["wall_bottom_slip"],
            "shear_rate": rate, "slip_length": b,
            "slip_length_err": abs(b) * math.hypot(slip_err / slip if slip else math.inf, rate_err / rate),
            "slip_length_over_d": b / a["d"]}


def calibrates_slip(state: dict[str, float]) -> bool:
    """Whether a rheometer run's :func:`rheometer_state` enters the slip length's mean: a finite b
    with an error, and homogeneous shear (I >= :data:`MIN_INERTIAL`, bulk I spread under
    :data:`MAX_SPREAD` I)."""
    return bool(math.isfinite(state["slip_length"]) and state["slip_length_err"] > 0
                and state["I"] >= MIN_INERTIAL and state["I_spread_over_I"] <= MAX_SPREAD)


def scatter_mean(values: np.ndarray, errors: np.ndarray) -> dict[str, float]:
    """Equal-weight mean, its standard error from the values' scatter, and the reduced chi2 of the
    values about it with their stated errors (how far the scatter exceeds them)."""
    if values.size < 2:
        raise CalibrationError(f"the wall's slip length needs two or more rheometer runs that flow homogeneously "
                               f"(I >= {MIN_INERTIAL}, bulk I spread under {MAX_SPREAD} I), got {values.size}")
    mean = float(values.mean())
    dof = values.size - 1
    chi2 = float(np.sum(((values - mean) / errors) ** 2) / dof)
    return {"value": mean, "error": float(values.std(ddof=1) / math.sqrt(values.size)), "chi2_reduced": chi2,
            "dof": dof, "n_runs": int(values.size)}


def inertial_trend(states: list[dict[str, float]]) -> dict[str, float]:
    """Slope of b against log10 I (weighted line) over its error: whether b depends on the state."""
    x = np.log10([s["I"] for s in states])
    y = np.array([s["slip_length"] for s in states])
    w = 1.0 / np.array([s["slip_length_err"] for s in states]) ** 2
    if np.unique(np.round(x, 3)).size < 3:
        return {"slope_per_decade": math.nan, "slope_err": math.nan, "z": math.nan}
    design = np.column_stack([np.ones_like(x), x])
    cov = np.linalg.inv(design.T @ (design * w[:, None]))
    coef = cov @ (design.T @ (w * y))
    chi2 = float(np.sum(w * (y - design @ coef) ** 2) / max(1, x.size - 2))
    err = math.sqrt(cov[1, 1] * max(1.0, chi2))  # the stated errors are short of the scatter: scaled to it
    return {"slope_per_decade": float(coef[1]), "slope_err": err, "z": float(coef[1] / err)}


def calibration_case_slip(paths: Sequence[Path]) -> dict[str, Any]:
    """The calibration case's top-wall b: the replicas' mean and its error from their scatter."""
    rows = [_attrs(Path(p), ("wall_top_slip_length", "wall_top_slip", "wall_top_shear_stress")) for p in paths]
    b = np.array([r["wall_top_slip_length"] for r in rows])
    good = b[np.isfinite(b)]
    out: dict[str, Any] = {"per_replica": {r["run"]: r["wall_top_slip_length"] for r in rows},
                           "n_replicas": int(good.size)}
    if good.size >= 2:
        out |= {"value": float(good.mean()), "error": float(good.std(ddof=1) / math.sqrt(good.size)),
                "error_method": f"standard error over {good.size} replicas"}
    elif good.size == 1:
        out |= {"value": float(good[0]), "error": math.nan, "error_method": "one replica: no scatter measured"}
    return out


def calibrate_wall(source: str, rheometer_files: Sequence[Path], states: list[dict[str, Any]],
                   nonlocal_files: Sequence[Path]) -> dict[str, Any]:
    """``params.json``'s ``wall`` entry (module doc): the chosen ``slip_length`` (m) with its error
    and provenance, and both measurements."""
    if source not in SOURCES:
        raise CalibrationError(f"calibration.wall_slip = {source!r}: choose one of {', '.join(SOURCES)}")
    per_state = [rheometer_state(Path(f), s) for f, s in zip(rheometer_files, states)]
    for state in per_state:
        state["used"] = calibrates_slip(state)
    good = [s for s in per_state if s["used"]]
    try:
        rheometer = scatter_mean(np.array([s["slip_length"] for s in good]), np.array([s["slip_length_err"] for s in good]))
    except CalibrationError as exc:
        if source == "rheometer":
            raise
        # another source was chosen: the rheometer's measurement is recorded as not made, with why
        rheometer = {"value": math.nan, "error": math.nan, "chi2_reduced": math.nan, "dof": len(good) - 1,
                     "n_runs": len(good), "not_measured": str(exc)}
    rheometer |= {"states": per_state, "inertial_trend": inertial_trend(good),
                  "method": (f"equal-weight mean of (s_top + s_bottom) / (2 gammadot_bulk) over the rheometer runs with "
                             f"I >= {MIN_INERTIAL} and a bulk I spread under {MAX_SPREAD} I; error from their scatter")}
    case = calibration_case_slip(nonlocal_files) if nonlocal_files else {}
    entry: dict[str, Any] = {"source": source, "rheometer": rheometer, "calibration_case": case}
    if case.get("error", math.nan) > 0:
        entry["z_calibration_case_minus_rheometer"] = (case["value"] - rheometer["value"]) / math.hypot(
            case["error"], rheometer["error"])
    if source == "rheometer":
        value, error, fitted_on = rheometer["value"], rheometer["error"], "rheometer"
    elif source == "calibration_case":
        if not math.isfinite(case.get("error", math.nan)):
            raise CalibrationError("calibration.wall_slip = calibration_case needs two or more replicas of "
                                   "the calibration case with a resolved top-wall shear rate")
        value, error, fitted_on = case["value"], case["error"], "calibration_case"
    else:
        value, error, fitted_on = 0.0, 0.0, "assumed"
    if value < 0.0:
        raise CalibrationError(f"the calibrated wall slip length is negative ({value:.3g} m from {fitted_on}): "
                               "the bed outruns its walls, which a Navier slip cannot describe")
    d = float(states[0]["d"])
    entry["slip_length"] = {"value": float(value), "error": float(error), "fitted_on": fitted_on,
                            "value_over_d": float(value) / d}
    return entry

