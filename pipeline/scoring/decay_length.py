"""The decay-length law of creep, like for like: ``validation/decay_length.csv`` and its fits.

In the creeping zone of planar shear with gravity the velocity decays with depth. Its local decay
rate, with z up and the moving wall on top,

    k(z) = d ln u_x / dz = 1 / xi   (m-1; positive where u_x falls away from the moving wall),

is ``1 / xi`` with ``xi = -1 / (d ln u / dx)`` of the literature (x the depth below the wall). NGF
predicts ``xi = A d / sqrt(mu_s - mu)`` (exponent 1/2, Kamrin & Koval 2012; Bouzid et al. 2013 found
it in DEM on both sides of yield); a model with one fixed internal length, this project's reading of
the volume-averaged model, ``xi = l`` whatever mu.

The windows and their slopes are :mod:`pipeline.scoring.creep_windows`'s; the workflow uses its
``resolved`` rule, described here; ``fixed_depth`` (windows fixed in depth, unresolved points kept,
slopes fitted in u) is the other (:func:`scaled_windows`, ``benchmarks/creep_law_sign.py``).

Windows (per run): consecutive non-overlapping windows of ``WINDOW_OVER_D`` d, by depth below the
top contact plane, inside the scores' margin (:func:`pipeline.scoring.replicas.interior`), where
the creep speed (:func:`pipeline.common.observables.creep_speed`) is below ``CREEP_FRACTION`` of the
wall speed and resolved (above twice its error) at every point, from the band's edge down to the
deepest resolved window. There is **no cut on the slope's significance**: a deep window whose slope
is small against its error is a measurement of a long decay length, and it stays in (the earlier cut,
slopes above two errors, removed the deep end, where the law is decided). Each window's slope k
comes from a weighted straight-line fit of ln u on z, its error from the fit (the points' errors,
no kernel inflation) times one scale, the replicas' own verdict on it: windows of two replicas of a
case at the same depth differ by ``sqrt(mean z^2)`` times their combined stated errors
(:func:`replica_error_scale`), which the slope errors are multiplied by. Each row carries the
window's mean stress ratio and inertial number, with its time error times the replicas' verdict
on it (the same test on mu, floored at 1: the packing's frozen stresses and each replica's wall
friction move mu between replicas beyond its time error, and a fit that ignores it is pulled
towards beta = 0).

beta's interval (:func:`beta_interval`): the fit's error counts every window as independent, but
the windows of one run share its packing and its wall friction, so beta's 95 % interval is
``t(n_runs - 1) x max(fit error, leave-one-run-out jackknife error)``. Measured on synthetic beds
with a known beta (tests/pipeline/scoring/test_decay_length_synthetic.py; 100 realisations of the
calibration case's 4 replicas at each of beta = 0.5, 0, -0.16): the fit's own 1.96-sigma interval
covers the truth in 267 and 242 of 300 (``resolved``, ``fixed_depth``), the jackknife's with
t(3) in 278 and 273, the larger of the two with t(3) in 297 and 294: conservative, 1.7-1.9 times
the fit's width.

Fit: ``k d = (mu_s - mu)^beta / C`` (so ``xi / d = C (mu_s - mu)^(-beta)``) by weighted least
squares **in k** over the windows below yield (mu < mu_s), the error of each row combining that of
k and that of mu through the current beta; a slope near zero or below it is then a point like any
other. Fitted on all windows, and without the windows nearest the band (``u / V >= BAND_EDGE``), so
that the band's edge cannot decide beta. Model selection between ``xi`` constant (beta = 0, one
parameter) and the power law (two): the chi2 difference (likelihood ratio, chi2 with one degree of
freedom when the errors are Gaussian) and the AIC difference. Where the windows reach above yield
(mu > mu_s, the band side), ``k d = (mu - mu_s)^beta / C`` is fitted on them too. Each model's k and mu on exactly the
DEM's windows (the same depths of the same case, the model's own u and mu there) give the model's
beta on the same footing.
"""
from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr
from scipy import stats
from scipy.optimize import curve_fit

from pipeline.common import atomic
from pipeline.common.config import load_config
from pipeline.common.observables import creep_speed
from pipeline.common.provenance import provenance
from pipeline.scoring.creep_windows import (CREEP_FRACTION, RULES, SLOPE_RANGE_D, creep_windows,  # noqa: F401
                                            fixed_windows, likelihood_slope, window_slope)
from pipeline.scoring.replicas import WALL_MARGIN_OVER_D, bottom_plane, top_plane
from pipeline.scoring.scores import calibration_cases

#: The windows nearest the band are those at or above this u / V: the fit is also made without them.
BAND_EDGE = 0.01
WINDOW_OVER_D = 1.0
COLUMNS = ["case", "run", "z", "mu", "xi", "xi_err", "I", "slope", "slope_err", "mu_err", "mu_over_mu_s",
           "depth_below_top", "u_over_V", "speed_source", "role", "window"]
MODEL_COLUMNS = ["case", "model", "run", "window", "z", "mu", "xi", "slope", "mu_over_mu_s", "depth_below_top", "u_over_V"]


class DecayLengthError(ValueError):
    """Too few resolved creep windows to fit the law; the message says where."""


def dem_rows(source: Path | xr.Dataset, mu_s: float, role: str, rule: str = "resolved") -> pd.DataFrame:
    """The decay-rate windows of one DEM fields file (a path or an open dataset; module
    docstring), errors not yet scaled, windows chosen by ``rule`` (:data:`RULES`)."""
    if rule not in RULES:
        raise ValueError(f"rule must be one of {RULES}, got {rule!r}")
    if isinstance(source, xr.Dataset):
        return _dem_rows(source, mu_s, role, rule, "")
    with xr.open_dataset(source) as ds:
        return _dem_rows(ds, mu_s, role, rule, source)


def _dem_rows(ds: xr.Dataset, mu_s: float, role: str, rule: str, path: Path | str) -> pd.DataFrame:
    d = float(ds.attrs["d"])
    u, err, disp = creep_speed(ds)
    z = ds.z.values
    top, bottom = top_plane(ds), bottom_plane(ds)
    depth = top - z
    v = float(ds.attrs["wall_speed"])
    lo, hi = WALL_MARGIN_OVER_D * d, (top - bottom) - WALL_MARGIN_OVER_D * d
    if rule == "resolved":
        windows = creep_windows(depth, u, err, v, WINDOW_OVER_D * d, lo, hi)
    else:
        windows = fixed_windows(depth, u, v, WINDOW_OVER_D * d, lo, hi)
    mu, mu_err, inertial = ds["mu"].values, ds["mu_err"].values, ds["I"].values
    case, run = str(ds.attrs.get("case", Path(path).parent.name)), str(ds.attrs.get("run", Path(path).stem))
    rows = []
    for k, idx in windows:
        if rule == "resolved":
            slope, slope_err = window_slope(z[idx], u[idx], err[idx])
            bounded = True
        else:
            slope, slope_err, bounded = likelihood_slope(z[idx], u[idx], err[idx], d)
        u_mean = float(np.mean(u[idx]))
        rows.append({"case": case, "run": run, "window": k, "z": float(z[idx].mean()), "slope": slope, "slope_err": slope_err,
                     "xi": 1.0 / slope if slope > 0 else math.inf,
                     "mu": float(mu[idx].mean()), "mu_err": float(mu_err[idx].mean()),
                     "I": float(inertial[idx].mean()), "depth_below_top": float(depth[idx].mean()),
                     # A window below its noise may hold points at or below zero: its speed is the
                     # plain mean there (the geometric mean where every point is positive).
                     "u_over_V": float(np.exp(np.log(u[idx]).mean()) / v) if np.all(u[idx] > 0) else u_mean / v,
                     "speed_source": "u_x_disp" if disp[idx].mean() >= 0.5 else "u_x", "role": role,
                     "slope_bounded": bounded})
    frame = pd.DataFrame(rows, columns=[c for c in COLUMNS if c not in ("mu_over_mu_s", "xi_err")] + ["slope_bounded"])
    return frame.assign(mu_over_mu_s=frame.mu / mu_s)


def replica_error_scale(windows: pd.DataFrame, value: str = "slope", error: str = "slope_err") -> tuple[float, int]:
    """The replicas' verdict on the errors of column ``value`` (the slope by default): for every pair
    of replicas of a case with a window at the same depth, ``z = (k_a - k_b) / sqrt(s_a^2 + s_b^2)``;
    returns ``sqrt(mean z^2)`` and the number of pairs (scale 1 with fewer than 3 pairs: nothing to
    judge by)."""
    terms: list[np.ndarray] = []
    for _, group in windows.groupby(["case", "window"]):
        k, s = group[value].to_numpy(dtype=float), group[error].to_numpy(dtype=float)
        i, j = np.triu_indices(k.size, 1)
        combined = np.hypot(s[i], s[j])
        keep = combined > 0
        terms.append(((k[i] - k[j])[keep] / combined[keep]) ** 2)
    terms = np.concatenate(terms) if terms else np.array([])
    if len(terms) < 3:
        return 1.0, len(terms)
    return float(math.sqrt(np.mean(terms))), len(terms)


def _power(x: np.ndarray, inv_c: float, beta: float) -> np.ndarray:
    return inv_c * np.power(x, beta)


def fit_law(mu: np.ndarray, slope_d: np.ndarray, slope_err_d: np.ndarray | None, mu_err: np.ndarray | None,
            mu_s: float, beta_fixed: float | None = None, side: str = "below") -> dict[str, float]:
    """Fit ``k d = |mu_s - mu|^beta / C`` over the rows below yield (mu < mu_s; ``side="above"``:
    mu > mu_s, the band side of Bouzid et al.) (module docstring); with ``beta_fixed``, C only.
    ``slope_d`` is k d (dimensionless); ``slope_err_d`` its errors (None: exact rows, equal weights)."""
    mu, slope_d = np.asarray(mu, dtype=float), np.asarray(slope_d, dtype=float)
    below = mu < mu_s if side == "below" else mu > mu_s
    x = np.abs(mu_s - mu[below])
    y = slope_d[below]
    n = int(below.sum())
    needed = 2 if beta_fixed is not None else 3
    if n < needed or (beta_fixed is None and np.ptp(x) == 0):
        raise DecayLengthError(f"{n} decay rates {side} yield: need {needed} or more over a range of mu")
    exact = slope_err_d is None
    beta = 0.5 if beta_fixed is None else beta_fixed
    # The start's amplitude weighs the rows by their errors, so that rows which carry no
    # information (a window below its noise, error the whole slope range) cannot flip its sign.
    if exact:
        inv_c = float(np.mean(y) / np.mean(x ** 0.5))
    else:
        w0 = 1.0 / np.asarray(slope_err_d, dtype=float)[below] ** 2
        inv_c = float(np.sum(w0 * y) / np.sum(w0 * x ** 0.5))
    sigma = None
    for _ in range(4):
        if not exact:
            s_k = np.asarray(slope_err_d, dtype=float)[below]
            s_mu = 0.0 if mu_err is None else np.abs(inv_c * beta * x ** (beta - 1.0)) * np.asarray(mu_err)[below]
            sigma = np.sqrt(s_k**2 + s_mu**2)
        if beta_fixed is None:
            (inv_c, beta), cov = curve_fit(_power, x, y, p0=[inv_c, beta], sigma=sigma, absolute_sigma=not exact,
                                           maxfev=20000)
        else:
            (inv_c,), cov = curve_fit(lambda xx, a: _power(xx, a, beta_fixed), x, y, p0=[inv_c], sigma=sigma,
                                      absolute_sigma=not exact)
            cov = np.array([[cov[0, 0], 0.0], [0.0, 0.0]])
    resid = (y - _power(x, inv_c, beta)) / (sigma if sigma is not None else 1.0)
    k = 1 if beta_fixed is not None else 2
    chi2 = float(np.sum(resid**2))
    scale = math.sqrt(max(chi2 / max(n - k, 1), 1.0)) if not exact else 1.0
    c = 1.0 / inv_c if inv_c != 0 else math.inf
    return {"beta": float(beta), "beta_err": float(math.sqrt(cov[1, 1]) * scale), "C": float(c),
            "C_err": float(abs(c) * math.sqrt(cov[0, 0]) / abs(inv_c) * scale) if inv_c else math.inf,
            "chi2": chi2, "chi2_reduced": chi2 / max(n - k, 1), "n_points": n,
            "mu_over_mu_s_min": float(mu[below].min() / mu_s), "mu_over_mu_s_max": float(mu[below].max() / mu_s)}


def fit_windows(windows: pd.DataFrame, mu_s: float, d: float, side: str = "below",
                beta_fixed: float | None = None) -> dict[str, float]:
    """:func:`fit_law` on a DEM windows table (columns mu, slope, slope_err, mu_err; slopes in m-1)."""
    return fit_law(windows.mu.values, windows.slope.values * d, windows.slope_err.values * d, windows.mu_err.values,
                   mu_s, beta_fixed=beta_fixed, side=side)


def jackknife_error(windows: pd.DataFrame, mu_s: float, d: float, side: str = "below") -> tuple[float, int]:
    """Leave-one-run-out jackknife standard error of beta over the (case, run) groups of
    ``windows`` (columns mu, slope, slope_err, mu_err; slopes in m-1), and the number of groups
    (NaN with fewer than 3, or where a leave-one-out fit fails)."""
    runs = list(windows.groupby(["case", "run"]).groups)
    if len(runs) < 3:
        return math.nan, len(runs)
    betas = []
    for case, run in runs:
        try:
            betas.append(fit_windows(windows[~((windows.case == case) & (windows.run == run))], mu_s, d, side)["beta"])
        except (DecayLengthError, RuntimeError):
            return math.nan, len(runs)
    b = np.asarray(betas)
    return float(math.sqrt((b.size - 1) / b.size * np.sum((b - b.mean()) ** 2))), len(runs)


def beta_interval(windows: pd.DataFrame, fit: dict[str, float], mu_s: float, d: float, side: str = "below",
                  confidence: float = 0.95) -> dict[str, float]:
    """beta's interval (module docstring): ``beta_err_jackknife``, ``beta_dof`` (runs - 1) and
    ``beta_half_width`` (t(beta_dof) x max(fit error, jackknife error) at ``confidence``; NaN
    without a jackknife)."""
    jk, n_runs = jackknife_error(windows, mu_s, d, side)
    half = (float(stats.t.ppf(0.5 + 0.5 * confidence, n_runs - 1)) * max(jk, fit["beta_err"])
            if math.isfinite(jk) else math.nan)
    return {"beta_err_jackknife": jk, "beta_dof": n_runs - 1, "beta_half_width": half}


def select_model(windows: pd.DataFrame, mu_s: float, d: float) -> dict[str, float]:
    """xi constant against the power law on the same windows: chi2 difference and its p-value
    (likelihood ratio, one degree of freedom), AIC of each (chi2 + 2 k) and their difference
    (positive: the power law is preferred)."""
    power = fit_windows(windows, mu_s, d)
    constant = fit_windows(windows, mu_s, d, beta_fixed=0.0)
    delta = constant["chi2"] - power["chi2"]
    return {"chi2_constant": constant["chi2"], "chi2_power": power["chi2"], "delta_chi2": delta,
            "p_value_constant": float(stats.chi2.sf(max(delta, 0.0), 1)),
            "aic_constant": constant["chi2"] + 2.0, "aic_power": power["chi2"] + 4.0,
            "delta_aic": (constant["chi2"] + 2.0) - (power["chi2"] + 4.0),
            "xi_constant_over_d": constant["C"], "xi_constant_over_d_err": constant["C_err"],
            "preferred": "power law" if (constant["chi2"] + 2.0) - (power["chi2"] + 4.0) > 2.0 else
                         ("xi constant" if (constant["chi2"] + 2.0) - (power["chi2"] + 4.0) < -2.0 else "neither (|delta AIC| <= 2)")}


def model_rows(path: Path, windows: pd.DataFrame, mu_s: float, d: float, fields: dict[tuple[str, str], Path]
               ) -> pd.DataFrame:
    """The model's slope and mu on exactly the DEM's windows of its case (the same depths below the
    top plane of each DEM run's window), from models/{case}/{model}.nc."""
    rows = []
    with xr.open_dataset(path) as sol:
        if "u_x" not in sol or "mu" not in sol:
            return pd.DataFrame(columns=MODEL_COLUMNS)
        case = str(sol.attrs.get("case", path.parent.name))
        depth_model = float(sol.attrs["depth"]) - sol.z_model.values
        order = np.argsort(depth_model)
        for w in windows[windows.case == case].itertuples():
            with xr.open_dataset(fields[(case, w.run)]) as ds:
                depth = top_plane(ds) - ds.z.values
                d_ = float(ds.attrs["d"])
                idx = np.nonzero((depth >= w.depth_below_top - 0.5 * WINDOW_OVER_D * d_)
                                 & (depth < w.depth_below_top + 0.5 * WINDOW_OVER_D * d_))[0]
                depths = depth[idx]
            u = np.interp(depths, depth_model[order], sol.u_x.values[order])
            mu = float(np.interp(depths, depth_model[order], sol.mu.values[order]).mean())
            if depths.size < 3 or np.any(~(u > 0)):
                continue
            slope = float(np.polyfit(-depths, np.log(u), 1)[0])
            rows.append({"case": case, "model": path.stem, "run": w.run, "window": w.window, "z": w.z, "mu": mu,
                         "xi": 1.0 / slope if slope > 0 else math.inf, "slope": slope, "mu_over_mu_s": mu / mu_s,
                         "depth_below_top": w.depth_below_top,
                         "u_over_V": float(np.exp(np.log(u).mean()) / float(sol.attrs["wall_speed"]))})
    return pd.DataFrame(rows, columns=MODEL_COLUMNS)


def fits_table(dem: pd.DataFrame, models: pd.DataFrame, mu_s: float, d: float) -> pd.DataFrame:
    """beta and C of the DEM and of each model on the DEM's windows, all windows and without those
    nearest the band, with the model selection for the DEM."""
    rows = []
    # The model rows are cut by their DEM window's speed, so both are fitted on the same windows.
    keyed = models.merge(dem[["case", "run", "window", "u_over_V"]].rename(columns={"u_over_V": "dem_u_over_V"}),
                         on=["case", "run", "window"], how="inner")
    for cut, limit in (("all windows", math.inf), (f"u/V < {BAND_EDGE:g}", BAND_EDGE)):
        sub = dem[dem.u_over_V < limit]
        base = {"windows": cut, "n_windows": len(sub)}
        try:
            fit = fit_windows(sub, mu_s, d)
            rows.append({"source": "dem", **base, **fit, **beta_interval(sub, fit, mu_s, d), **select_model(sub, mu_s, d)})
        except (DecayLengthError, RuntimeError) as exc:
            rows.append({"source": "dem", **base, "note": str(exc)})
        if limit == math.inf:
            # The band side, where the creep windows reach above mu_s.
            above = sub[sub.mu > mu_s]
            try:
                fit = fit_windows(above, mu_s, d, side="above")
                rows.append({"source": "dem", "windows": "above yield", "n_windows": len(above), **fit,
                             **beta_interval(above, fit, mu_s, d, side="above")})
            except (DecayLengthError, RuntimeError) as exc:
                rows.append({"source": "dem", "windows": "above yield", "n_windows": len(above), "note": str(exc)})
        for model, msub in keyed[keyed.dem_u_over_V < limit].groupby("model"):
            try:
                rows.append({"source": model, **base, "n_windows": len(msub),
                             **fit_law(msub.mu.values, msub.slope.values * d, None, None, mu_s)})
            except (DecayLengthError, RuntimeError) as exc:
                rows.append({"source": model, **base, "n_windows": len(msub), "note": str(exc)})
    return pd.DataFrame(rows)


def scaled_windows(sources: list[tuple[Path | xr.Dataset, str]], mu_s: float, rule: str = "resolved"
                   ) -> tuple[pd.DataFrame, float, int]:
    """Every run's windows under ``rule`` (``sources``: (fields file or dataset, role)), their slope
    errors times the replicas' verdict (:func:`replica_error_scale`, judged on the windows that
    bound their slope: one that does not would compare as z = 0 whatever the scatter), with
    ``xi_err``; returns the table, the scale and its number of pairs."""
    frames = [dem_rows(f, mu_s, role, rule) for f, role in sources]
    # A run without a window adds nothing (and an empty frame would turn every column to objects).
    dem = pd.concat([f for f in frames if len(f)] or frames[:1], ignore_index=True)
    scale, pairs = replica_error_scale(dem[dem.slope_bounded.astype(bool)])
    dem["slope_err"] = dem.slope_err * scale
    # mu's stated error is its time error; the replicas at one depth differ besides by the
    # packing's frozen stresses and their wall friction. Taken from them as the slope's is (floored
    # at 1: a window's mu is not known better than its own time series says). Measured on the
    # synthetic beds with a known beta (tests/pipeline/scoring/test_decay_length_synthetic.py): with
    # the time error alone the fit pulls beta towards 0 by mu's scatter (0.42 for a true 0.5, -0.135
    # for -0.16, 30 realisations each) and its 95 % interval covers the truth in 54 of 90; with the
    # replicas' scale 0.501 and -0.165, and 77 of 90.
    mu_scale, mu_pairs = replica_error_scale(dem, "mu", "mu_err")
    mu_scale = max(mu_scale, 1.0)
    dem["mu_err"] = dem.mu_err * mu_scale
    dem.attrs["mu_error_scale"] = (mu_scale, mu_pairs)
    dem["xi_err"] = np.where(dem.slope > 0, dem.slope_err / np.where(dem.slope > 0, dem.slope, 1.0) ** 2, np.inf)
    return dem, scale, pairs


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Creep decay length against the stress ratio, DEM and models.")
    parser.add_argument("--config", required=True, help="the workflow config (recorded beside the tables)")
    parser.add_argument("--params", required=True, type=Path, help="calibration/params.json (mu_s, the calibration runs)")
    parser.add_argument("--fields", required=True, nargs="+", type=Path, help="fields/CASE/RUN.nc of the planar cases")
    parser.add_argument("--models", nargs="*", default=[], type=Path, help="models/CASE/MODEL.nc of the planar cases")
    parser.add_argument("--out", required=True, type=Path, help="validation/decay_length.csv (fits beside it)")
    parser.add_argument("--rule", choices=RULES, default="resolved",
                        help="the windows' selection rule (pipeline.scoring.creep_windows; the workflow's: resolved)")
    args = parser.parse_args(argv)
    params = json.loads(args.params.read_text())
    mu_s, d = float(params["local"]["mu_s"]["value"]), float(params["d"])
    calibrated = calibration_cases(params)
    dem, scale, pairs = scaled_windows([(f, "calibration" if f.parent.name in calibrated else "held_out")
                                        for f in args.fields], mu_s, args.rule)
    mu_scale, mu_pairs = dem.attrs["mu_error_scale"]
    dem = dem[COLUMNS]
    fields = {(f.parent.name, f.stem): f for f in args.fields}
    models = pd.concat([model_rows(f, dem, mu_s, d, fields) for f in args.models] or [pd.DataFrame(columns=MODEL_COLUMNS)],
                       ignore_index=True)
    fits = fits_table(dem, models, mu_s, d).assign(mu_s=mu_s, slope_error_scale=scale, slope_error_scale_pairs=pairs,
                                                   mu_error_scale=mu_scale, mu_error_scale_pairs=mu_pairs)
    meta = provenance(load_config(args.config))
    atomic.write_csv(dem, args.out)
    atomic.write_csv(models, args.out.with_name("decay_length_models.csv"))
    atomic.write_csv(fits, args.out.with_name("decay_length_fit.csv"))
    atomic.write_text(json.dumps({"mu_s": mu_s, "window_rule": args.rule, "window_over_d": WINDOW_OVER_D, "creep_fraction": CREEP_FRACTION,
                                  "band_edge": BAND_EDGE, "slope_error_scale": scale, "slope_error_scale_pairs": pairs,
                                  "mu_error_scale": mu_scale, "mu_error_scale_pairs": mu_pairs,
                                  "provenance": meta}, indent=1), args.out.with_name("decay_length.json"))
    print(f"{len(dem)} DEM windows from {len(args.fields)} runs; slope errors scaled by {scale:.3g} "
          f"(the replicas' verdict, {pairs} pairs), mu errors by {mu_scale:.3g} ({mu_pairs} pairs); fits:")
    with pd.option_context("display.width", 250, "display.max_columns", 30):
        print(fits.to_string(index=False))
    return 0
