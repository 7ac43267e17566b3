"""What a rough DEM wall does to the bed next to it: its slip, its effective plane, its stress.

The models bound the bed at the DEM's contact planes (``z_*_contact_plane``, where the wall grains
take the bed's load: :mod:`pipeline.common.planar_cell`). The bed's grains there do not move with
the wall. Measured per run on the body grains' velocity ``u_x_disp`` (the wall grains, which move
with the wall, are not in it; ``u_x`` is, and next to the plane it is half wall grains):

- the **profile at the wall**, extrapolated to the plane (value and slope): in homogeneous shear
  (no gravity) the bulk's straight line; under gravity, at the top wall an exponential (the band
  decays away from the wall) and at the bottom a line, fitted, weighted by the errors, through the
  body grains' velocity from ``offset_over_d`` to ``offset_over_d + layer_over_d`` grain
  diameters inside the contact plane. Nearer the plane than ``offset_over_d`` the kernel averages
  the first layer of grains alone (their centres lie about half a grain inside the plane) and the
  coarse-grained profile flattens: that layer's own lag is kept apart, as
  ``wall_*_first_layer_slip`` (the body grains' velocity at the plane itself);
- the **slip** at each contact plane: the wall's speed less the extrapolated profile there
  (top: V - u(z_top), bottom: u(z_bottom) - 0), m s-1, positive when the bed lags the wall;
- the **near-wall shear rate**: the extrapolated profile's slope at the plane (s-1);
- the **Navier slip length** b = slip / near-wall shear rate (m), the models' wall law
  (``continuum.geometry.PlanarShear.slip_length``), and the **effective wall plane** b outside
  the contact plane, where the profile's tangent reaches the wall's speed. With a shear rate that
  is not resolved (below twice its error, as at the bottom of a bed whose creep has died out) b
  and the plane are NaN;
- the **wall's stress** from the wall's own force series: shear |<f_x>| / A and normal <f_z> / A
  (Pa), with the same error rule as the wall friction (the larger of 8 blocks' and the
  autocorrelation-time estimate).

Errors here are a run's own (its time blocks and the velocity's structural error, the fit's
points counted as correlated over the kernel's width); the replicas' scatter is the scoring's
and the calibration's.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

from pipeline.common.statistics import autocorrelated_mean_error

#: Grain diameters inside the contact plane where the near-wall fit starts, and its length.
OFFSET_OVER_D = 0.75
LAYER_OVER_D = 1.75


def _weighted_line(x: np.ndarray, y: np.ndarray, err: np.ndarray, correlated: float) -> tuple[np.ndarray, np.ndarray]:
    w = 1.0 / err**2
    design = np.column_stack([np.ones_like(x), x])
    cov = np.linalg.inv(design.T @ (design * w[:, None]))
    return cov @ (design.T @ (w * y)), np.sqrt(np.diag(cov)) * correlated


def profile_at_plane(z: np.ndarray, u: np.ndarray, err: np.ndarray, plane: float, lo: float, hi: float, width: float,
                     shape: str) -> tuple[float, float, float, float]:
    """The profile through the points with ``lo <= z <= hi``, extrapolated to ``plane``: (value,
    its error, slope, its error). ``shape`` ``linear``: a weighted straight line (homogeneous
    shear); ``exponential``: a straight line in ln u (a shear band decaying away from the wall, as
    under gravity; points with u not above twice its error are left out). The points are
    kernel-smoothed, correlated over the kernel's ``width`` (m): the errors are scaled by
    sqrt(points per width), not counted as independent."""
    sel = (z >= lo) & (z <= hi) & np.isfinite(u) & np.isfinite(err) & (err > 0)
    if shape == "exponential":
        sel &= u > 2.0 * err
    if sel.sum() < 3:
        return math.nan, math.nan, math.nan, math.nan
    correlated = math.sqrt(max(1.0, width / float(np.median(np.diff(z)))))
    x = z[sel] - plane
    if shape == "linear":
        coef, sd = _weighted_line(x, u[sel], err[sel], correlated)
        return float(coef[0]), float(sd[0]), float(coef[1]), float(sd[1])
    coef, sd = _weighted_line(x, np.log(u[sel]), err[sel] / u[sel], correlated)
    value = float(math.exp(coef[0]))
    return value, value * float(sd[0]), value * float(coef[1]), value * float(math.hypot(sd[1], coef[1] * sd[0]))


def wall_slip(ds: xr.Dataset, wall_speed: float, d: float, layer_over_d: float = LAYER_OVER_D,
              offset_over_d: float = OFFSET_OVER_D, bulk_margin_over_d: float = 3.0) -> dict[str, float]:
    """Slip, near-wall shear rate, slip length and effective plane at both walls (module doc).

    ``ds`` is a fields file with ``u_x_disp``, ``u_x_disp_err``, ``gravity`` and the contact-plane
    attributes; ``wall_speed`` (m s-1) the top wall's, the bottom wall being at rest. Heights in m
    (DEM frame). Without gravity (homogeneous shear) the profile at both walls is the bulk's
    straight line (``bulk_margin_over_d`` from both planes) extrapolated; with gravity the top
    wall's band is fitted as an exponential and the bottom as a line, each over ``offset_over_d``
    to ``offset_over_d + layer_over_d`` d inside its plane.
    """
    z = ds["z"].values
    u, err = ds["u_x_disp"].values, ds["u_x_disp_err"].values
    width = float(ds.attrs.get("width", 0.5 * d))
    top, bottom = float(ds.attrs["z_top_contact_plane"]), float(ds.attrs["z_bottom_contact_plane"])
    homogeneous = float(ds.attrs.get("gravity", 0.0)) == 0.0
    out: dict[str, float] = {"wall_layer_over_d": float(layer_over_d), "wall_layer_offset_over_d": float(offset_over_d),
                             "wall_profile_fit": "bulk line" if homogeneous else "top exponential, bottom line"}
    for side, plane, wall_u, inward in (("top", top, wall_speed, -1.0), ("bottom", bottom, 0.0, 1.0)):
        if homogeneous:
            lo, hi, shape = bottom + bulk_margin_over_d * d, top - bulk_margin_over_d * d, "linear"
        else:
            lo, hi = sorted((plane + inward * offset_over_d * d, plane + inward * (offset_over_d + layer_over_d) * d))
            shape = "exponential" if side == "top" else "linear"
        at_plane, at_plane_err, rate, rate_err = profile_at_plane(z, u, err, plane, lo, hi, width, shape)
        first = float(np.interp(plane, z, u))
        slip = (wall_u - at_plane) if side == "top" else (at_plane - wall_u)
        resolved = math.isfinite(rate) and abs(rate) > 2.0 * rate_err
        length = slip / rate if resolved else math.nan
        # b = s / gammadot: the two come from one fit; their errors are taken as independent
        length_err = (abs(length) * math.hypot(at_plane_err / slip if slip else math.inf, rate_err / rate)
                      if resolved else math.nan)
        out.update({
            f"wall_{side}_slip": slip, f"wall_{side}_slip_err": at_plane_err,
            f"wall_{side}_first_layer_slip": (wall_u - first) if side == "top" else (first - wall_u),
            f"wall_{side}_shear_rate": rate, f"wall_{side}_shear_rate_err": rate_err,
            f"wall_{side}_slip_length": length, f"wall_{side}_slip_length_err": length_err,
            f"wall_{side}_effective_plane": plane - inward * length if resolved else math.nan,
        })
    return out


def _mean_and_error(values: np.ndarray, blocks: int) -> tuple[float, float]:
    mean = float(values.mean())
    block_means = np.array([b.mean() for b in np.array_split(values, blocks)])
    block_err = float(block_means.std(ddof=1) / math.sqrt(blocks))
    return mean, float(np.nanmax([block_err, autocorrelated_mean_error(values)]))


def wall_stresses(series: pd.DataFrame, area: float, blocks: int = 8) -> dict[str, float]:
    """The top and bottom walls' shear and normal stresses (Pa) over the production: the force
    series' means per area, magnitudes (shear |<f_x>| / A, normal |<f_z>| / A), and their errors."""
    out: dict[str, float] = {}
    for side, prefix in (("top", "ftop"), ("bottom", "fbot")):
        for kind, column in (("shear", "x"), ("normal", "z")):
            mean, err = _mean_and_error(series[f"{prefix}_{column}"].to_numpy(dtype=float), blocks)
            out[f"wall_{side}_{kind}_stress"] = abs(mean) / area
            out[f"wall_{side}_{kind}_stress_err"] = err / area
    return out


def wall_attrs(ds: xr.Dataset, series: pd.DataFrame, run: dict[str, Any]) -> dict[str, float]:
    """Every wall attribute of a planar fields file (module doc)."""
    area = float(run["cell"][0]) * float(run["cell"][1])
    return wall_slip(ds, float(run["wall_speed"]), float(run["d"])) | wall_stresses(series, area)
