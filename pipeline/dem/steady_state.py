"""Detect a statistically steady state from wall time series.

A signal is stationary over a window when its linear drift across the window is within a
tolerance plus twice the drift's own statistical uncertainty. The uncertainty comes from the
least-squares slope of *block means* (blocks long compared with the correlation time of the
signal), so that correlated noise is not mistaken for a trend nor a trend for noise.

A force is balanced over a window when its mean equals what it must balance (the top wall's
load) within a tolerance plus twice the mean's block standard error: a body whose mean
acceleration vanishes feels no net mean force.

Creep is settled when its speed in each depth band, over the window, agrees with its speed over
as many chunks before, within a tolerance in decades plus twice the difference's error
(:func:`creep_settled`): far below the shear band the bed creeps by a fraction of a grain per
strain unit, and its start-up transient outlasts the wall's by strain units (2-3 times faster
creep at 6-12 d in a production's first half than in its second, before this test).
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from pipeline.dem.precision import standard_error


@dataclass(frozen=True)
class DriftTest:
    """Outcome of a drift test on one signal over a window.

    Attributes:
        mean: mean of the signal over the window.
        drift: fitted change of the signal across the window (slope times window length).
        drift_err: standard error of ``drift`` from the block means.
        allowed: tolerance the drift was held to (``tol * scale + 2 * drift_err``).
        stationary: ``abs(drift) <= allowed``.
    """

    mean: float
    drift: float
    drift_err: float
    allowed: float
    stationary: bool

    def as_dict(self) -> dict[str, float | bool]:
        return asdict(self)


def drift_test(time: np.ndarray, signal: np.ndarray, tol: float, scale: float, n_blocks: int = 8) -> DriftTest:
    """Test ``signal(time)`` for a linear drift larger than ``tol * scale``.

    Args:
        time: sample times (s), increasing.
        signal: samples of the signal.
        tol: allowed drift as a fraction of ``scale``.
        scale: magnitude the tolerance refers to (e.g. the mean wall force, the layer depth).
        n_blocks: number of consecutive blocks averaged before fitting the trend.
    """
    time = np.asarray(time, dtype=float)
    signal = np.asarray(signal, dtype=float)
    if time.shape != signal.shape or time.ndim != 1:
        raise ValueError("time and signal must be 1D arrays of the same length")
    if time.size < 2 * n_blocks:
        raise ValueError(f"need at least {2 * n_blocks} samples to test a drift with {n_blocks} blocks, got {time.size}")
    blocks_t = np.array([b.mean() for b in np.array_split(time, n_blocks)])
    blocks_y = np.array([b.mean() for b in np.array_split(signal, n_blocks)])
    slope, intercept = np.polyfit(blocks_t, blocks_y, 1)
    residual = blocks_y - (slope * blocks_t + intercept)
    sxx = np.sum((blocks_t - blocks_t.mean()) ** 2)
    slope_err = np.sqrt(np.sum(residual**2) / (n_blocks - 2) / sxx)
    length = time[-1] - time[0]
    drift, drift_err = slope * length, slope_err * length
    allowed = tol * abs(scale) + 2.0 * drift_err
    return DriftTest(float(signal.mean()), float(drift), float(drift_err), float(allowed), bool(abs(drift) <= allowed))


@dataclass(frozen=True)
class BalanceTest:
    """Outcome of a balance test of one force over a window.

    Attributes:
        mean: mean of the force over the window (N).
        target: the force it must balance (N).
        mean_err: standard error of ``mean`` from the block means (N).
        allowed: tolerance the difference was held to (``tol * |target| + 2 * mean_err``).
        ratio: ``mean / target``.
        balanced: ``abs(mean - target) <= allowed``.
    """

    mean: float
    target: float
    mean_err: float
    allowed: float
    ratio: float
    balanced: bool

    def as_dict(self) -> dict[str, float | bool]:
        return asdict(self)


def balance_test(signal: np.ndarray, target: float, tol: float, n_blocks: int = 8) -> BalanceTest:
    """Test that the mean of ``signal`` equals ``target`` within ``tol * |target|`` plus twice the
    block standard error of the mean.

    Args:
        signal: samples of a force (N), equally spaced in time.
        target: the force the mean must equal (N), non-zero.
        tol: allowed difference as a fraction of ``|target|``.
        n_blocks: number of consecutive blocks whose means give the standard error.
    """
    signal = np.asarray(signal, dtype=float)
    if signal.ndim != 1 or signal.size < 2 * n_blocks:
        raise ValueError(f"need a 1D series of at least {2 * n_blocks} samples for {n_blocks} blocks, got shape {signal.shape}")
    if target == 0:
        raise ValueError("the target force must be non-zero")
    blocks = np.array([b.mean() for b in np.array_split(signal, n_blocks)])
    mean = float(signal.mean())
    err = float(standard_error(blocks))
    allowed = tol * abs(target) + 2.0 * err
    return BalanceTest(mean, float(target), err, float(allowed), mean / target, bool(abs(mean - target) <= allowed))


def band_speeds(u_over_v: np.ndarray, depth: np.ndarray, d: float, bands_over_d: tuple[float, ...]
                ) -> tuple[np.ndarray, list[tuple[float, float]]]:
    """Per-chunk mean creep speed (over V) in depth bands: ``u_over_v`` (chunks, bins) binned at
    ``depth`` (m below the top wall); bands between consecutive edges of ``bands_over_d`` (in d)."""
    edges = list(zip(bands_over_d[:-1], bands_over_d[1:]))
    out = np.full((u_over_v.shape[0], len(edges)), np.nan)
    for k, (a, b) in enumerate(edges):
        inside = (depth >= a * d) & (depth < b * d)
        if inside.any():
            with np.errstate(invalid="ignore"):
                out[:, k] = np.nanmean(u_over_v[:, inside], axis=1)
    return out, edges


def creep_settled(before: np.ndarray, now: np.ndarray, edges: list[tuple[float, float]], tol_decades: float,
                  creep_below: float = 0.1) -> dict:
    """Whether the creep of the window ``now`` (chunks, bands: speeds over V) agrees with the
    window ``before``: in every band where both windows' mean speed is below ``creep_below`` V (the
    creep, not the band) and resolved (above twice the chunk-scatter standard error), the log10 ratio
    is within ``tol_decades`` plus twice its error. Returns the per-band record and ``stationary``."""
    bands, stationary = [], True
    for k, (a, b) in enumerate(edges):
        if not (np.isfinite(before[:, k]).any() and np.isfinite(now[:, k]).any()):
            bands.append({"depth_over_d": [a, b], "resolved": False})
            continue
        mean_b, mean_n = float(np.nanmean(before[:, k])), float(np.nanmean(now[:, k]))
        err_b, err_n = float(standard_error(before[:, k:k + 1])[0]), float(standard_error(now[:, k:k + 1])[0])
        resolved = all(np.isfinite(x) for x in (mean_b, mean_n, err_b, err_n)) and mean_b > 2 * err_b and mean_n > 2 * err_n
        row = {"depth_over_d": [a, b], "before": mean_b, "before_err": err_b, "now": mean_n, "now_err": err_n,
               "resolved": bool(resolved)}
        if resolved and max(mean_b, mean_n) < creep_below:
            change = float(np.log10(mean_n / mean_b))
            change_err = float(np.hypot(err_n / mean_n, err_b / mean_b) / np.log(10.0))
            allowed = tol_decades + 2.0 * change_err
            row |= {"log10_change": change, "log10_change_err": change_err, "allowed": allowed,
                    "settled": bool(abs(change) <= allowed)}
            stationary &= row["settled"]
        bands.append(row)
    tested = [r for r in bands if "settled" in r]
    return {"bands": bands, "tested": len(tested), "tol_decades": tol_decades, "stationary": bool(stationary and tested)}
