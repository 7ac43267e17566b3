"""What a fields file measures, as the calibration and the scores compare it with the models.

One definition each, shared by every stage that reads fields:
- the creep speed: the snapshot-averaged ``u_x`` or the displacement-based ``u_x_disp``
  (:mod:`pipeline.coarse_graining.displacement`), whichever has the smaller standard error at
  each height. Both estimate the same mean velocity; deep in the creeping zone only the
  displacements resolve it.
- the stress ratio ``mu = |sigma_xz| / p`` (p one third of the trace), as in the fields files;
  the models' p is sigma_zz over the rheometer's sigma_zz / p (:mod:`continuum.geometry`).
"""
from __future__ import annotations

import math

import numpy as np
import xarray as xr

#: log10 error floor (decades) of a creep point in the non-local fits and the decay lengths: the
#: replica-to-replica spread of log10 u_x in the default run is about 0.1 decade, so a point
#: whose stated error is smaller (the fast shear band) does not weigh more than that.
LOG_SPEED_ERROR_FLOOR = 0.1


def creep_speed(ds: xr.Dataset) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mean velocity along x (m s-1), its standard error, and True where it is ``u_x_disp``."""
    u, err = ds["u_x"].values, ds["u_x_err"].values
    if "u_x_disp" not in ds:
        return u, err, np.zeros(u.shape, dtype=bool)
    ud, ed = ds["u_x_disp"].values, ds["u_x_disp_err"].values
    use = np.isfinite(ud) & np.isfinite(ed) & (~np.isfinite(err) | (ed < err))
    return np.where(use, ud, u), np.where(use, ed, err), use


#: The halves of a production window whose creep a fields file carries (``u_x_disp_<half>_half``).
HALVES = ("first", "second")


def has_halves(ds: xr.Dataset) -> bool:
    """Whether ``ds`` carries the displacement creep of both halves of its window."""
    return all(f"u_x_disp_{half}_half" in ds and f"u_x_disp_{half}_half_err" in ds for half in HALVES)


def creep_half(ds: xr.Dataset, half: str) -> xr.Dataset:
    """``ds`` with its displacement creep speed ``u_x_disp`` (and error) over one ``half`` of the
    window ("first" or "second", :func:`pipeline.coarse_graining.fields.add_half_windows`) in place
    of the whole window's: the creep at an earlier or later age of the same run. The half's time
    error is floored at the whole window's structural error (the frozen packing, common to both
    halves), so a half is no more precise than the packing allows."""
    if half not in HALVES:
        raise ValueError(f"half must be one of {HALVES}, got {half!r}")
    u, err = ds[f"u_x_disp_{half}_half"].values, ds[f"u_x_disp_{half}_half_err"].values
    total = np.fmax(err, ds["u_x_disp_err_structure"].values) if "u_x_disp_err_structure" in ds else err
    out = ds.copy()
    out["u_x_disp"] = ("z", u, dict(ds["u_x_disp"].attrs))
    out["u_x_disp_err"] = ("z", total, dict(ds["u_x_disp_err"].attrs))
    if "u_x_disp_err_time" in ds:
        out["u_x_disp_err_time"] = ("z", err, dict(ds["u_x_disp_err_time"].attrs))
    out.attrs["creep_from_half_window"] = half
    return out


def log_speed_error(u: np.ndarray, err: np.ndarray) -> np.ndarray:
    """Standard error of log10 u (decades), floored at :data:`LOG_SPEED_ERROR_FLOOR`."""
    with np.errstate(divide="ignore", invalid="ignore"):
        raw = err / (np.abs(u) * np.log(10.0))
    return np.maximum(np.where(np.isfinite(raw), raw, np.inf), LOG_SPEED_ERROR_FLOOR)


def walk_order(u: np.ndarray) -> np.ndarray:
    """The indices of a creep profile from its fastest point towards its slower end (the side
    whose far end is slower), fastest first; empty when no point is finite."""
    u = np.asarray(u, dtype=float)
    finite = np.isfinite(u)
    if not finite.any():
        return np.array([], dtype=int)
    top = int(np.nanargmax(np.where(finite, u, -np.inf)))
    left, right = u[:top + 1][::-1], u[top:]
    side = -1 if np.nanmin(left) < np.nanmin(right) else 1
    return np.arange(top, -1, -1) if side < 0 else np.arange(top, u.size)


def resolved_walk(u: np.ndarray, err: np.ndarray) -> tuple[int, np.ndarray, int]:
    """The walk of :func:`decades_resolved`: the fastest point's index, the indices walked from it
    towards the slower end that are resolved (above 2 standard errors, in walking order), and the
    first index that is not (-1 when the walk reaches the profile's end)."""
    u = np.asarray(u, dtype=float)
    err = np.asarray(err, dtype=float)
    order = walk_order(u)
    if order.size == 0:
        return -1, order, -1
    top = int(order[0])
    resolved = np.isfinite(u[order]) & np.isfinite(err[order]) & (u[order] > 2.0 * err[order])
    stop = int(np.argmin(resolved)) if not resolved.all() else order.size
    return top, order[:stop], int(order[stop]) if stop < order.size else -1


def decades_resolved(u: np.ndarray, err: np.ndarray, wall_speed: float) -> tuple[float, float]:
    """Decades of u / V resolved above 2 standard errors, and the slowest resolved u / V.

    The profile is walked from its fastest point away from the moving wall (``u`` ordered from the
    top wall down, or any order: the walk goes down the indices' direction away from the maximum
    towards the slower side); the stretch ends at the first point with ``u <= 2 err`` (or no
    error), so a noise spike deeper down does not count. Returns ``(log10(u_max / u_min), u_min /
    V)``; ``(0, nan)`` when nothing is resolved.
    """
    u = np.asarray(u, dtype=float)
    top, walked, _ = resolved_walk(u, err)
    return resolution(u, top, walked, wall_speed)


def resolution(u: np.ndarray, top: int, walked: np.ndarray, wall_speed: float) -> tuple[float, float]:
    """:func:`decades_resolved` from a walk already made (:func:`resolved_walk`)."""
    if walked.size == 0:
        return 0.0, float("nan")
    slowest = float(np.min(np.asarray(u, dtype=float)[walked]))
    return float(math.log10(u[top] / slowest)), slowest / wall_speed


def replica_mean(depth: np.ndarray, replicas: list[tuple[np.ndarray, np.ndarray, np.ndarray]]
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Mean of replica profiles at ``depth`` (m below the top wall) and its error.

    ``replicas``: each replica's ``(depth, value, error)``, interpolated onto ``depth`` (NaN
    beyond its own range: the replicas' walls differ slightly). The error is the larger of the
    combined stated errors and the replicas' scatter over sqrt(n) (replicas differ by more than
    their stated errors where the packing's structure is frozen, or their random rough walls
    differ): :func:`replica_mean_parts`."""
    mean, stated, scatter = replica_mean_parts(depth, replicas)
    return mean, np.fmax(stated, scatter)


def replica_mean_parts(depth: np.ndarray, replicas: list[tuple[np.ndarray, np.ndarray, np.ndarray]]
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`replica_mean`'s mean and its two errors apart: the combined stated errors
    ``sqrt(sum err_r^2) / n`` (the time average's, falling with the production's length) and the
    replicas' scatter ``sd / sqrt(n)`` (falling with their number only)."""
    values, errors = [], []
    for own, value, error in replicas:
        order = np.argsort(own)
        values.append(np.interp(depth, own[order], value[order], left=np.nan, right=np.nan))
        errors.append(np.interp(depth, own[order], error[order], left=np.nan, right=np.nan))
    values, errors = np.array(values), np.array(errors)
    n = values.shape[0]
    return values.mean(axis=0), np.sqrt(np.sum(errors**2, axis=0)) / n, values.std(axis=0, ddof=1) / math.sqrt(n)
