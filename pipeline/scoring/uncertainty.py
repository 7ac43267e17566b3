"""The uncertainty of a score, in the manner of ASME V&V 20: ``u_dem``, ``u_input``, ``u_num``, ``u_val``.

A score S compares a model's prediction with the mean of the DEM replicas. Three independent
sources move it, each estimated by recomputing S with one input changed and the others nominal:

- ``u_dem``: the DEM mean's own uncertainty. The replica mean is resampled ``B`` times (parametric):
  ``mean + s * err * epsilon(z)``, ``err`` the mean's stated standard error (the replicas' block
  errors combined), ``epsilon`` a unit Gaussian process along z with the correlation the replicas'
  standardised residuals show (an AR(1) whose integrated autocorrelation time is the one
  :func:`pipeline.scoring.error_check.replica_chi2` measures: points share grains through the
  kernel, and a load-controlled wall moves a whole profile), and ``s = sqrt(chi2)``, the replica
  scatter over the stated errors, where chi2 exceeds 1 by more than twice its own error (else 1:
  never below, since replicas that agree better than their errors do so through a few
  realisations' offsets, which the chi2's point-counted degrees of freedom overstate). Log-compared variables (creep speed, fluidity) are resampled in log where resolved. Its degrees
  of freedom are the chi2's, ``(n - 1)`` times the independent points. The intruder's rod speeds are
  resampled per depth from the replicas' pooled scatter of log10 U (their stated errors are 5-7x too
  small for an intermittent creep), with ``sum_depths (n_d - 1)`` degrees of freedom. A profile's
  replicas may also differ by a whole-profile offset beyond what that model predicts (a denser
  packing, a freer creep): its excess variance (:func:`offset_noise`) is resampled as a uniform
  shift, a part of ``u_dem`` with n - 1 degrees of freedom of its own.
- ``u_input``: the calibration's. S for each parameter draw (:mod:`pipeline.calibration.draws`,
  solved by pipeline.models) against the nominal DEM mean; K - 1 degrees of freedom.
- ``u_num``: the grid's. ``|S(n_grid) - S(refined)|``, the refined grid having half the spacing
  (planar) or twice the cells per d (intruder); a first-order estimate taken as a standard
  uncertainty with infinite degrees of freedom.

``u_val = sqrt(u_dem^2 + u_input^2 + u_num^2)``; its effective degrees of freedom come from the
Welch-Satterthwaite formula (V&V 20, section 7), and intervals use Student's t with them.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import xarray as xr
from scipy import stats

from pipeline.scoring.error_check import replica_chi2

#: Variables whose scores compare logarithms: resampled in log where resolved (above 2 errors).
LOG_RESAMPLED = ("u_creep", "fluidity", "fluidity_micro")


@dataclass(frozen=True)
class DemNoise:
    """How one DEM variable of a case is resampled: the error scale ``s``, the correlation of the
    noise along z (integrated autocorrelation time ``tau`` in points, 1/2 for white noise), the
    degrees of freedom of that error model, and the chi2 it came from (NaN with one replica)."""

    scale: float
    tau: float
    dof: float
    chi2: float = math.nan
    chi2_err: float = math.nan


def dem_noise_model(reps: list[xr.Dataset], variable: str) -> DemNoise:
    """The replicas' verdict on their stated errors for ``variable`` (module docstring)."""
    if len(reps) < 2:
        return DemNoise(1.0, 0.5, math.inf)
    check = replica_chi2(reps, variable)
    chi2, chi2_err = check["chi2"], check["chi2_err"]
    if not (math.isfinite(chi2) and math.isfinite(chi2_err)):
        return DemNoise(1.0, 0.5, math.inf)
    # Only up: replicas that agree better than their stated errors (chi2 < 1) do so mostly through
    # a few realisations' offsets, which the chi2's point-counted degrees of freedom overstate; the
    # stated errors then stand (validation/error_check.csv still records the scale down).
    scale = math.sqrt(chi2) if chi2 - 1.0 > 2.0 * chi2_err else 1.0
    tau = float(check["correlation_points"]) if math.isfinite(check["correlation_points"]) else 0.5
    return DemNoise(scale, max(tau, 0.5), float(check["dof"]), chi2, chi2_err)


def correlated_normal(rng: np.random.Generator, n_samples: int, n_points: int, tau: float) -> np.ndarray:
    """Unit-variance Gaussian noise (samples, points), AR(1) along the points with integrated
    autocorrelation time ``tau`` (``tau = 1/2 + phi / (1 - phi)``, so ``phi = (2 tau - 1) / (2 tau + 1)``)."""
    phi = (2.0 * tau - 1.0) / (2.0 * tau + 1.0)
    eta = rng.standard_normal((n_samples, n_points))
    out = np.empty_like(eta)
    out[:, 0] = eta[:, 0]
    innovation = math.sqrt(max(1.0 - phi * phi, 0.0))
    for i in range(1, n_points):
        out[:, i] = phi * out[:, i - 1] + innovation * eta[:, i]
    return out


def resample_profile(mean: np.ndarray, err: np.ndarray, noise: DemNoise, n_samples: int, rng: np.random.Generator,
                     log: bool) -> np.ndarray:
    """``n_samples`` resamples (samples, points) of a replica-mean profile (module docstring)."""
    eps = correlated_normal(rng, n_samples, mean.size, noise.tau)
    sigma = noise.scale * np.where(np.isfinite(err), err, 0.0)
    linear = mean[None, :] + sigma[None, :] * eps
    if not log:
        return linear
    with np.errstate(divide="ignore", invalid="ignore"):
        resolved = np.isfinite(mean) & (mean > 2.0 * np.where(np.isfinite(err), err, np.inf))
        relative = np.where(resolved, sigma / np.where(resolved, mean, 1.0), 0.0)
        logged = mean[None, :] * np.exp(relative[None, :] * eps)  # symmetric in log: the scores compare logs
    return np.where(resolved[None, :], logged, linear)


@dataclass(frozen=True)
class OffsetNoise:
    """A whole-profile offset between replicas beyond what the error model predicts: the variance
    (per replica; in log for log-resampled variables) of the replicas' mean deviations from their
    mean over the scored points, less the part the pointwise model explains, and its degrees of
    freedom (n - 1)."""

    variance: float
    dof: float
    observed: float = math.nan
    predicted: float = math.nan


def offset_noise(values: np.ndarray, errors: np.ndarray, noise: DemNoise, log: bool) -> OffsetNoise:
    """The replicas' extra offset (``values``, ``errors``: replicas x points of the scored points).

    A packing realisation shifts a whole profile (a denser replica has a higher nu everywhere, a
    freer one a faster creep at every depth); the pointwise model with its short correlation
    averages such shifts down by the number of independent points. With n >= 2 replicas the sample
    variance of their mean deviations estimates the single replica's offset variance; the pointwise
    model predicts ``mean(s^2 err^2) 2 tau / N`` of it; the excess, if any, is the extra offset.
    """
    n = values.shape[0]
    if n < 2:
        return OffsetNoise(0.0, math.inf)
    with np.errstate(divide="ignore", invalid="ignore"):
        if log:
            ok = np.all((values > 2.0 * errors) & np.isfinite(values) & np.isfinite(errors), axis=0)
            x, sig = np.log(values[:, ok]), errors[:, ok] / values[:, ok]
        else:
            ok = np.all(np.isfinite(values) & np.isfinite(errors), axis=0)
            x, sig = values[:, ok], errors[:, ok]
    if x.shape[1] < 2:
        return OffsetNoise(0.0, math.inf)
    offsets = (x - x.mean(axis=0)).mean(axis=1)
    observed = float(np.sum(offsets**2) / (n - 1))
    predicted = float(np.mean((noise.scale * sig) ** 2) * min(2.0 * noise.tau / x.shape[1], 1.0))
    # Only an excess the replicas show at 95 % (their offsets' variance against chi2 with n - 1 dof):
    # an estimate from 2-3 replicas would otherwise add a noisy, low-dof part to every score.
    if observed <= predicted * float(stats.chi2.ppf(0.95, n - 1)) / (n - 1):
        return OffsetNoise(0.0, float(n - 1), observed, predicted)
    return OffsetNoise(observed - predicted, float(n - 1), observed, predicted)


def offset_profiles(mean: np.ndarray, err: np.ndarray, offset: OffsetNoise, n_replicas: int, n_samples: int,
                    rng: np.random.Generator, log: bool) -> np.ndarray:
    """Resamples of the replica mean shifted as a whole by the extra offset (its variance over n)."""
    shift = rng.standard_normal(n_samples) * math.sqrt(offset.variance / max(n_replicas, 1))
    if not log:
        return mean[None, :] + shift[:, None]
    with np.errstate(invalid="ignore"):
        resolved = np.isfinite(mean) & (mean > 2.0 * np.where(np.isfinite(err), err, np.inf))
    return np.where(resolved[None, :], mean[None, :] * np.exp(shift[:, None]), mean[None, :])


@dataclass(frozen=True)
class RodNoise:
    """The intruder's DEM noise: the pooled standard deviation of log10 U between replicas at one
    depth, its degrees of freedom, and where it came from."""

    log_sd: float
    dof: float
    source: str


def rod_noise(by_depth: dict[float, list[float]], stated: dict[float, list[float]]) -> RodNoise:
    """Pooled replica scatter of log10 U over the depths (``by_depth``: moving rods' speeds); with
    one replica per depth, the stated errors (``stated``: their speed errors), which understate it."""
    sums, dof = 0.0, 0
    for speeds in by_depth.values():
        logs = np.log10([s for s in speeds if s > 0])
        if logs.size >= 2:
            sums += float(np.sum((logs - logs.mean()) ** 2))
            dof += logs.size - 1
    if dof >= 1:
        return RodNoise(math.sqrt(sums / dof), float(dof), f"replica scatter, {dof} degrees of freedom")
    rel = [e / s for d, speeds in by_depth.items() for s, e in zip(speeds, stated.get(d, [])) if s > 0]
    sd = float(np.sqrt(np.mean(np.square(rel)))) / math.log(10.0) if rel else math.nan
    return RodNoise(sd, math.inf, "stated errors (one replica per depth: no scatter measured)")


@dataclass
class ScoreSamples:
    """One score and its resamples: ``value`` (nominal), ``dem`` (B DEM resamples, nominal
    parameters), ``draws`` (K parameter draws, nominal DEM; NaN where a draw has no solution),
    ``refined`` (the refined grid) and the DEM's degrees of freedom. For scores that are an RMS over
    points that models may cover differently (the intruder's depths), ``terms_*`` hold the per-point
    terms (last axis: the points ``points``) so that two models can be scored on their shared points."""

    value: float
    dem: np.ndarray
    draws: np.ndarray
    refined: float
    dem_dof: float
    points: list[str] = field(default_factory=list)
    terms_value: np.ndarray | None = None
    terms_dem: np.ndarray | None = None
    terms_draws: np.ndarray | None = None
    terms_refined: np.ndarray | None = None
    #: The score over resamples of the replicas' extra whole-profile offset (:class:`OffsetNoise`).
    dem_offset: np.ndarray = field(default_factory=lambda: np.array([]))
    offset_dof: float = math.inf

    @property
    def u_dem(self) -> float:
        return rss(finite_sd(self.dem), finite_sd(self.dem_offset))

    @property
    def u_input(self) -> float:
        return finite_sd(self.draws)

    @property
    def u_num(self) -> float:
        """``|S(refined) - S|``; NaN where the refined grid gave no score (its solve failed, or the
        score is infinite): unknown, and shown so in scores.csv, not taken as zero there."""
        if not (math.isfinite(self.value) and math.isfinite(self.refined)):
            return math.nan
        return abs(self.refined - self.value)

    @property
    def u_val(self) -> float:
        return rss(self.u_dem, self.u_input, self.u_num)

    @property
    def draws_finite_fraction(self) -> float:
        return float(np.isfinite(self.draws).mean()) if self.draws.size else math.nan

    def on_points(self, keep: list[str]) -> ScoreSamples:
        """The same score recomputed as the RMS of its terms on the points ``keep`` only."""
        if self.terms_value is None:
            return self
        index = [self.points.index(p) for p in keep]

        def rms(t: np.ndarray) -> np.ndarray | float:
            sub = t[..., index]
            with np.errstate(invalid="ignore"):
                out = np.sqrt(np.mean(np.square(sub), axis=-1))
            return out if np.ndim(out) else float(out)

        return ScoreSamples(float(rms(self.terms_value)), np.asarray(rms(self.terms_dem)),
                            np.asarray(rms(self.terms_draws)), float(rms(self.terms_refined)), self.dem_dof,
                            list(keep), self.terms_value[index], self.terms_dem[:, index],
                            self.terms_draws[:, index], self.terms_refined[index])


def finite_sd(x: np.ndarray) -> float:
    """Standard deviation of the finite values (NaN with fewer than two)."""
    x = np.asarray(x, dtype=float)
    x = x[np.isfinite(x)]
    return float(x.std(ddof=1)) if x.size >= 2 else math.nan


def rss(*parts: float) -> float:
    """Root sum of squares of the finite parts (NaN if none is finite)."""
    finite = [p for p in parts if math.isfinite(p)]
    return float(math.sqrt(sum(p * p for p in finite))) if finite else math.nan


def welch_satterthwaite(parts: list[tuple[float, float]]) -> float:
    """Effective degrees of freedom of a sum of variances ``[(u_i, dof_i)]`` (inf dof allowed)."""
    total = sum(u * u for u, _ in parts if math.isfinite(u))
    denominator = sum(u**4 / nu for u, nu in parts if math.isfinite(u) and math.isfinite(nu) and nu > 0 and u > 0)
    if total == 0.0:
        return math.inf
    return math.inf if denominator == 0.0 else total * total / denominator


def coverage_factor(dof: float, confidence: float) -> float:
    """Student's t quantile for a two-sided interval of ``confidence`` with ``dof`` degrees of freedom."""
    q = 0.5 + 0.5 * confidence
    return float(stats.norm.ppf(q) if not math.isfinite(dof) else stats.t.ppf(q, max(dof, 1.0)))
