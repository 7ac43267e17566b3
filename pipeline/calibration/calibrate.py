"""Calibrate the continuum models from DEM fields: ``calibration/params.json``.

Local laws come from the rheometer only: each rheometer run gives one homogeneous state (bulk
averages at least ``bulk_margin_over_d`` d from each wall) of I, mu, nu and p with standard
errors; mu(I), nu(I) and the critical-state family are fitted to those states
(:mod:`continuum.calibration`). The non-local parameters (NGF A, the Cosserat and the
volume-averaged lengths l) are fitted, with the local laws fixed, on one calibration run named in
the config (``calibration.nonlocal_case`` / ``nonlocal_run``), by least squares of log10 u_x in
its creeping zone; ``params.json`` records where each value was fitted so the report can say which
scores are not independent of the calibration.

Usage: ``python -m pipeline.calibration.calibrate --config CONFIG --rheometer F1.nc F2.nc ... --nonlocal FIELDS.nc --out params.json``
"""
from __future__ import annotations

import argparse
import json
import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

import continuum
from continuum import calibration as fits
from continuum.geometry import PlanarShear
from continuum.parameters import (
    CosseratParameters,
    CriticalStateParameters,
    LocalMuIParameters,
    NGFParameters,
    VolumeAveragedParameters,
)
from pipeline.common.config import calibration_runs, load_config, validation_cases
from pipeline.common.formats import open_fields
from pipeline.common.observables import creep_speed, log_speed_error
from pipeline.common.planar_cell import planar_cell
from pipeline.common.provenance import provenance

CALIBRATION_DEFAULTS: dict[str, Any] = {
    "nonlocal_case": "shear_gravity",
    "nonlocal_run": "r1",
    "bulk_margin_over_d": 3.0,
    # Creeping points below this fraction of the wall speed are left out of the log fit: the
    # DEM resolves them only above its noise (checked against the point's own error too).
    "min_speed_over_wall_speed": 1e-5,
    "critical_state_n": 1.05,
    "cosserat_beta": 1.0,
    "cosserat_wall_spin_ratio": 0.5,
}


#: Slope d nu_cs / d ln p used when the DEM resolves none (rigid grains): the order of the
#: relative grain compliance (mean overlap / d ~ 1e-3).
KAPPA_FLOOR = 1e-3

#: Points faster than this fraction of the wall speed are the shear band in the fit report.
BAND_SPEED = 0.1


class CalibrationError(ValueError):
    """The fields cannot calibrate the models; the message names the file and the cause."""


def calibration_settings(config: dict[str, Any]) -> dict[str, Any]:
    """The config's ``calibration`` section over :data:`CALIBRATION_DEFAULTS`."""
    return CALIBRATION_DEFAULTS | (config.get("calibration") or {})


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


def _entry(value: float, error: float, fitted_on: str, note: str = "") -> dict[str, Any]:
    entry: dict[str, Any] = {"value": float(value), "error": float(error), "fitted_on": fitted_on}
    if note:
        entry["note"] = note
    return entry


def planar_geometry(ds: xr.Dataset, normal_stress_ratio: float) -> tuple[PlanarShear, np.ndarray]:
    """The model cell of one fields file (contact planes, :mod:`pipeline.common.planar_cell`)
    and the fields' z measured from its bottom plane."""
    geometry, z0 = planar_cell([ds], normal_stress_ratio)
    return geometry, ds.z.values - z0


def creep_profile(ds: xr.Dataset, settings: dict[str, Any], ratio: float
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points of u_x(z) usable for a log fit: inside the walls, resolved above the DEM noise."""
    geometry, z = planar_geometry(ds, ratio)
    u, err, _ = creep_speed(ds)
    floor = settings["min_speed_over_wall_speed"] * geometry.wall_speed
    keep = (z > 0.0) & (z < geometry.depth) & (u > floor) & (u > 2.0 * err)
    return z[keep], u[keep], err[keep]


def fit_errors(u: np.ndarray, err: np.ndarray) -> np.ndarray:
    """Errors (m s-1) the non-local fits weight log10 u by: the stated error, floored at
    LOG_SPEED_ERROR_FLOOR decades (pipeline.common.observables), so the shear band's tiny relative
    errors do not decide a length that the creep below it measures."""
    return log_speed_error(u, err) * u * math.log(10.0)


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


def calibrate(config: dict[str, Any], rheometer_files: list[Path], nonlocal_file: Path | None) -> dict[str, Any]:
    """All parameters with errors and provenance (the content of ``params.json``)."""
    settings = calibration_settings(config)
    read = [run_label(Path(f)) for f in [*rheometer_files, *([nonlocal_file] if nonlocal_file is not None else [])]]
    check_calibration_set(config, read)
    states = [bulk_state(Path(f), settings["bulk_margin_over_d"]) for f in rheometer_files]
    if len(states) < 3:
        raise CalibrationError(f"mu(I) has 3 parameters: need at least 3 rheometer states, got {len(states)}")
    arr = {k: np.array([s[k] for s in states]) for k in ("I", "I_err", "mu", "mu_err", "nu", "nu_err", "p")}
    if len({round(math.log10(i), 2) for i in arr["I"]}) < 3:
        raise CalibrationError(f"mu(I) needs 3 distinct inertial numbers, got I = {arr['I'].tolist()}")
    mu_fit = fits.fit_mu_i(arr["I"], arr["mu"], arr["mu_err"])
    nu_fit = fits.fit_solid_fraction(arr["I"], arr["nu"], arr["nu_err"])
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
        },
        "normal_stresses": normal_stress_entries(states),
        "microscopic_fluidity": microscopic_fluidity_fit(states, float(states[0]["d"])),
        "rheometer_states": states,
        # The exact runs this calibration read: every score on a case with one of them is a fit.
        "calibration_runs": [f"{case}/{run}" for case, run in read],
        "nonlocal": {},
    }
    if nonlocal_file is not None:
        params["nonlocal"], params["nonlocal_fit_residuals"] = calibrate_nonlocal(params, Path(nonlocal_file), settings)
    with open_fields(rheometer_files[0]) as first:
        d, rho_s = float(first.attrs["d"]), float(first.attrs["rho_s"])
    params["d"] = d
    params["rho_s"] = rho_s
    params["provenance"] = provenance(config)
    return params


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


def normal_stress_ratio(params: dict[str, Any]) -> float:
    """sigma_zz / p of the calibration: the models' p is sigma_zz over it (continuum.geometry)."""
    try:
        return float(params["normal_stresses"]["sigma_zz_over_p"]["value"])
    except KeyError:
        raise CalibrationError("params.json has no normal_stresses.sigma_zz_over_p: written by an older "
                               "calibration, rerun it") from None


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


def calibrate_nonlocal(params: dict[str, Any], path: Path, settings: dict[str, Any]
                       ) -> tuple[dict[str, Any], dict[str, dict[str, float]]]:
    """NGF A and the Cosserat and volume-averaged l, each fitted to the creep of one run, and
    each fit's log10 residuals in the shear band and in the creep (:func:`region_residuals`)."""
    ds = open_fields(path)
    ratio = normal_stress_ratio(params)
    geometry, _ = planar_geometry(ds, ratio)
    z, u, err = creep_profile(ds, settings, ratio)
    where = f"{ds.attrs.get('case', '?')}/{ds.attrs.get('run', path.stem)}"
    if z.size < 4:
        raise CalibrationError(f"{path}: only {z.size} resolved creep points to fit the non-local lengths")
    base = {name: entry["value"] for name, entry in (params["local"] | params["critical_state"]).items()}
    out: dict[str, Any] = {}
    ngf0 = ngf_parameters(base, A=0.48)
    weights = fit_errors(u, err)
    fit = fits.fit_nonlocal_length("ngf", geometry, lambda a: replace(ngf0, A=a), z, u, weights,
                                   initial=0.48, bounds=(0.01, 10.0), name="A", case=where)
    at_bound = fit.values["A"] < 0.0101 or fit.values["A"] > 9.99
    out["ngf"] = {"A": _entry(fit.values["A"], fit.errors["A"], where,
                              "the fit sits at a bound of [0.01, 10]: the DEM creep is not NGF-shaped here" if at_bound else "")}
    residuals = {"ngf": region_residuals("ngf", geometry, replace(ngf0, A=fit.values["A"]), z, u)}
    d = geometry.d
    for model, build in (("cosserat", cosserat_parameters), ("volume_averaged", volume_averaged_parameters)):
        start = build(base, l=d, settings=settings)
        make = lambda l, s=start: replace(s, l=l)  # noqa: E731
        lo, hi = admissible_interval(model, geometry, make, 0.05 * d, 20.0 * d)
        fit = fits.fit_nonlocal_length(model, geometry, make, z, u, weights, initial=math.sqrt(lo * hi),
                                       bounds=(lo, hi), name="l", case=where)
        note = ""
        if lo > 0.05 * d or hi < 20.0 * d:
            note = f"the model solves on this geometry only for l in [{lo / d:.3g}, {hi / d:.3g}] d; fitted there"
        if fit.values["l"] > 0.99 * hi or fit.values["l"] < 1.01 * lo:
            note += "; the fit sits at a bound of that interval"
        out[model] = {"l": _entry(fit.values["l"], fit.errors["l"], where, note.strip("; "))}
        residuals[model] = region_residuals(model, geometry, make(fit.values["l"]), z, u)
    ds.close()
    return out, residuals


def admissible_interval(model: str, geometry: PlanarShear, make_params: Any, lo: float, hi: float,
                        n_grid: int = 400, samples: int = 25) -> tuple[float, float]:
    """The widest interval of lengths in [lo, hi] (log-spaced samples) where the model solves.

    The Cosserat model has solutions only in a window of l for a given wall-spin condition: below
    it the couple-stress wall conditions are not met on the grid, above it the shear stress it
    needs exceeds what the top wall admits. Fitting must stay inside that window.
    """
    import continuum

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
    return float(lengths[best[0]]), float(lengths[best[1] - 1])


# ------------------------------------------------------------------- parameter dataclasses
def _mu_i(v: dict[str, float]):
    from continuum.parameters import MuIParameters

    return MuIParameters(v["mu_s"], v["mu_2"], v["I_0"])


def local_mu_i_parameters(v: dict[str, float]) -> LocalMuIParameters:
    from continuum.parameters import SolidFractionLaw

    return LocalMuIParameters(_mu_i(v), SolidFractionLaw(v["nu_c"], v["a"]))


def ngf_parameters(v: dict[str, float], A: float) -> NGFParameters:
    return NGFParameters(_mu_i(v), A=A, nu=v["nu_c"])


def critical_state_parameters(v: dict[str, float], settings: dict[str, Any] | None = None) -> CriticalStateParameters:
    from continuum.parameters import CriticalStateLine

    n = v.get("n", (settings or CALIBRATION_DEFAULTS)["critical_state_n"])
    return CriticalStateParameters(v["sin_phi"], CriticalStateLine(v["nu_ref"], v["kappa"], v["p_ref"]), n=n)


def cosserat_parameters(v: dict[str, float], l: float, settings: dict[str, Any] | None = None) -> CosseratParameters:
    s = settings or CALIBRATION_DEFAULTS
    return CosseratParameters(critical_state_parameters(v, s), l=l, beta=s["cosserat_beta"],
                              wall_spin_ratio=s["cosserat_wall_spin_ratio"])


def volume_averaged_parameters(v: dict[str, float], l: float, settings: dict[str, Any] | None = None) -> VolumeAveragedParameters:
    return VolumeAveragedParameters(critical_state_parameters(v, settings), l=l)


def values(params: dict[str, Any]) -> dict[str, float]:
    """Flat name -> value of the local and critical-state parameters of a params.json."""
    return {name: entry["value"] for name, entry in (params["local"] | params["critical_state"]).items()}


def model_parameters(params: dict[str, Any], model: str) -> Any:
    """The continuum parameter dataclass of ``model`` from a params.json content."""
    v = values(params)
    nonlocal_ = params.get("nonlocal", {})
    if model == "local_mu_i":
        return local_mu_i_parameters(v)
    if model == "critical_state":
        return critical_state_parameters(v)
    if model not in nonlocal_:
        raise CalibrationError(f"params.json has no non-local calibration for model {model!r}")
    if model == "ngf":
        return ngf_parameters(v, A=nonlocal_["ngf"]["A"]["value"])
    if model == "cosserat":
        return cosserat_parameters(v, l=nonlocal_["cosserat"]["l"]["value"])
    if model == "volume_averaged":
        return volume_averaged_parameters(v, l=nonlocal_["volume_averaged"]["l"]["value"])
    raise CalibrationError(f"unknown model {model!r}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Fit the continuum parameters from DEM fields.")
    parser.add_argument("--config", required=True)
    parser.add_argument("--rheometer", nargs="+", required=True, type=Path, help="rheometer fields files")
    parser.add_argument("--nonlocal", dest="nonlocal_fields", type=Path, help="fields file of the non-local calibration run")
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
    for model, entry in params["nonlocal"].items():
        for name, e in entry.items():
            print(f"{model}: {name} = {e['value']:.4g} +- {e['error']:.2g} (fitted on {e['fitted_on']})")
    return 0
