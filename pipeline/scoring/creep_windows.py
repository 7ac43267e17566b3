"""The creep windows of a planar run and their decay rates, under two selection rules.

A window is ``WINDOW_OVER_D`` d of depth below the top contact plane (counted from the scores'
margin); its decay rate k = d ln u / dz (m-1, z up, positive where u falls away from the moving
wall). Two rules choose the windows and fit k (:data:`RULES`):

- ``resolved`` (the workflow's, :func:`creep_windows` and :func:`window_slope`): from the band's
  edge (u < ``CREEP_FRACTION`` V) down to the last window whose every point is resolved (above
  twice its error; the walk stops at the first that is not), k from a weighted straight-line fit
  of ln u on z. It conditions on resolution: at depth only windows whose noise happened to lift
  them above 2 sigma enter, the bias issue 44 asks about.
- ``fixed_depth`` (:func:`fixed_windows` and :func:`likelihood_slope`): the same windows, fixed
  in depth from the band's edge down to the bottom margin whatever the points' resolution; k
  fitted to u itself (Gaussian errors in u, so unresolved and negative points are points like
  any other), its error from the likelihood; a window that bounds no slope weighs nothing.
"""
from __future__ import annotations

import math

import numpy as np

#: Creep: speeds below this fraction of the wall speed (the shear band above is not creep).
CREEP_FRACTION = 0.1


def window_slope(z: np.ndarray, u: np.ndarray, err: np.ndarray | None) -> tuple[float, float]:
    """Slope of ln u on z (m-1) and its error from the points' errors (0 for an exact profile)."""
    y = np.log(u)
    if err is None:
        return float(np.polyfit(z, y, 1)[0]), 0.0
    sigma = err / u
    coef, cov = np.polyfit(z, y, 1, w=1.0 / sigma, cov="unscaled")
    return float(coef[0]), float(math.sqrt(cov[0, 0]))


def creep_windows(depth: np.ndarray, u: np.ndarray, err: np.ndarray | None, wall_speed: float, width: float,
                  lo: float, hi: float) -> list[tuple[int, np.ndarray]]:
    """(window index, point indices) of the resolved creep windows between depths ``lo`` and ``hi``
    (m below the top plane): windows of ``width`` counted from ``lo``, from the first below the band
    down to the last resolved one (the walk stops at the first window not resolved)."""
    out = []
    started = False
    for k, a in enumerate(np.arange(lo, hi - 0.5 * width, width)):
        idx = np.nonzero((depth >= a) & (depth < a + width))[0]
        if idx.size < 3:
            continue
        uu = u[idx]
        if not np.all(np.isfinite(uu)) or np.any(uu >= CREEP_FRACTION * wall_speed):
            if started:
                break
            continue
        if err is not None and (not np.all(np.isfinite(err[idx])) or np.any(uu <= 2.0 * err[idx])):
            break
        if np.any(uu <= 0):
            break
        started = True
        out.append((k, idx))
    return out


def fixed_windows(depth: np.ndarray, u: np.ndarray, wall_speed: float, width: float, lo: float, hi: float
                  ) -> list[tuple[int, np.ndarray]]:
    """(window index, point indices) of the creep windows of the ``fixed_depth`` rule: the same
    windows of ``width`` counted from ``lo`` as :func:`creep_windows`, from the first below the band
    (u < ``CREEP_FRACTION`` V at every point) down to ``hi``, whatever the points' resolution: a
    window whose creep is below its noise stays in, with the error its likelihood gives it."""
    out = []
    started = False
    for k, a in enumerate(np.arange(lo, hi - 0.5 * width, width)):
        idx = np.nonzero((depth >= a) & (depth < a + width))[0]
        if idx.size < 3 or not np.all(np.isfinite(u[idx])):
            continue
        if not started and np.any(u[idx] >= CREEP_FRACTION * wall_speed):
            continue
        started = True
        out.append((k, idx))
    return out


#: The ``fixed_depth`` rule's slopes are searched over k d in this range (a window that does not
#: bound its slope inside it gets the range's half width as its error: it weighs nothing), first
#: on a coarse grid, then on a fine one around the coarse interval.
SLOPE_RANGE_D = (-30.0, 30.0)
_COARSE_STEP_D, _FINE_STEP_D = 0.1, 0.005


def _profile_chi2(k: np.ndarray, z: np.ndarray, u: np.ndarray, w: np.ndarray) -> np.ndarray:
    """chi2 of ``u = A exp(k z)`` at each k (m-1) with A at its best (closed form)."""
    shape = np.exp(np.outer(k, z))
    a = (shape * u * w).sum(axis=1) / (shape**2 * w).sum(axis=1)
    return ((u - a[:, None] * shape) ** 2 * w).sum(axis=1)


def likelihood_slope(z: np.ndarray, u: np.ndarray, err: np.ndarray, d: float) -> tuple[float, float, bool]:
    """Decay rate k (m-1) of ``u = A exp(k (z - z_mean))`` fitted to the points in u itself, with
    their errors (Gaussian in u, so a point below its noise, or negative, is a point like any
    other): A is profiled out in closed form, k is the chi2 minimum over k d in
    :data:`SLOPE_RANGE_D`, its error half the width of the delta chi2 = 1 interval. Returns
    (k, error, bounded); an interval reaching the range's ends is not bounded, its error the range's
    half width (no information, no weight)."""
    w = 1.0 / np.asarray(err, dtype=float) ** 2
    zc = (z - z.mean()) / d
    coarse = np.arange(SLOPE_RANGE_D[0], SLOPE_RANGE_D[1] + 0.5 * _COARSE_STEP_D, _COARSE_STEP_D)
    chi2 = _profile_chi2(coarse, zc, u, w)
    best = int(np.argmin(chi2))
    inside = np.nonzero(chi2 <= chi2[best] + 1.0)[0]
    if inside.min() == 0 or inside.max() == coarse.size - 1:
        return float(coarse[best] / d), 0.5 * (SLOPE_RANGE_D[1] - SLOPE_RANGE_D[0]) / d, False
    fine = np.arange(coarse[inside.min() - 1], coarse[inside.max() + 1] + 0.5 * _FINE_STEP_D, _FINE_STEP_D)
    chi2 = _profile_chi2(fine, zc, u, w)
    best = int(np.argmin(chi2))
    inside = np.nonzero(chi2 <= chi2[best] + 1.0)[0]
    half = max(0.5 * (fine[inside.max()] - fine[inside.min()]), _FINE_STEP_D)
    return float(fine[best] / d), float(half / d), True


#: The window selection rules: ``resolved`` (the workflow's: every point above twice its error,
#: the walk stops at the first unresolved window; slopes of ln u) and ``fixed_depth`` (windows
#: fixed in depth down to the bottom margin, unresolved points kept; slopes fitted in u).
RULES = ("resolved", "fixed_depth")
