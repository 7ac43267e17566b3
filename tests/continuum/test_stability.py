"""Hadamard stability of the continuum models about simple shear (issue 8, item 1)."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from continuum import stability as st
from continuum.stability import base, mu_i

REF = st.GLASS_BEADS_REFERENCE
GB = dict(mu_s=0.3819, mu_2=0.6435, I_0=0.279)


def _edge(lo: float, hi: float, model: str = "local_mu_i", iters: int = 40) -> float:
    """Bisection in log I on the boolean classifier; lo and hi must classify differently."""
    f_lo = st.well_posed(model, lo, REF)
    assert f_lo != st.well_posed(model, hi, REF)
    for _ in range(iters):
        mid = np.sqrt(lo * hi)
        if st.well_posed(model, mid, REF) == f_lo:
            lo = mid
        else:
            hi = mid
    return np.sqrt(lo * hi)


def test_incompressible_band_edges_match_barker_2015():
    low, high = _edge(1e-3, 0.1), _edge(0.1, 5.0)
    assert low == pytest.approx(0.019, rel=0.1)
    assert high == pytest.approx(0.85, rel=0.1)
    # and the closed form changes sign at the same places
    assert mu_i.barker_criterion(low * 0.99, **GB) > 0 > mu_i.barker_criterion(low * 1.01, **GB)
    assert mu_i.barker_criterion(high * 1.01, **GB) > 0 > mu_i.barker_criterion(high * 0.99, **GB)


def test_numerics_agree_with_closed_form_everywhere():
    I = np.logspace(-3.5, 1.0, 46)
    closed_ill = mu_i.barker_criterion(I, **GB) > 0
    numeric_ill = np.array([not st.well_posed("local_mu_i", float(x), REF) for x in I])
    np.testing.assert_array_equal(numeric_ill, closed_ill)


@pytest.mark.parametrize("I", [2e-3, 0.05, 0.4, 3.0])
def test_leading_order_growth_coefficient_is_barker_dispersion_relation(I):
    # R s / K^2 -> -mu B(X) with B = f(X)/(1 - m X), f = (1-c) X^2 - m X + c, m = mu (1 - c/2),
    # X = cos 2(theta - pi/4) (angle from the stretching principal axis of the base D)
    mu = float(mu_i.mu_of_I(I, **GB))
    c = I * (GB["mu_2"] - GB["mu_s"]) * GB["I_0"] / (I + GB["I_0"]) ** 2 / mu
    m = mu * (1 - c / 2)
    theta = np.linspace(0, np.pi, 721)[:-1]
    X = np.cos(2 * (theta - np.pi / 4))
    expected = -mu * ((1 - c) * X**2 - m * X + c) / (1 - m * X)
    K = 1e5
    s = mu_i.incompressible_growth(I, **GB, nu=0.6, K=np.array([K]), theta=theta)[0, :, 0]
    R = 0.6 * I**2
    np.testing.assert_allclose(s.real * R / K**2, expected, atol=1e-6)


def test_ill_posed_state_grows_without_bound_and_well_posed_state_saturates():
    K = np.logspace(1, 6, 6)
    ill = st.local_mu_i_growth(1e-3, **GB, K=K).max(axis=1)
    assert np.all(ill > 0)
    np.testing.assert_allclose(ill[1:] / ill[:-1], 100.0, rtol=0.01)  # ~K^2 per decade
    well = st.local_mu_i_growth(0.1, **GB, K=K).max(axis=1)
    assert np.all(well < 1.0)  # bounded by O(gammadot)
    assert not st.well_posed("local_mu_i", 1e-3, REF)
    assert st.well_posed("local_mu_i", 0.1, REF)


def test_rate_independent_coulomb_limit_is_ill_posed_everywhere():
    for I in (1e-3, 0.1, 1.0):
        assert not st.well_posed("critical_state", I, REF, variant="incompressible")


def test_volume_averaged_reduces_to_critical_state_as_l_vanishes():
    I, K = 0.05, np.logspace(-2, 3, 11)
    cs = st.critical_state_growth(I, 0.3819, 0.6, K=K)
    np.testing.assert_array_equal(st.volume_averaged_growth(I, 0.3819, 0.6, 0.0, K=K), cs)
    np.testing.assert_allclose(st.volume_averaged_growth(I, 0.3819, 0.6, 1e-6, K=K), cs,
                               rtol=1e-5, atol=1e-9)  # (l K)^2 <= 1e-6 here


def test_volume_averaged_unstable_growth_decays_like_inverse_lk_squared():
    # Every rate perturbation carries (1 + (l k)^2): the bounded critical-state mode is
    # suppressed as 1/(l k)^2 at large k
    K = np.array([1e3, 1e4])
    g = st.volume_averaged_growth(0.05, 0.3819, 0.6, 2.0, K=K).max(axis=1)
    assert g[1] == pytest.approx(g[0] / 100.0, rel=0.02)


def test_ngf_high_k_growth_is_cut_off_at_the_cooperative_length():
    # Locally ill-posed state (I = 1e-3): the sup over k of the growth scales as 1/xi^2 ~ 1/A^2
    K = np.logspace(-1, 7, 49)
    sup = [st.ngf_growth(1e-3, **GB, A=A, K=K).max() * A**2 for A in (0.048, 0.0048)]
    assert sup[0] == pytest.approx(sup[1], rel=0.01)
    assert st.well_posed("ngf", 1e-3, REF)


def test_ngf_large_k_limit_is_newtonian_with_viscosity_p_over_g():
    I, K = 0.1, 1e5
    mu0 = st.state_mu("ngf", I, REF)
    s = st.ngf_growth(I, **GB, A=0.48, K=np.array([K])).max()
    assert s == pytest.approx(-mu0 * K**2 / (0.6 * I**2), rel=1e-3)


def test_cosserat_with_quasistatic_spin_and_no_length_is_critical_state():
    from continuum.stability import cosserat, critical_state

    K = np.logspace(-1, 5, 7)
    a = base.max_growth(cosserat.growth(0.05, 0.3819, 0.6, l=0.0, spin_inertia=0.0, K=K))
    b = base.max_growth(critical_state.growth(0.05, 0.3819, 0.6, K=K))
    np.testing.assert_allclose(a, b, rtol=1e-9)


def test_compressible_mu_i_needs_bulk_friction():
    # plain mu(I)-nu(I) is ill posed; a bulk friction above ~2 - 2 mu (Heyman et al. 2017, 2D)
    # makes it well posed
    p = dict(REF)
    assert not st.well_posed("local_mu_i", 0.1, p, variant="compressible")
    p["mu_b"] = 2.0
    assert st.well_posed("local_mu_i", 0.1, p, variant="compressible")


def test_table_has_contract_columns_and_one_row_per_model_and_state():
    I = [0.005, 0.1]
    df = st.well_posedness_table({"glass_beads_reference": REF}, I, include_variants=False)
    assert list(df.columns) == ["model", "parameter_set", "I", "mu", "max_growth_rate", "well_posed"]
    assert len(df) == len(st.MODELS) * len(I)
    assert not df.duplicated(["model", "parameter_set", "I"]).any()
    assert df["well_posed"].dtype == bool and np.isfinite(df["max_growth_rate"]).all()
    lookup = df.set_index(["model", "I"])["well_posed"]
    assert not lookup[("local_mu_i", 0.005)] and lookup[("local_mu_i", 0.1)]
    assert lookup[("ngf", 0.005)] and lookup[("volume_averaged", 0.005)]


def test_table_accepts_a_calibrated_set_with_l_in_metres():
    cal = {"mu_s": 0.36, "mu_2": 0.62, "I_0": 0.3, "A": 0.5, "l": 2e-3, "d": 1e-3}
    df = st.well_posedness_table({"calibrated": cal}, [0.1])
    assert isinstance(df, pd.DataFrame)
    assert set(df["parameter_set"]) == {"calibrated", "calibrated+compressible",
                                        "calibrated+incompressible"}


def test_stability_map_shapes_and_consistency():
    I = np.array([1e-3, 0.1])
    theta = np.linspace(0, np.pi, 19)[:-1]
    m = st.stability_map("local_mu_i", REF, I, theta=theta)
    assert m.growth.shape == m.well_posed.shape == (2, 18)
    assert not m.well_posed[0].all() and m.well_posed[1].all()


def test_ngf_above_mu_one_has_a_pressure_pole_and_is_classified_ill_posed():
    from continuum.stability import ngf

    # mu = mu_s + b I crosses 1 at I ~ 0.66: a fine orientation scan finds huge growth at
    # finite k there, and none just below
    theta = np.linspace(0, np.pi, 20001)[:-1]
    K = np.logspace(-1, 3, 9)
    below = base.max_growth(ngf.growth(0.6, **GB, A=0.48, K=K, theta=theta)).max()
    above = base.max_growth(ngf.growth(0.7, **GB, A=0.48, K=K, theta=theta)).max()
    assert below < 1.0 < 1e4 < above
    assert st.well_posed("ngf", 0.6, REF) and not st.well_posed("ngf", 0.7, REF)
