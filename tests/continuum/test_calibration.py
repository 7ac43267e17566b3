"""Calibration fits recover known parameters from synthetic noisy data within their errors."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from continuum import ngf, volume_averaged
from continuum.calibration import (
    critical_state_line,
    fit_critical_state,
    fit_mu_i,
    fit_nonlocal_length,
    fit_solid_fraction,
    mu_i_parameters,
)
from continuum.parameters import VolumeAveragedParameters

from .conftest import D, shear_gravity

TRUE_MU = {"mu_s": 0.3819, "mu_2": 0.6435, "I_0": 0.279}


def _synthetic_mu(rng, n=25, err=0.004):
    i = np.logspace(-3, np.log10(0.5), n)
    mu_true = mu_i_parameters_from(TRUE_MU).mu(i)
    return i, mu_true + rng.normal(0, err, n), np.full(n, err)


def mu_i_parameters_from(values):
    from continuum.parameters import MuIParameters
    return MuIParameters(**values)


def test_mu_i_fit_recovers_parameters_within_three_sigma(rng):
    i, mu, err = _synthetic_mu(rng)
    fit = fit_mu_i(i, mu, err)
    for name, true in TRUE_MU.items():
        assert abs(fit.values[name] - true) < 3 * fit.errors[name], (name, fit.values[name], fit.errors[name])
    assert 0.3 < fit.chi2_reduced < 2.0
    assert mu_i_parameters(fit).mu_s == fit.values["mu_s"]


def test_mu_i_errors_have_the_stated_coverage(rng):
    """Over many noise realisations about 68 % of fits lie within one stated sigma of the truth
    (binomial spread for 300 trials: +-2.7 %; the bound below is 4 standard deviations)."""
    inside = []
    for _ in range(300):
        i, mu, err = _synthetic_mu(rng)
        fit = fit_mu_i(i, mu, err)
        inside.append(abs(fit.values["mu_s"] - TRUE_MU["mu_s"]) < fit.errors["mu_s"])
    assert abs(np.mean(inside) - 0.683) < 0.11


def test_solid_fraction_fit(rng):
    i = np.logspace(-3, np.log10(0.3), 20)
    err = np.full(i.size, 0.002)
    nu = 0.59 - 0.31 * i + rng.normal(0, 0.002, i.size)
    fit = fit_solid_fraction(i, nu, err)
    assert abs(fit.values["nu_c"] - 0.59) < 3 * fit.errors["nu_c"]
    assert abs(fit.values["a"] - 0.31) < 3 * fit.errors["a"]


def test_critical_state_fit(rng):
    n = 30
    i = np.tile(np.logspace(-3, -1, 10), 3)
    p = np.repeat([200.0, 800.0, 3200.0], 10)
    mu_err, nu_err = np.full(n, 0.004), np.full(n, 0.001)
    mu = mu_i_parameters_from(TRUE_MU).mu(i) + rng.normal(0, 0.004, n)
    nu = 0.595 + 0.006 * np.log(p / 800.0) - 0.3 * i + rng.normal(0, 0.001, n)
    fit = fit_critical_state(i, mu, mu_err, p, nu, nu_err, p_ref=800.0)
    for name, true in {"sin_phi": 0.3819, "nu_ref": 0.595, "kappa": 0.006, "a": 0.3}.items():
        assert abs(fit.values[name] - true) < 3 * fit.errors[name], name
    assert critical_state_line(fit).nu_cs(800.0) == pytest.approx(fit.values["nu_ref"])
    with pytest.raises(ValueError, match="pressures"):
        fit_critical_state(i, mu, mu_err, np.full(n, 500.0), nu, nu_err)


def test_ngf_amplitude_fit_recovers_a_from_a_noisy_creep_profile(rng, ngf_params):
    geo = shear_gravity()
    truth = ngf.solve(geo, replace(ngf_params, A=0.48), n_grid=201)
    z = truth.z.values[::4]
    rel_err = 0.05  # 5 % noise on each speed, as from block averages
    u = truth.u_x.values[::4] * np.exp(rng.normal(0, rel_err, z.size))
    fit = fit_nonlocal_length("ngf", geo, lambda a: replace(ngf_params, A=a), z, u, u_err=rel_err * u,
                              initial=0.3, bounds=(0.05, 2.0), n_grid=201, name="A")
    assert abs(fit.values["A"] - 0.48) < 3 * fit.errors["A"]
    assert fit.errors["A"] < 0.01


def test_volume_averaged_length_fit(rng, cs_params):
    geo = shear_gravity()
    truth = volume_averaged.solve(geo, VolumeAveragedParameters(cs_params, 1.3 * D), n_grid=201)
    z = truth.z.values[::4]
    u = truth.u_x.values[::4] * np.exp(rng.normal(0, 0.05, z.size))
    fit = fit_nonlocal_length("volume_averaged", geo, lambda l: VolumeAveragedParameters(cs_params, l), z, u,
                              u_err=0.05 * u, initial=3 * D, bounds=(0.05 * D, 20 * D), n_grid=201, name="l")
    assert abs(fit.values["l"] - 1.3 * D) < 3 * fit.errors["l"]
