"""The decay-length law (pipeline.scoring.decay_length) on profiles with a known law."""
from __future__ import annotations

import numpy as np
import pytest

from pipeline.scoring.decay_length import DecayLengthError, fit_law, local_decay_lengths

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


@pytest.mark.parametrize("beta", [0.0, 0.5, 1.0])
def test_exact_profiles_give_their_exponent(beta: float) -> None:
    # xi = 1.5 d at mu = 0.7 mu_s whatever beta: a creep that stays above 1e-12 V over the layer.
    z, u, mu, _ = power_law_creep(beta, 1.5 * (0.3 * MU_S) ** beta)
    rows = local_decay_lengths(z, u, None, mu, z[0], z[-1], wall_speed=1.0, width=D)
    fit = fit_law(rows.mu.values, rows.xi.values / D, None, None, MU_S)
    assert fit["beta"] == pytest.approx(beta, abs=0.02)
    assert fit["n_points"] >= 15


def test_noisy_profiles_recover_the_exponent_within_its_error(rng) -> None:
    z, u, mu, _ = power_law_creep(0.5, 0.3)
    err = 0.05 * u
    noisy = u * (1 + 0.05 * rng.standard_normal(u.size))
    rows = local_decay_lengths(z, noisy, err, mu, z[0], z[-1], wall_speed=1.0, width=2 * D)
    fit = fit_law(rows.mu.values, rows.xi.values / D, rows.xi_err.values / D, np.zeros(len(rows)), MU_S)
    assert abs(fit["beta"] - 0.5) < 3 * fit["beta_err"] + 0.02
    assert 0 < fit["beta_err"] < 0.3


def test_points_not_resolved_are_dropped_and_too_few_refuse_the_fit() -> None:
    z, u, mu, _ = power_law_creep(0.5, 0.3)
    rows = local_decay_lengths(z, u, u * 0.8, mu, z[0], z[-1], wall_speed=1.0, width=D)  # u < 2 err everywhere
    assert rows.empty
    with pytest.raises(DecayLengthError):
        fit_law(np.array([0.3, 0.31]), np.array([1.0, 1.1]), None, None, MU_S)


@pytest.mark.workflow
def test_the_workflow_writes_the_law_for_every_planar_run(reduced_results) -> None:
    import pandas as pd

    table = pd.read_csv(reduced_results / "validation" / "decay_length.csv")
    assert list(table.columns[:6]) == ["case", "run", "z", "mu", "xi", "xi_err"]
    assert (table.xi > 0).all() and (table.xi_err > 0).all()
    assert set(table.role) <= {"calibration", "held_out"}
    fits = pd.read_csv(reduced_results / "validation" / "decay_length_fit.csv")
    assert "dem" in set(fits.source) and "ngf" in set(fits.source)
