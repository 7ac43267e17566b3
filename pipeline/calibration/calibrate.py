"""Calibrate the continuum models from DEM fields: ``calibration/params.json``.

Local laws come from the rheometer only: each rheometer run gives one homogeneous state (bulk
averages at least ``bulk_margin_over_d`` d from each wall) of I, mu, nu and p with standard
errors; mu(I), nu(I) and the critical-state family are fitted to those states
(:mod:`continuum.calibration`). The non-local parameters (NGF A, the Cosserat and the
volume-averaged lengths l) are fitted, with the local laws fixed, on the replica mean of the
calibration case the config names (``calibration.nonlocal_case`` / ``nonlocal_runs``), by least
squares of log10 u_x in its creeping zone, with errors from its replicas
(:mod:`pipeline.calibration.nonlocal_fit`); ``params.json`` records where each value was fitted so
the report can say which scores are not independent of the calibration.

Usage: ``python -m pipeline.calibration.calibrate --config CONFIG --rheometer F1.nc F2.nc ... --nonlocal R1.nc R2.nc ... --out params.json``
"""
from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from continuum import calibration as fits
from pipeline.calibration.nonlocal_fit import calibrate_nonlocal
from pipeline.calibration.wall_slip import calibrate_wall
from pipeline.calibration.parameter_sets import CalibrationError, calibration_settings
from pipeline.common.config import calibration_runs, load_config, validation_cases
from pipeline.common.formats import open_fields
from pipeline.common.provenance import provenance
from pipeline.common.statistics import pooled_chi2

#: Slope d nu_cs / d ln p used when the DEM resolves none (rigid grains): the order of the
#: relative grain compliance (mean overlap / d ~ 1e-3).
KAPPA_FLOOR = 1e-3


def bulk_state(path: Path, margin_over_d: float) -> dict[str, float]:
    """Bulk averages (and their standard errors) of one rheometer fields file.

    The bulk is the part of the profile at least ``margin_over_d`` d from both walls. The error of
    a bulk average is that of the bulk mean the coarse-graining block-averaged itself
    (``bulk_<name>_err``, pipeline.coarse_graining.fields.bulk_means, over the same margin): the
    points' correlations counted as they are. The mean of the pointwise errors, used before,
    counted them as total and overstated the errors (the mu(I) fit's reduced chi-square was 0.09).
    Files without the bulk attributes fall back to it, and say so in ``error_source``.
    """
    ds = open_fields(path)
    d = float(ds.attrs["d"])
    z0, z1 = float(ds.attrs["z_bottom_wall"]), float(ds.attrs["z_top_wall"])
    bulk = ds.where((ds.z >= z0 + margin_over_d * d) & (ds.z <= z1 - margin_over_d * d), drop=True)
    if bulk.sizes["z"] < 3:
        raise CalibrationError(
            f"{path}: fewer than 3 profile points lie {margin_over_d:g} d from both walls "
            f"(walls at {z0:.4g} and {z1:.4g} m, d = {d:.3g} m): the rheometer cell is too thin"
        )
    out: dict[str, float] = {"file": str(path), "wall_pressure": float(ds.attrs["wall_pressure"]), "d": d}
    p = bulk["p"].values
    for name in ("sigma_xx", "sigma_yy", "sigma_zz"):
        ratio = bulk[name].values / p
        if not np.all(np.isfinite(ratio)):
            raise CalibrationError(f"{path}: non-finite {name} / p in the bulk")
        # sigma_aa and p share their fluctuations; the error of sigma_aa over p bounds the ratio's.
        out[f"{name}_over_p"] = float(ratio.mean())
        out[f"{name}_over_p_err"] = float((bulk[f"{name}_err"].values / p).mean())
    own = "bulk_mu_err" in ds.attrs
    if own and not math.isclose(float(ds.attrs["bulk_margin_over_d"]), margin_over_d):
        raise CalibrationError(
            f"{path}: its bulk means were taken {float(ds.attrs['bulk_margin_over_d']):g} d from the walls "
            f"(coarse_grain.bulk_margin_over_d), the calibration asks for {margin_over_d:g} d "
            "(calibration.bulk_margin_over_d): set the two alike")
    out["error_source"] = "bulk mean block-averaged" if own else "mean of pointwise errors (no bulk attributes)"
    for name in ("I", "mu", "nu", "p", "shear_rate", "fluidity", "granular_temperature"):
        values = bulk[name].values
        if not np.all(np.isfinite(values)):
            raise CalibrationError(f"{path}: non-finite {name} in the bulk")
        out[name] = float(values.mean())
        out[f"{name}_err"] = float(ds.attrs[f"bulk_{name}_err"]) if own else float(bulk[f"{name}_err"].values.mean())
    # Inhomogeneity of the bulk (shear banding) shows as a spread larger than the errors.
    out["mu_spread"] = float(bulk["mu"].values.std())
    out["I_spread"] = float(bulk["I"].values.std())
    ds.close()
    return out


def scale_state_errors(states: list[dict[str, Any]], runs: list[str]) -> dict[str, dict[str, float]]:
    """Hold the states' stated errors of mu, nu and I to their replicas' scatter: with two or more
    replicas of a state (run ids that differ in their ``-r<k>`` only), the pooled replica chi2
    (:func:`pipeline.common.statistics.pooled_chi2`); where it departs from 1 by more than twice its
    error, every state's error of that quantity is multiplied by ``sqrt(chi2)`` (in place). Returns
    the check per quantity (``error_scale`` 1 where the errors held, NaN without replicas)."""
    groups: dict[str, list[int]] = {}
    for k, run in enumerate(runs):
        groups.setdefault(run.rsplit("-r", 1)[0], []).append(k)
    out = {}
    for name in ("mu", "nu", "I"):
        check = pooled_chi2((np.array([states[k][name] for k in ks]), np.array([states[k][f"{name}_err"] for k in ks]))
                            for ks in groups.values())
        scale = check["error_scale"]
        if math.isfinite(scale) and scale != 1.0:
            for state in states:
                state[f"{name}_err_stated"] = state[f"{name}_err"]
                state[f"{name}_err"] = state[f"{name}_err"] * scale
        out[name] = {k: check[k] for k in ("chi2", "chi2_err", "dof", "error_scale")}
    return out


def _entry(value: float, error: float, fitted_on: str, note: str = "") -> dict[str, Any]:
    entry: dict[str, Any] = {"value": float(value), "error": float(error), "fitted_on": fitted_on}
    if note:
        entry["note"] = note
    return entry


def rheometer_laws(rheometer_files: list[Path], margin_over_d: float
                   ) -> tuple[list[dict[str, Any]], dict[str, dict[str, float]], fits.FitResult, fits.FitResult]:
    """The local laws mu(I) and nu(I) fitted on rheometer fields files: their bulk states (errors
    held to the replicas' scatter, :func:`scale_state_errors`), the error check, and the two fits
    (values, errors, covariances). ``margin_over_d``: the bulk's distance from the walls (in d)."""
    states = [bulk_state(Path(f), margin_over_d) for f in rheometer_files]
    error_scales = scale_state_errors(states, [run_label(Path(f))[1] for f in rheometer_files])
    if len(states) < 3:
        raise CalibrationError(f"mu(I) has 3 parameters: need at least 3 rheometer states, got {len(states)}")
    inertial = np.array([s["I"] for s in states])
    if len({round(math.log10(i), 2) for i in inertial}) < 3:
        raise CalibrationError(f"mu(I) needs 3 distinct inertial numbers, got I = {inertial.tolist()}")
    mu_fit = fits.fit_mu_i(inertial, np.array([s["mu"] for s in states]), np.array([s["mu_err"] for s in states]))
    nu_fit = fits.fit_solid_fraction(inertial, np.array([s["nu"] for s in states]), np.array([s["nu_err"] for s in states]))
    return states, error_scales, mu_fit, nu_fit


def calibrate(config: dict[str, Any], rheometer_files: list[Path], nonlocal_files: list[Path] | None = None) -> dict[str, Any]:
    """All parameters with errors and provenance (the content of ``params.json``); the non-local
    lengths from the replica mean of ``nonlocal_files`` (:mod:`pipeline.calibration.nonlocal_fit`)."""
    settings = calibration_settings(config)
    nonlocal_files = [Path(f) for f in (nonlocal_files or [])]
    read = [run_label(Path(f)) for f in [*rheometer_files, *nonlocal_files]]
    check_calibration_set(config, read)
    states, error_scales, mu_fit, nu_fit = rheometer_laws(rheometer_files, settings["bulk_margin_over_d"])
    arr = {k: np.array([s[k] for s in states]) for k in ("I", "I_err", "mu", "mu_err", "nu", "nu_err", "p")}
    cs_fit = fits.fit_critical_state(arr["I"], arr["mu"], arr["mu_err"], arr["p"], arr["nu"], arr["nu_err"])
    on_rheo = "rheometer"
    cs_notes = {}
    if not cs_fit.values["kappa"] > 0.0:
        # Rigid grains: nu_cs hardly depends on p, and the fitted slope came out <= 0 within its
        # error. The rate-independent models need p_c(nu) increasing, so kappa takes the floor
        # (the grains' compliance scale) and the line passes through nu(I -> 0).
        note = (f"fitted kappa {cs_fit.values['kappa']:.3g} +- {cs_fit.errors['kappa']:.2g} is not positive: "
                f"the DEM resolves no pressure dependence of nu at the critical state; kappa set to {KAPPA_FLOOR:g}, "
                "nu_ref to nu_c of the nu(I) fit")
        cs_fit.values["kappa"], cs_fit.values["nu_ref"] = KAPPA_FLOOR, nu_fit.values["nu_c"]
        cs_fit.errors["nu_ref"] = nu_fit.errors["nu_c"]
        cs_notes = {"kappa": note, "nu_ref": note}
    params: dict[str, Any] = {
        "local": {name: _entry(mu_fit.values[name], mu_fit.errors[name], on_rheo) for name in mu_fit.names}
        | {name: _entry(nu_fit.values[name], nu_fit.errors[name], on_rheo) for name in nu_fit.names},
        "critical_state": {
            name: _entry(cs_fit.values[name], cs_fit.errors[name], on_rheo, cs_notes.get(name, ""))
            for name in cs_fit.names
        }
        | {"n": _entry(settings["critical_state_n"], 0.0, "assumed", "steady planar flow does not fix the yield exponent")},
        "fit_quality": {
            "mu_i_chi2_reduced": mu_fit.chi2_reduced,
            "nu_i_chi2_reduced": nu_fit.chi2_reduced,
            "critical_state_chi2_reduced": cs_fit.chi2_reduced,
        },
        "covariance": {
            "mu_i": {"names": list(mu_fit.names), "matrix": np.asarray(mu_fit.covariance).tolist()},
            "nu_i": {"names": list(nu_fit.names), "matrix": np.asarray(nu_fit.covariance).tolist()},
            # sin_phi is mu_s of the mu(I) fit (its variance here; drawn with mu_s); p_ref is fixed.
            "critical_state": {"names": list(cs_fit.names), "matrix": np.asarray(cs_fit.covariance).tolist(),
                               "kappa_floored": bool(cs_notes)},
        },
        "normal_stresses": normal_stress_entries(states),
        "microscopic_fluidity": microscopic_fluidity_fit(states, float(states[0]["d"])),
        "rheometer_states": states,
        "rheometer_error_scale": error_scales,
        # The exact runs this calibration read: every score on a case with one of them is a fit.
        "calibration_runs": [f"{case}/{run}" for case, run in read],
        "nonlocal": {},
    }
    # Before the non-local fit: its cells have the models' walls.
    params["wall"] = calibrate_wall(settings["wall_slip"], rheometer_files, states, nonlocal_files)
    if nonlocal_files:
        params["normal_stresses"]["models_sigma_zz_over_p"] = planar_bed_ratio(nonlocal_files, states)
    else:
        params["normal_stresses"]["models_sigma_zz_over_p"] = params["normal_stresses"]["sigma_zz_over_p"] | {
            "source": "rheometer (no planar calibration run)"}
    if nonlocal_files:
        params["nonlocal"], params["nonlocal_fit_residuals"] = calibrate_nonlocal(params, nonlocal_files, settings)
    with open_fields(rheometer_files[0]) as first:
        d, rho_s = float(first.attrs["d"]), float(first.attrs["rho_s"])
    params["d"] = d
    params["rho_s"] = rho_s
    params["provenance"] = provenance(config)
    return params


def planar_bed_ratio(paths: list[Path], states: list[dict[str, Any]], margin_over_d: float = 1.0) -> dict[str, Any]:
    """sigma_zz / p the models use: measured in the calibration case's bed itself, where the bed is
    in the rheometer's range of inertial number (I at or above the slowest state's), at least
    ``margin_over_d`` d of bed from both contact planes; the mean over the replicas, its error their
    scatter over sqrt(n) (or the points' where there is one replica). In the default beds this is
    the top 4-5 d, where sigma_zz / p is 1.04-1.10 against the rheometer bulk's 1.03 (the bed's
    normal-stress differences near the moving wall are not the homogeneous shear's); deeper, in the
    creep, it is 1.11-1.16, outside any calibrated state (docs/validation.md)."""
    slowest = min(float(s["I"]) for s in states)
    values, spreads, points = [], [], 0
    for path in paths:
        with open_fields(path) as ds:
            d = float(ds.attrs["d"])
            z = ds.z.values
            inside = ((z >= float(ds.attrs["z_bottom_contact_plane"]) + margin_over_d * d)
                      & (z <= float(ds.attrs["z_top_contact_plane"]) - margin_over_d * d) & (ds["I"].values >= slowest))
            if inside.sum() < 2:
                continue
            ratio = ds["sigma_zz"].values[inside] / ds["p"].values[inside]
            values.append(float(ratio.mean()))
            spreads.append(float(ratio.std(ddof=1) / math.sqrt(inside.sum())))
            points += int(inside.sum())
    if not values:
        raise CalibrationError(f"{', '.join(map(str, paths))}: no point of the calibration case's bed reaches the "
                               f"rheometer's slowest inertial number {slowest:.3g}: no sigma_zz / p to give the models")
    error = float(np.std(values, ddof=1) / math.sqrt(len(values))) if len(values) > 1 else spreads[0]
    return _entry(float(np.mean(values)), error, "planar bed of " + ", ".join(f"{run_label(p)[0]}/{run_label(p)[1]}" for p in paths),
                  f"where I >= {slowest:.3g} (the slowest rheometer state's), {points} points over {len(values)} replicas; "
                  "the models' p is sigma_zz over it") | {"per_replica": values}


def normal_stress_entries(states: list[dict[str, Any]]) -> dict[str, Any]:
    """sigma_aa / p over the rheometer states: the error-weighted mean of each, its error (the
    larger of the weighted-mean error and the states' scatter over sqrt(n), since the ratio may
    vary with I), and the normal-stress differences N1 = sigma_xx - sigma_zz, N2 = sigma_zz -
    sigma_yy over p that the 1D models leave out."""
    out: dict[str, Any] = {}
    for name in ("sigma_xx", "sigma_yy", "sigma_zz"):
        v = np.array([s[f"{name}_over_p"] for s in states])
        e = np.array([s[f"{name}_over_p_err"] for s in states])
        w = 1.0 / np.maximum(e, 1e-12) ** 2
        mean = float(np.sum(w * v) / np.sum(w))
        err = max(float(1.0 / math.sqrt(np.sum(w))), float(v.std(ddof=1) / math.sqrt(v.size)) if v.size > 1 else 0.0)
        out[f"{name}_over_p"] = _entry(mean, err, "rheometer", f"states span {v.min():.4f} to {v.max():.4f}")
    xx, yy, zz = (out[f"sigma_{a}_over_p"]["value"] for a in ("xx", "yy", "zz"))
    out["N1_over_p"] = _entry(xx - zz, math.hypot(out["sigma_xx_over_p"]["error"], out["sigma_zz_over_p"]["error"]),
                              "rheometer", "(sigma_xx - sigma_zz) / p; left out of the 1D models")
    out["N2_over_p"] = _entry(zz - yy, math.hypot(out["sigma_zz_over_p"]["error"], out["sigma_yy_over_p"]["error"]),
                              "rheometer", "(sigma_zz - sigma_yy) / p; left out of the 1D models")
    return out


def microscopic_fluidity_fit(states: list[dict[str, Any]], d: float) -> dict[str, Any]:
    """F(nu) of the microscopic fluidity g = (delta_v / d) F(nu) (Zhang & Kamrin 2017), fitted on the
    rheometer, where g = shear_rate / mu is known: delta_v = sqrt(granular temperature), and
    ln F = c0 + c1 nu (an exponential in nu, the form chosen here: F must fall steeply as nu rises
    towards jamming; the data decide c0, c1), by error-weighted least squares in ln F."""
    g = np.array([s["fluidity"] for s in states])
    g_err = np.array([s["fluidity_err"] for s in states])
    temp = np.array([s["granular_temperature"] for s in states])
    temp_err = np.array([s["granular_temperature_err"] for s in states])
    nu = np.array([s["nu"] for s in states])
    f = g * d / np.sqrt(temp)
    sigma = np.hypot(g_err / g, 0.5 * temp_err / temp)
    (c1, c0), cov = np.polyfit(nu, np.log(f), 1, w=1.0 / sigma, cov="unscaled")
    resid = (np.log(f) - (c0 + c1 * nu)) / sigma
    chi2 = float(np.sum(resid**2) / max(len(f) - 2, 1))
    scale = math.sqrt(max(chi2, 1.0))
    return {"form": "g = sqrt(granular_temperature) / d * exp(c0 + c1 nu)",
            "c0": _entry(c0, math.sqrt(cov[1, 1]) * scale, "rheometer"),
            "c1": _entry(c1, math.sqrt(cov[0, 0]) * scale, "rheometer"),
            "chi2_reduced": chi2, "nu_range": [float(nu.min()), float(nu.max())]}


def microscopic_fluidity(params: dict[str, Any], nu: np.ndarray, temperature: np.ndarray,
                         temperature_err: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The microscopic fluidity (s-1) and its error from the fields' nu and granular temperature.

    NaN where nu lies outside the rheometer states' range (``nu_range`` of the fit): F(nu) is
    not measured there, and the creeping zone's nu (0.60-0.62 in the default beds, above the
    slowest state's 0.594) is exactly where an extrapolated F would decide the comparison.
    """
    fit = params["microscopic_fluidity"]
    d = float(params["d"])
    c0, c1 = fit["c0"]["value"], fit["c1"]["value"]
    lo, hi = fit["nu_range"]
    nu = np.asarray(nu, dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        g = np.sqrt(np.maximum(temperature, 0.0)) / d * np.exp(c0 + c1 * nu)
        err = g * 0.5 * temperature_err / temperature
    calibrated = (nu >= lo) & (nu <= hi)
    return np.where(calibrated, g, np.nan), np.where(calibrated, err, np.nan)


def run_label(path: Path) -> tuple[str, str]:
    """(case, run) of a fields file, from its attributes."""
    with open_fields(path) as ds:
        case, run = str(ds.attrs.get("case", "")), str(ds.attrs.get("run", ""))
    if not case or not run:
        raise CalibrationError(f"{path}: fields file names no case/run (attributes 'case' and 'run')")
    return case, run


def check_calibration_set(config: dict[str, Any], read: list[tuple[str, str]]) -> None:
    """Refuse any run outside the config's calibration set (a validation case must never be fitted on)."""
    allowed = set(calibration_runs(config))
    stray = [f"{c}/{r}" for c, r in read if (c, r) not in allowed]
    if stray:
        raise CalibrationError(
            f"{', '.join(stray)}: not in the calibration set of the config (the rheometer runs and "
            f"calibration.nonlocal_case/nonlocal_run); validation cases ({', '.join(validation_cases(config)) or 'none'}) "
            "are never read by the calibration")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Fit the continuum parameters from DEM fields.")
    parser.add_argument("--config", required=True)
    parser.add_argument("--rheometer", nargs="+", required=True, type=Path, help="rheometer fields files")
    parser.add_argument("--nonlocal", dest="nonlocal_fields", nargs="*", default=[], type=Path,
                        help="fields files of the non-local calibration runs (their replica mean is fitted)")
    parser.add_argument("--out", required=True, type=Path)
    args = parser.parse_args(argv)
    config = load_config(args.config)
    params = calibrate(config, args.rheometer, args.nonlocal_fields)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.out.with_name(args.out.name + ".tmp")
    tmp.write_text(json.dumps(params, indent=1))
    tmp.replace(args.out)
    local = params["local"]
    print("mu_s = {:.4f} +- {:.4f}, mu_2 = {:.4f} +- {:.4f}, I_0 = {:.4f} +- {:.4f}, nu_c = {:.4f} +- {:.4f}, a = {:.3f} +- {:.3f}".format(
        *(x for n in ("mu_s", "mu_2", "I_0", "nu_c", "a") for x in (local[n]["value"], local[n]["error"]))))
    wall, d = params["wall"], float(params["d"])
    rheo, case = wall["rheometer"], wall["calibration_case"]
    print(f"wall slip length b = {wall['slip_length']['value_over_d']:.3f} d (from {wall['slip_length']['fitted_on']}); "
          f"rheometer {rheo['value'] / d:.3f} +- {rheo['error'] / d:.3f} d "
          f"(chi2/dof {rheo['chi2_reduced']:.2f}, slope per decade of I {rheo['inertial_trend']['z']:.1f} errors); "
          f"calibration case {case.get('value', float('nan')) / d:.3f} +- "
          f"{case.get('error', float('nan')) / d:.3f} d")
    for model, entry in params["nonlocal"].items():
        for name, e in entry.items():
            per = ", ".join(f"{run} {v:.4g}" for run, v in e["per_replica"].items())
            age, aged = e.get("age") or {}, ""
            if "error_with_age" in e:
                aged = (f"; first half {age['first_half']:.4g}, second half {age['second_half']:.4g}, "
                        f"with the age's error +- {e['error_with_age']:.2g}")
            elif age:
                aged = f"; no age error: {age}"
            print(f"{model}: {name} = {e['value']:.4g} +- {e['error']:.2g} (curvature {e['error_fit_curvature']:.2g}, "
                  f"jackknife {e.get('error_jackknife', float('nan')):.2g}; fitted on {e['fitted_on']}; per replica {per}{aged})")
    return 0
