"""The decay-length law (pipeline.scoring.decay_length) on profiles with a known law."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from pipeline.scoring.decay_length import (DecayLengthError, creep_windows, fit_law, replica_error_scale, select_model,
                                           window_slope)

D = 0.002
MU_S = 0.38


def power_law_creep(beta: float, c: float, n: int = 801):
    """u(z) = V exp(-integral_z^H dz' / xi(z')), xi = c d (mu_s - mu)^-beta, mu falling linearly with depth."""
    z = np.linspace(0.0, 20 * D, n)
    mu = MU_S * (0.4 + 0.55 * z / z[-1])  # 0.4 mu_s at the bottom to 0.95 mu_s at the top
    xi = c * D * (MU_S - mu) ** (-beta)
    phase = np.concatenate([[0.0], np.cumsum(0.5 * (1 / xi[1:] + 1 / xi[:-1]) * np.diff(z))])
    u = 1e-3 * np.exp(phase - phase[-1])  # 1e-3 V at the top: all creep
    return z, u, mu, xi


def windows(z, u, err, mu):
    depth = z[-1] - z
    rows = []
    for k, idx in creep_windows(depth, u, err, 1.0, D, 0.0, z[-1]):
        slope, slope_err = window_slope(z[idx], u[idx], None if err is None else err[idx])
        rows.append({"window": k, "slope": slope, "slope_err": slope_err, "mu": mu[idx].mean(), "mu_err": 0.0,
                     "depth": depth[idx].mean()})
    return pd.DataFrame(rows)


@pytest.mark.parametrize("beta", [0.0, 0.5, 1.0])
def test_exact_profiles_give_their_exponent(beta: float) -> None:
    # xi = 1.5 d at mu = 0.7 mu_s whatever beta: a creep that stays above 1e-12 V over the layer.
    z, u, mu, _ = power_law_creep(beta, 1.5 * (0.3 * MU_S) ** beta)
    rows = windows(z, u, None, mu)
    fit = fit_law(rows.mu.values, rows.slope.values * D, None, None, MU_S)
    assert fit["beta"] == pytest.approx(beta, abs=0.02)
    assert fit["n_points"] >= 15


def test_noisy_profiles_recover_the_exponent_within_its_error(rng) -> None:
    z, u, mu, _ = power_law_creep(0.5, 0.3)
    err = 0.05 * u
    noisy = u * (1 + 0.05 * rng.standard_normal(u.size))
    rows = windows(z, noisy, err, mu)
    fit = fit_law(rows.mu.values, rows.slope.values * D, rows.slope_err.values * D, rows.mu_err.values, MU_S)
    assert abs(fit["beta"] - 0.5) < 3 * fit["beta_err"] + 0.02
    assert 0 < fit["beta_err"] < 0.3


def test_a_deep_window_with_an_insignificant_slope_is_kept(rng) -> None:
    """No cut on the slope's significance: a resolved window whose slope is below two errors stays."""
    z = np.linspace(0.0, 4 * D, 41)
    u = 1e-3 * np.exp(z / (40 * D))          # xi = 40 d: slope small against the noise
    err = 0.02 * u
    rows = windows(z, u * (1 + 0.02 * rng.standard_normal(z.size)), err, np.full(z.size, 0.3))
    assert len(rows) == 4
    assert (np.abs(rows.slope) < 2 * rows.slope_err).any()


def test_unresolved_points_end_the_windows_and_too_few_refuse_the_fit() -> None:
    z, u, mu, _ = power_law_creep(0.5, 0.3)
    assert windows(z, u, u * 0.8, mu).empty  # u < 2 err everywhere
    with pytest.raises(DecayLengthError):
        fit_law(np.array([0.3, 0.31]), np.array([1.0, 1.1]), None, None, MU_S)


def test_model_selection_tells_a_constant_length_from_the_half_power(rng) -> None:
    """Over 40 noisy sets of 30 windows: rows from xi = const rarely prefer the power law (the AIC
    rule wrongly does so when delta chi2 > 4: 4.6 % for Gaussian errors), rows from beta = 1/2
    always do."""
    mu = np.linspace(0.45, 0.95, 30) * MU_S
    err = np.full(mu.size, 0.02)
    preferred = {0.0: [], 0.5: []}
    for beta in preferred:
        for _ in range(40):
            slope_d = (MU_S - mu) ** beta / (1.2 if beta == 0 else 0.45) + err * rng.standard_normal(mu.size)
            table = pd.DataFrame({"mu": mu, "slope": slope_d / D, "slope_err": err / D, "mu_err": 0.0})
            preferred[beta].append(select_model(table, MU_S, D)["preferred"])
    assert preferred[0.0].count("power law") <= 6  # 40 x 0.046 = 1.8 expected; 6 or more: P < 0.5 %
    assert preferred[0.5].count("power law") == 40


def test_the_replicas_scale_the_slope_errors(rng) -> None:
    """Replica windows scattered by sigma, stated with errors 2 sigma: the scale is about 1/2."""
    true = rng.uniform(100, 400, 40)
    rows = [{"case": "c", "window": k, "run": f"r{r}", "slope": s + 10.0 * rng.standard_normal(), "slope_err": 20.0}
            for k, s in enumerate(true) for r in (1, 2)]
    scale, pairs = replica_error_scale(pd.DataFrame(rows))
    assert pairs == 40
    assert scale == pytest.approx(0.5, rel=0.25)


@pytest.mark.workflow
def test_the_workflow_writes_the_law_for_every_planar_run(reduced_results) -> None:
    table = pd.read_csv(reduced_results / "validation" / "decay_length.csv")
    assert list(table.columns[:7]) == ["case", "run", "z", "mu", "xi", "xi_err", "I"]
    assert (table.slope_err > 0).all() and (table.I > 0).all()
    assert set(table.role) <= {"calibration", "held_out"}
    fits = pd.read_csv(reduced_results / "validation" / "decay_length_fit.csv")
    assert "dem" in set(fits.source) and "ngf" in set(fits.source)
