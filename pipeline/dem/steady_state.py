"""Detect a statistically steady state from wall time series.

A signal is stationary over a window when its linear drift across the window is within a
tolerance plus twice the drift's own statistical uncertainty. The uncertainty comes from the
least-squares slope of *block means* (blocks long compared with the correlation time of the
signal), so that correlated noise is not mistaken for a trend nor a trend for noise.

A force is balanced over a window when its mean equals what it must balance (the top wall's
load) within a tolerance plus twice the mean's block standard error: a body whose mean
acceleration vanishes feels no net mean force.
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
