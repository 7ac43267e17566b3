"""Scoring metrics: how far a predicted profile is from a DEM profile.

Every function takes profiles on a common height grid ``z`` (m) and returns a number, ``inf`` when
the prediction cannot be scored on that metric because it predicts no flow where DEM flows
(a model that cannot creep is scored as such), or raises :class:`MetricError` when the DEM data
do not define the metric (e.g. no resolved creep).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Creep points are resolved when the DEM speed exceeds this many standard errors.
RESOLVED_SIGMAS = 2.0


class MetricError(ValueError):
    """The reference data do not define the metric."""


@dataclass(frozen=True)
class Profile:
    """A velocity profile u_x(z) with standard errors (m s-1); err may be zeros for a model."""

    z: np.ndarray
    u: np.ndarray
    err: np.ndarray


def velocity_rmse_rel(z: np.ndarray, u_model: np.ndarray, u_dem: np.ndarray, wall_speed: float) -> float:
    """RMS of (u_model - u_dem) over the wall speed."""
    return float(np.sqrt(np.mean((np.asarray(u_model) - np.asarray(u_dem)) ** 2)) / wall_speed)


def creeping_mask(dem: Profile, wall_speed: float, creep_below: float = 0.1, floor: float = 1e-6) -> np.ndarray:
    """Points of the creeping region where DEM resolves the speed.

    Creeping: u below ``creep_below`` V (beneath the shear band); resolved: u above
    ``RESOLVED_SIGMAS`` standard errors and above ``floor`` V.
    """
    u, err = np.asarray(dem.u), np.asarray(dem.err)
    return (u < creep_below * wall_speed) & (u > RESOLVED_SIGMAS * err) & (u > floor * wall_speed)


def log_velocity_rmse(u_model: np.ndarray, dem: Profile, mask: np.ndarray) -> float:
    """RMS of log10(u_model / u_dem) over the creeping points ``mask``; inf if the model is 0 there."""
    if not np.any(mask):
        raise MetricError("no resolved creeping points in the DEM profile")
    um = np.asarray(u_model)[mask]
    if np.any(um <= 0.0):
        return float("inf")
    return float(np.sqrt(np.mean((np.log10(um) - np.log10(np.asarray(dem.u)[mask])) ** 2)))


def decay_length(z: np.ndarray, u: np.ndarray, mask: np.ndarray) -> float:
    """e-folding length (m) of u over the masked points: slope of a straight-line fit of ln u on z."""
    zz, uu = np.asarray(z)[mask], np.asarray(u)[mask]
    if zz.size < 3:
        raise MetricError(f"only {zz.size} creeping points: no decay length")
    if np.any(uu <= 0.0):
        return float("inf")
    slope = np.polyfit(zz, np.log(uu), 1)[0]
    # Creep grows towards the moving wall (z up): a positive slope; a flat profile has no length.
    return float(1.0 / slope) if slope > 0 else float("inf")


def decay_length_rel_err(z: np.ndarray, u_model: np.ndarray, dem: Profile, mask: np.ndarray) -> float:
    """|l_model - l_dem| / l_dem with both lengths fitted over the same creeping points."""
    l_dem = decay_length(z, dem.u, mask)
    if not np.isfinite(l_dem):
        raise MetricError("the DEM creep has no finite decay length")
    l_model = decay_length(z, u_model, mask)
    return float(abs(l_model - l_dem) / l_dem) if np.isfinite(l_model) else float("inf")


def shear_band_width(z: np.ndarray, u: np.ndarray, wall_speed: float, low: float = 0.1, high: float = 0.9) -> float:
    """Height (m) over which u rises from ``low`` V to ``high`` V (band below the moving wall).

    Heights are interpolated linearly, scanning down from the top wall; 0 for a velocity jump.
    """
    z, u = np.asarray(z), np.asarray(u) / wall_speed

    def crossing(level: float) -> float:
        # Last point from the top where u falls below level.
        below = np.nonzero(u < level)[0]
        if below.size == 0:
            return float(z[0])
        k = below[-1]
        if k == len(z) - 1:
            return float(z[-1])
        z0, z1, u0, u1 = z[k], z[k + 1], u[k], u[k + 1]
        return float(z0 + (level - u0) * (z1 - z0) / (u1 - u0)) if u1 != u0 else float(z0)

    return max(crossing(high) - crossing(low), 0.0)


def shear_band_width_rel_err(z: np.ndarray, u_model: np.ndarray, u_dem: np.ndarray, wall_speed: float) -> float:
    """|w_model - w_dem| / w_dem of the 10-90 % shear-band width."""
    w_dem = shear_band_width(z, u_dem, wall_speed)
    if w_dem <= 0.0:
        raise MetricError("the DEM profile has no shear band of finite width")
    return float(abs(shear_band_width(z, u_model, wall_speed) - w_dem) / w_dem)


def rmse(a: np.ndarray, b: np.ndarray) -> float:
    """Root-mean-square difference."""
    return float(np.sqrt(np.mean((np.asarray(a) - np.asarray(b)) ** 2)))


def resolved(value: np.ndarray, err: np.ndarray) -> np.ndarray:
    """True where ``value`` is finite and above ``RESOLVED_SIGMAS`` times its error (a NaN
    error, or a NaN value such as an undefined microscopic fluidity, is not resolved)."""
    value, err = np.asarray(value, dtype=float), np.asarray(err, dtype=float)
    ok = np.isfinite(value) & np.isfinite(err)
    return np.greater(value, RESOLVED_SIGMAS * np.where(ok, err, 0.0), out=np.zeros(value.shape, dtype=bool), where=ok)


def log_rmse_resolved(model: np.ndarray, dem: np.ndarray, dem_err: np.ndarray) -> float:
    """RMS of log10(model / dem) over the points where the DEM value is positive and resolved
    (above ``RESOLVED_SIGMAS`` errors); inf where the model is not positive there."""
    model, dem, dem_err = (np.asarray(a, dtype=float) for a in (model, dem, dem_err))
    mask = resolved(dem, dem_err)
    if not np.any(mask):
        raise MetricError("no resolved positive DEM points")
    if np.any(~(model[mask] > 0.0)):
        return float("inf")
    return float(np.sqrt(np.mean((np.log10(model[mask]) - np.log10(dem[mask])) ** 2)))
