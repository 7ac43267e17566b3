"""Calibration fits: pure numerics on arrays, no files, no DEM.

Each fit returns a small dataclass with the fitted values, their standard errors and the
covariance, all from ``scipy.optimize.curve_fit`` with ``sigma`` = the given standard errors and
``absolute_sigma=True`` (the data's error bars, e.g. block-average standard errors, are taken as
absolute). ``chi2_reduced`` lets the caller check that claim: near 1 if the error bars and the
law are right; well above 1 means the law misses the data or the error bars are too small.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np
from scipy.optimize import curve_fit

from . import SOLVERS
from .geometry import PlanarShear
from .parameters import CriticalStateLine, MuIParameters, SolidFractionLaw


@dataclass(frozen=True)
class FitResult:
    """Values, standard errors and covariance of a least-squares fit.

    Attributes:
        names: parameter names, in the order of ``covariance``.
        values, errors: name -> value, name -> one-sigma standard error.
        covariance: parameter covariance matrix.
        chi2_reduced: sum of squared weighted residuals / (points - parameters).
        n_points: number of data points used.
    """

    names: tuple[str, ...]
    values: dict[str, float]
    errors: dict[str, float]
    covariance: np.ndarray = field(repr=False)
    chi2_reduced: float
    n_points: int


def _fit(model: Callable[..., np.ndarray], x: Any, y: np.ndarray, err: np.ndarray, p0: list[float],
         names: tuple[str, ...], bounds: tuple[Any, Any] = (-np.inf, np.inf)) -> FitResult:
    y, err = np.asarray(y, dtype=float), np.asarray(err, dtype=float)
    if np.any(~(err > 0.0)):
        raise ValueError("uncertainties must be positive")
    if y.size <= len(p0):
        raise ValueError(f"need more than {len(p0)} points, got {y.size}")
    popt, pcov = curve_fit(model, x, y, p0=p0, sigma=err, absolute_sigma=True, bounds=bounds, maxfev=20000)
    if not np.all(np.isfinite(pcov)):
        raise ValueError("fit is degenerate: the data do not constrain every parameter")
    chi2 = float(np.sum(((model(x, *popt) - y) / err) ** 2))
    return FitResult(names, dict(zip(names, map(float, popt))), dict(zip(names, map(float, np.sqrt(np.diag(pcov))))),
                     pcov, chi2 / (y.size - len(p0)), int(y.size))


def _mu_of_i(i: np.ndarray, mu_s: float, mu_2: float, i_0: float) -> np.ndarray:
    return mu_s + (mu_2 - mu_s) * i / (i + i_0)


def fit_mu_i(inertial_number: np.ndarray, mu: np.ndarray, mu_err: np.ndarray) -> FitResult:
    """Fit mu(I) = mu_s + (mu_2 - mu_s) / (1 + I_0 / I); names ``mu_s``, ``mu_2``, ``I_0``.

    ``mu_i_parameters(result)`` turns the result into a ``MuIParameters``.
    """
    i = np.asarray(inertial_number, dtype=float)
    m = np.asarray(mu, dtype=float)
    p0 = [float(m[np.argmin(i)]), float(m.max()) + 0.1, float(np.median(i))]
    return _fit(_mu_of_i, i, m, mu_err, p0, ("mu_s", "mu_2", "I_0"),
                bounds=([0.0, 0.0, 1e-8], [np.inf, np.inf, np.inf]))


def mu_i_parameters(result: FitResult) -> MuIParameters:
    """The fitted values as a ``MuIParameters``."""
    v = result.values
    return MuIParameters(v["mu_s"], v["mu_2"], v["I_0"])


def fit_solid_fraction(inertial_number: np.ndarray, nu: np.ndarray, nu_err: np.ndarray) -> FitResult:
    """Fit nu(I) = nu_c - a I (weighted linear least squares); names ``nu_c``, ``a``."""
    i = np.asarray(inertial_number, dtype=float)
    return _fit(lambda x, nu_c, a: nu_c - a * x, i, nu, nu_err, [float(np.max(nu)), 0.3], ("nu_c", "a"))


def solid_fraction_law(result: FitResult) -> SolidFractionLaw:
    """The fitted values as a ``SolidFractionLaw``."""
    return SolidFractionLaw(result.values["nu_c"], result.values["a"])


def fit_critical_state(inertial_number: np.ndarray, mu: np.ndarray, mu_err: np.ndarray,
                       p: np.ndarray, nu: np.ndarray, nu_err: np.ndarray,
                       p_ref: float | None = None) -> FitResult:
    """Fit the critical-state family from rheometer states; names ``sin_phi``, ``nu_ref``,
    ``kappa``, ``a`` (+ ``p_ref`` fixed, not fitted: its error is 0).

    The rate-independent model describes the quasi-static limit, so:
    - sin_phi is the I -> 0 stress ratio: mu_s of a mu(I) fit to the same states (critical-state
      stress ratio, with the normalisation tau = |sigma_xz| in simple shear);
    - the critical-state line nu_cs(p) = nu_ref + kappa ln(p / p_ref) is the I -> 0 limit of the
      solid fraction: nu = nu_ref + kappa ln(p / p_ref) - a I, a weighted linear fit to all states,
      where the -a I term takes out the rate dependence. kappa needs states at two or more
      pressures; with a single pressure the fit raises ValueError.

    Args:
        p: pressure of each state (Pa). p_ref defaults to the geometric mean of p.
    """
    p = np.asarray(p, dtype=float)
    if np.max(p) / np.min(p) < 1.2:
        raise ValueError("the critical-state line needs states at two or more pressures (max/min >= 1.2)")
    if p_ref is None:
        p_ref = float(np.exp(np.mean(np.log(p))))
    mu_fit = fit_mu_i(inertial_number, mu, mu_err)
    i = np.asarray(inertial_number, dtype=float)
    x = np.vstack([i, np.log(p / p_ref)])
    line = _fit(lambda xx, nu_ref, kappa, a: nu_ref + kappa * xx[1] - a * xx[0], x, nu, nu_err,
                [float(np.mean(nu)), 0.01, 0.3], ("nu_ref", "kappa", "a"))
    names = ("sin_phi",) + line.names + ("p_ref",)
    cov = np.zeros((5, 5))
    cov[0, 0] = mu_fit.covariance[0, 0]
    cov[1:4, 1:4] = line.covariance
    values = {"sin_phi": mu_fit.values["mu_s"], **line.values, "p_ref": p_ref}
    errors = {"sin_phi": mu_fit.errors["mu_s"], **line.errors, "p_ref": 0.0}
    return FitResult(names, values, errors, cov, line.chi2_reduced, line.n_points)


def critical_state_line(result: FitResult) -> CriticalStateLine:
    """The fitted p_c(nu) as a ``CriticalStateLine``."""
    v = result.values
    return CriticalStateLine(v["nu_ref"], v["kappa"], v["p_ref"])


def fit_nonlocal_length(model: str, geometry: PlanarShear, make_params: Callable[[float], Any],
                        z: np.ndarray, u: np.ndarray, u_err: np.ndarray | None = None,
                        initial: float = 1.0, bounds: tuple[float, float] = (1e-3, 1e3),
                        n_grid: int = 400, min_speed: float | None = None, name: str = "length",
                        **solve_options: Any) -> FitResult:
    """Fit one non-local parameter (NGF A; l of the Cosserat or volume-averaged model) by least
    squares of log10 u_x against a measured creep profile.

    Args:
        model: model name known to ``continuum.solve``.
        geometry: the calibration case's geometry.
        make_params: parameter value -> the model's parameter dataclass (e.g.
            ``lambda A: replace(ngf_params, A=A)``).
        z, u: measured heights (m) and velocities (m s-1).
        u_err: standard errors of u (m s-1); the log10 residuals are weighted by
            u_err / (u ln 10). Without them the points are weighted equally and the error is
            scaled by the residual scatter (curve_fit with absolute_sigma=False).
        initial, bounds: starting value and bounds of the parameter (its own units: A is
            dimensionless, l in m).
        min_speed: points with u <= min_speed are left out (default: 1e-6 of the wall speed):
            the log of a speed lost in noise carries no information.
        name: name of the parameter in the result.

    Returns:
        FitResult with the single parameter ``name``.
    """
    z, u = np.asarray(z, dtype=float), np.asarray(u, dtype=float)
    floor = 1e-6 * geometry.wall_speed if min_speed is None else min_speed
    keep = u > floor
    if keep.sum() < 3:
        raise ValueError("fewer than 3 points above the speed floor")
    solver, _ = SOLVERS[model]

    def log_speed(zz: np.ndarray, value: float) -> np.ndarray:
        ds = solver(geometry, make_params(float(value)), n_grid=n_grid, **solve_options)
        model_u = np.interp(zz, ds.z.values, ds.u_x.values)
        return np.log10(np.maximum(model_u, np.finfo(float).tiny))

    y = np.log10(u[keep])
    if u_err is None:
        sigma, absolute = None, False
    else:
        sigma, absolute = np.asarray(u_err, dtype=float)[keep] / (u[keep] * np.log(10.0)), True
    popt, pcov = curve_fit(log_speed, z[keep], y, p0=[initial], sigma=sigma, absolute_sigma=absolute,
                           bounds=([bounds[0]], [bounds[1]]), diff_step=1e-4)
    resid = log_speed(z[keep], popt[0]) - y
    weights = 1.0 if sigma is None else sigma
    chi2 = float(np.sum((resid / weights) ** 2)) / (keep.sum() - 1)
    return FitResult((name,), {name: float(popt[0])}, {name: float(np.sqrt(pcov[0, 0]))}, pcov, chi2,
                     int(keep.sum()))


__all__ = ["FitResult", "fit_mu_i", "mu_i_parameters", "fit_solid_fraction", "solid_fraction_law",
           "fit_critical_state", "critical_state_line", "fit_nonlocal_length"]
