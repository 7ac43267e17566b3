"""Statistics of correlated series shared by the stages (the DEM stopping rules, the fields' errors,
the scores' checks)."""
from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np
# The distributions' own functions from scipy.special (what scipy.stats evaluates, bit for bit):
# importing scipy.stats costs a process about 0.55 CPU s, paid by every coarse-graining job.
from scipy import special


def integrated_autocorrelation_time(series: np.ndarray, window_factor: float = 5.0) -> np.ndarray:
    """Integrated autocorrelation time (in samples) of each column of ``series`` (time on axis 0),
    ``tau = 1/2 + sum_{k=1}^{M} rho(k)`` with Sokal's self-consistent window (the smallest M with
    M >= window_factor * tau(M)); at least 1/2 (uncorrelated samples). NaN where a column is not finite."""
    n = series.shape[0]
    x = series - series.mean(axis=0)
    spectrum = np.fft.rfft(x, n=2 * n, axis=0)
    acov = np.fft.irfft(spectrum * np.conj(spectrum), axis=0)[:n]
    with np.errstate(invalid="ignore", divide="ignore"):
        rho = acov / acov[:1]
    tau = 0.5 + np.cumsum(rho[1:], axis=0)  # tau(M) for M = 1 .. n-1
    m = np.arange(1, n)[:, None] if series.ndim > 1 else np.arange(1, n)
    shape = (n - 1,) + (1,) * (series.ndim - 1)
    ok = m.reshape(shape) >= window_factor * tau
    first = np.where(ok.any(axis=0), ok.argmax(axis=0), n - 2)
    out = np.take_along_axis(tau, first[None, ...], axis=0)[0]
    return np.where(np.isfinite(out), np.maximum(out, 0.5), np.nan)


def autocorrelated_mean_error(sample: np.ndarray) -> float:
    """Standard error of the mean of a correlated series: its standard deviation times
    sqrt(2 tau / n), tau the integrated autocorrelation time in samples; NaN for 8 samples or fewer."""
    tau = float(integrated_autocorrelation_time(sample[:, None])[0]) if sample.size > 8 else math.nan
    return float(sample.std(ddof=1) * math.sqrt(2.0 * tau / sample.size)) if math.isfinite(tau) else math.nan


def normal_equivalent(t: float, dof: float) -> tuple[float, float]:
    """The normal deviate with the same two-sided probability as Student's ``t`` with ``dof``
    degrees of freedom, signed as ``t``, and that probability: a difference whose errors come from
    few blocks reads as a normal deviate (|t| > 2 is 18 % likely at 2 dof, the result beyond 2 is
    4.55 %). ``(nan, nan)`` where ``dof`` is not finite or below 1."""
    if not (math.isfinite(t) and math.isfinite(dof) and dof >= 1.0):
        return math.nan, math.nan
    p_value = float(2.0 * special.stdtr(dof, -abs(t)))  # Student t survival function at |t|
    return math.copysign(float(-special.ndtri(0.5 * p_value)), t), p_value  # the normal deviate of that tail


def welch_dof(var_a: float, var_b: float, blocks_a: float, blocks_b: float) -> float:
    """Welch-Satterthwaite degrees of freedom of a difference of two batch means whose variances
    ``var_a``, ``var_b`` come from ``blocks_a``, ``blocks_b`` blocks (``blocks - 1`` dof each)."""
    return (var_a + var_b) ** 2 / (var_a ** 2 / (blocks_a - 1.0) + var_b ** 2 / (blocks_b - 1.0))


def chi2_of_deviates(deviates: Iterable[float]) -> dict[str, float]:
    """The mean square of normal deviates (``chi2``, 1 if they are standard normal), in the columns
    of :func:`pooled_chi2`: one degree of freedom a deviate, ``chi2_err = sqrt(2 / dof)``, the
    two-sided chi-squared probability of a departure from 1 at least as large; ``replicas`` is the
    caller's to say."""
    z = np.asarray([v for v in deviates if math.isfinite(v)], dtype=float)
    if z.size == 0:
        return dict(NO_CHECK)
    return chi2_row(float(np.sum(z ** 2)), int(z.size), pairs=int(z.size), points=int(z.size), replicas=math.nan)


def independent_points(points: int, tau: float) -> float:
    """Independent points of ``points`` correlated along a profile with integrated autocorrelation
    time ``tau`` (in points): ``points / (2 tau)``, between one and ``points``."""
    return float(np.clip(points / (2.0 * tau), 1.0, points))


def chi2_row(total: float, dof: float, **counts: float) -> dict[str, float]:
    """The check's row from a chi-squared ``total`` over ``dof`` degrees of freedom (not
    necessarily whole: correlated points count as :func:`independent_points`)."""
    chi2, chi2_err = total / dof, math.sqrt(2.0 / dof)
    cdf = float(special.chdtr(dof, total))  # chi-squared distribution function
    return {"chi2": chi2, "chi2_err": chi2_err, **counts, "dof": float(dof),
            "p_value": float(min(1.0, 2.0 * min(cdf, 1.0 - cdf))), "correlation_points": math.nan,
            "error_scale": error_scale(chi2, chi2_err)}


#: The row of a check with nothing to check (fewer than two values in every group).
NO_CHECK: dict[str, float] = {"chi2": math.nan, "chi2_err": math.nan, "pairs": 0, "points": 0, "replicas": 0,
                              "dof": math.nan, "p_value": math.nan, "correlation_points": math.nan,
                              "error_scale": math.nan}


def error_scale(chi2: float, chi2_err: float) -> float:
    """``sqrt(chi2)`` where it departs from 1 by more than twice its error, else 1 (NaN: no check)."""
    if not (math.isfinite(chi2) and math.isfinite(chi2_err)):
        return math.nan
    return math.sqrt(chi2) if abs(chi2 - 1.0) > 2.0 * chi2_err else 1.0


def pooled_chi2(groups: Iterable[tuple[np.ndarray, np.ndarray]]) -> dict[str, float]:
    """The pooled replica chi2 of ``groups`` of (values, stated errors) (module docstring)."""
    total, dof, points, pairs, replicas = 0.0, 0, 0, 0, 0
    for values, errors in groups:
        values, errors = np.asarray(values, dtype=float), np.asarray(errors, dtype=float)
        ok = np.isfinite(values) & np.isfinite(errors) & (errors > 0)
        values, errors = values[ok], errors[ok]
        if values.size < 2:
            continue
        w = 1.0 / errors**2
        mean = float(np.sum(w * values) / np.sum(w))
        total += float(np.sum(((values - mean) / errors) ** 2))
        dof += values.size - 1
        points += 1
        pairs += values.size * (values.size - 1) // 2
        replicas = max(replicas, values.size)
    if dof == 0:
        return dict(NO_CHECK) | {"points": points, "replicas": replicas}
    return chi2_row(total, dof, pairs=pairs, points=points, replicas=replicas)
