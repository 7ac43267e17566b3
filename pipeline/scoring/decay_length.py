"""The decay-length law of creep: ``validation/decay_length.csv`` and its fit.

In the creeping zone of planar shear with gravity the velocity decays with depth. Its local decay
length, with z up and the moving wall on top,

    xi(z) = 1 / (d ln u_x / dz)   (m; positive where u_x falls away from the moving wall),

is the ``-1 / (d ln u / dx)`` of the literature with x the depth below the wall. NGF predicts
``xi = A d / sqrt(mu_s - mu)`` (exponent 1/2, Kamrin & Koval 2012; Bouzid et al. 2013 found it in
DEM); a model with one fixed internal length, this project's reading of the volume-averaged
model, ``xi = l`` whatever mu. Changing the top-wall pressure moves mu(z), so the cases together
span a range of mu / mu_s against which the two predictions separate.

Measurement, per run: non-overlapping windows of ``window_over_d`` d over the interior (at least
the scores' wall margin from both walls) where the creep speed (:func:`pipeline.common.observables
.creep_speed`) is below ``CREEP_FRACTION`` of the wall speed and resolved (above twice its error at
every point of the window). In each window a weighted straight-line fit of ln u against z gives the
slope and its error; the error is multiplied by sqrt(kernel width / grid spacing) because
neighbouring profile points share grains through the kernel, and by sqrt(chi2) where the scatter
exceeds the stated errors. Windows whose slope is not positive at two standard errors are left out.
Each row carries the window's mean stress ratio mu = |sigma_xz| / p.

Fit: ``xi / d = C (mu_s - mu)^(-beta)`` by weighted least squares in log space over the rows below
yield (mu < mu_s, mu_s from the calibration), the error of each row combining that of xi and that
of mu through the current beta; beta's error is scaled by sqrt(chi2) when above 1. The same
windows on each model's own u_x(z) and mu(z) give the model's xi(mu) and beta.
"""
from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr
from scipy.optimize import curve_fit

from pipeline.common import atomic
from pipeline.common.observables import creep_speed
from pipeline.common.config import load_config
from pipeline.common.provenance import provenance
from pipeline.scoring.replicas import WALL_MARGIN_OVER_D
from pipeline.scoring.scores import calibration_cases

#: Creep: speeds below this fraction of the wall speed (the shear band above is not creep).
CREEP_FRACTION = 0.1
WINDOW_OVER_D = 1.0
COLUMNS = ["case", "run", "z", "mu", "xi", "xi_err", "mu_err", "mu_over_mu_s", "depth_below_top", "u_over_V",
           "speed_source", "role"]
MODEL_COLUMNS = ["case", "model", "z", "mu", "xi", "mu_over_mu_s", "depth_below_top"]


class DecayLengthError(ValueError):
    """Too few resolved creep windows to fit the law; the message says where."""


def _windows(z: np.ndarray, z_lo: float, z_hi: float, width: float) -> list[np.ndarray]:
    """Index sets of consecutive non-overlapping windows of ``width`` over [z_lo, z_hi]."""
    edges = np.arange(z_lo, z_hi + 1e-12, width)
    return [np.nonzero((z >= a) & (z < b))[0] for a, b in zip(edges[:-1], edges[1:])]


def local_decay_lengths(z: np.ndarray, u: np.ndarray, err: np.ndarray | None, mu: np.ndarray,
                        z_lo: float, z_hi: float, wall_speed: float, width: float,
                        correlation: float = 1.0) -> pd.DataFrame:
    """Decay length per window (module docstring); ``err=None`` for an exact (model) profile.

    Returns columns z (window centre), xi, xi_err, mu, mu_err, u_over_V.
    """
    rows = []
    for idx in _windows(z, z_lo, z_hi, width):
        if idx.size < 3:
            continue
        uu = u[idx]
        if not np.all(np.isfinite(uu)) or np.any(uu <= 0) or np.any(uu >= CREEP_FRACTION * wall_speed):
            continue
        y, x = np.log(uu), z[idx]
        if err is None:
            if np.any(uu < 1e-12 * wall_speed):
                continue
            slope = np.polyfit(x, y, 1)[0]
            slope_err = 0.0
        else:
            ee = err[idx]
            if not np.all(np.isfinite(ee)) or np.any(uu <= 2.0 * ee):
                continue
            sigma = ee / uu
            coef, cov = np.polyfit(x, y, 1, w=1.0 / sigma, cov="unscaled")
            slope = coef[0]
            resid = (y - np.polyval(coef, x)) / sigma
            chi2 = float(np.sum(resid**2) / max(idx.size - 2, 1))
            slope_err = math.sqrt(cov[0, 0]) * math.sqrt(correlation) * math.sqrt(max(chi2, 1.0))
            if not slope > 2.0 * slope_err:
                continue
        if not slope > 0:
            continue
        m = mu[idx]
        rows.append({"z": float(x.mean()), "xi": 1.0 / slope, "xi_err": slope_err / slope**2,
                     "mu": float(np.mean(m)), "u_over_V": float(np.exp(y.mean()) / wall_speed)})
    return pd.DataFrame(rows, columns=["z", "xi", "xi_err", "mu", "u_over_V"])


def fit_law(mu: np.ndarray, xi_over_d: np.ndarray, xi_err_over_d: np.ndarray | None, mu_err: np.ndarray | None,
            mu_s: float) -> dict[str, float]:
    """Fit ``xi / d = C (mu_s - mu)^(-beta)`` over the rows with mu < mu_s (module docstring)."""
    mu, xi_over_d = np.asarray(mu, dtype=float), np.asarray(xi_over_d, dtype=float)
    xi_err_over_d = None if xi_err_over_d is None else np.asarray(xi_err_over_d, dtype=float)
    mu_err = None if mu_err is None else np.asarray(mu_err, dtype=float)
    below = mu < mu_s
    x = np.log(mu_s - mu[below])
    y = np.log(xi_over_d[below])
    n = int(below.sum())
    if n < 3 or np.ptp(x) == 0:
        raise DecayLengthError(f"{n} decay lengths below yield: need 3 or more over a range of mu")
    exact = xi_err_over_d is None

    def line(xx: np.ndarray, log_c: float, beta: float) -> np.ndarray:
        return log_c - beta * xx

    beta, log_c = 0.5, float(np.mean(y + 0.5 * x))
    sigma = None
    for _ in range(3):
        if not exact:
            s_xi = xi_err_over_d[below] / xi_over_d[below]
            s_mu = beta * (mu_err[below] if mu_err is not None else 0.0) / (mu_s - mu[below])
            sigma = np.sqrt(s_xi**2 + s_mu**2)
        (log_c, beta), cov = curve_fit(line, x, y, p0=[log_c, beta], sigma=sigma, absolute_sigma=not exact)
    resid = (y - line(x, log_c, beta)) / (sigma if sigma is not None else 1.0)
    chi2 = float(np.sum(resid**2) / max(n - 2, 1))
    scale = math.sqrt(max(chi2, 1.0)) if not exact else 1.0
    return {"beta": float(beta), "beta_err": float(math.sqrt(cov[1, 1]) * scale), "C": float(math.exp(log_c)),
            "C_err": float(math.exp(log_c) * math.sqrt(cov[0, 0]) * scale), "chi2_reduced": chi2, "n_points": n,
            "mu_over_mu_s_min": float(mu[below].min() / mu_s), "mu_over_mu_s_max": float(mu[below].max() / mu_s)}


def _interior(ds: xr.Dataset, d: float) -> tuple[float, float]:
    return (float(ds.attrs["z_bottom_wall"]) + WALL_MARGIN_OVER_D * d, float(ds.attrs["z_top_wall"]) - WALL_MARGIN_OVER_D * d)


def dem_rows(path: Path, mu_s: float, role: str) -> pd.DataFrame:
    """The decay-length rows of one DEM fields file."""
    with xr.open_dataset(path) as ds:
        d = float(ds.attrs["d"])
        u, err, disp = creep_speed(ds)
        z = ds.z.values
        correlation = float(ds.attrs["width"]) / float(z[1] - z[0])
        lo, hi = _interior(ds, d)
        frame = local_decay_lengths(z, u, err, ds["mu"].values, lo, hi, float(ds.attrs["wall_speed"]),
                                    WINDOW_OVER_D * d, correlation)
        mu_err = []
        sources = []
        for zc in frame.z:
            idx = np.nonzero(np.abs(z - zc) <= 0.5 * WINDOW_OVER_D * d)[0]
            mu_err.append(float(np.mean(ds["mu_err"].values[idx])))
            sources.append("u_x_disp" if disp[idx].mean() >= 0.5 else "u_x")
        top = float(ds.attrs["z_top_wall"])
        frame = frame.assign(case=str(ds.attrs.get("case", path.parent.name)), run=str(ds.attrs.get("run", path.stem)),
                             mu_err=mu_err, mu_over_mu_s=frame.mu / mu_s, depth_below_top=top - frame.z,
                             speed_source=sources, role=role)
    return frame[COLUMNS]


def model_rows(path: Path, mu_s: float, d: float) -> pd.DataFrame:
    """The decay-length rows of one model solution (models/{case}/{model}.nc), on its own mu."""
    with xr.open_dataset(path) as sol:
        if "u_x" not in sol or "mu" not in sol:
            return pd.DataFrame(columns=MODEL_COLUMNS)
        z = sol.z.values
        z0 = float(sol.attrs["z_bottom_wall"])
        lo, hi = z0 + WALL_MARGIN_OVER_D * d, z0 + float(sol.attrs["depth"]) - WALL_MARGIN_OVER_D * d
        frame = local_decay_lengths(z, sol.u_x.values, None, sol.mu.values, lo, hi, float(sol.attrs["wall_speed"]),
                                    WINDOW_OVER_D * d)
        top = z0 + float(sol.attrs["depth"])
        frame = frame.assign(case=str(sol.attrs.get("case", path.parent.name)), model=path.stem,
                             mu_over_mu_s=frame.mu / mu_s, depth_below_top=top - frame.z)
    return frame[MODEL_COLUMNS]


def fits_table(dem: pd.DataFrame, models: pd.DataFrame, mu_s: float, d: float) -> pd.DataFrame:
    """beta and C of the DEM (all planar cases together) and of each model (all its cases)."""
    rows = []
    try:
        rows.append({"source": "dem", **fit_law(dem.mu.values, dem.xi.values / d, dem.xi_err.values / d,
                                                 dem.mu_err.values, mu_s)})
    except DecayLengthError as exc:
        rows.append({"source": "dem", "note": str(exc)})
    for model, sub in models.groupby("model"):
        try:
            rows.append({"source": model, **fit_law(sub.mu.values, sub.xi.values / d, None, None, mu_s)})
        except DecayLengthError as exc:
            rows.append({"source": model, "note": str(exc)})
    return pd.DataFrame(rows)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Creep decay length against the stress ratio, DEM and models.")
    parser.add_argument("--config", required=True, help="the workflow config (recorded beside the tables)")
    parser.add_argument("--params", required=True, type=Path, help="calibration/params.json (mu_s, the calibration runs)")
    parser.add_argument("--fields", required=True, nargs="+", type=Path, help="fields/CASE/RUN.nc of the planar cases")
    parser.add_argument("--models", nargs="*", default=[], type=Path, help="models/CASE/MODEL.nc of the planar cases")
    parser.add_argument("--out", required=True, type=Path, help="validation/decay_length.csv (fits beside it)")
    args = parser.parse_args(argv)
    params = json.loads(args.params.read_text())
    mu_s, d = float(params["local"]["mu_s"]["value"]), float(params["d"])
    calibrated = calibration_cases(params)
    dem = pd.concat([dem_rows(f, mu_s, "calibration" if f.parent.name in calibrated else "held_out") for f in args.fields],
                    ignore_index=True)
    models = pd.concat([model_rows(f, mu_s, d) for f in args.models] or [pd.DataFrame(columns=MODEL_COLUMNS)],
                       ignore_index=True)
    fits = fits_table(dem, models, mu_s, d).assign(mu_s=mu_s)
    meta = provenance(load_config(args.config))
    atomic.write_csv(dem, args.out)
    atomic.write_csv(models, args.out.with_name("decay_length_models.csv"))
    atomic.write_csv(fits, args.out.with_name("decay_length_fit.csv"))
    atomic.write_text(json.dumps({"mu_s": mu_s, "window_over_d": WINDOW_OVER_D, "creep_fraction": CREEP_FRACTION,
                                  "provenance": meta}, indent=1), args.out.with_name("decay_length.json"))
    print(f"{len(dem)} DEM windows from {len(args.fields)} runs; fits:")
    print(fits.to_string(index=False))
    return 0
