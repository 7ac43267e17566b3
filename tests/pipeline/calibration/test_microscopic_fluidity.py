"""The microscopic fluidity g = (delta_v / d) F(nu) (Zhang & Kamrin 2017): F fitted on rheometer
states of known F, and never evaluated outside the states' nu."""
from __future__ import annotations

import numpy as np

from pipeline.calibration.calibrate import microscopic_fluidity, microscopic_fluidity_fit

D = 0.002


def states(rng: np.random.Generator, c0: float, c1: float, nu: np.ndarray) -> list[dict]:
    """Rheometer states whose fluidity is sqrt(T) / d exp(c0 + c1 nu) times 1 % noise."""
    temperature = 10.0 ** rng.uniform(-6, -3, nu.size)
    g = np.sqrt(temperature) / D * np.exp(c0 + c1 * nu) * (1.0 + 0.01 * rng.standard_normal(nu.size))
    return [{"fluidity": gi, "fluidity_err": 0.01 * gi, "granular_temperature": ti, "granular_temperature_err": 1e-4 * ti,
             "nu": ni} for gi, ti, ni in zip(g, temperature, nu)]


def test_fit_recovers_f_and_is_not_extrapolated(rng: np.random.Generator) -> None:
    nu = np.linspace(0.50, 0.59, 8)
    fit = microscopic_fluidity_fit(states(rng, 4.0, -6.0, nu), D)
    # 1 % noise on 8 states over a nu span of 0.09: c1 to a few tenths, c0 to a few hundredths x 6.
    assert abs(fit["c1"]["value"] + 6.0) < 3 * fit["c1"]["error"] + 1e-9
    assert abs(fit["c0"]["value"] - 4.0) < 3 * fit["c0"]["error"] + 1e-9
    assert fit["nu_range"] == [nu.min(), nu.max()]
    params = {"microscopic_fluidity": fit, "d": D}
    profile_nu = np.array([0.48, 0.50, 0.55, 0.59, 0.61])
    temperature = np.full(profile_nu.size, 1e-4)
    g, err = microscopic_fluidity(params, profile_nu, temperature, 1e-6 * np.ones(profile_nu.size))
    inside = (profile_nu >= nu.min()) & (profile_nu <= nu.max())
    np.testing.assert_allclose(g[inside], np.sqrt(1e-4) / D * np.exp(4.0 - 6.0 * profile_nu[inside]), rtol=0.05)
    # Outside the states' nu (the loose top, the dense creeping zone) F is not known: no value.
    assert np.all(np.isnan(g[~inside])) and np.all(np.isnan(err[~inside]))
    assert np.all(np.isfinite(g[inside]))
