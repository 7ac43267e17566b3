"""Drift test: stationary noise passes, a trend larger than the tolerance fails. Balance test: a
force whose mean is its target passes as often as Student's t says, an offset beyond the tolerance fails."""
from __future__ import annotations

import numpy as np
import pytest

from scipy import stats

from pipeline.dem.steady_state import balance_test, drift_test


def test_stationary_noise_passes(rng: np.random.Generator) -> None:
    t = np.linspace(0.0, 1.0, 400)
    y = 10.0 + rng.normal(0.0, 0.5, t.size)
    result = drift_test(t, y, tol=0.02, scale=10.0)
    assert result.stationary
    assert result.mean == pytest.approx(10.0, abs=0.1)


def test_trend_above_tolerance_fails(rng: np.random.Generator) -> None:
    t = np.linspace(0.0, 1.0, 400)
    y = 10.0 + 1.0 * t + rng.normal(0.0, 0.05, t.size)  # 10 % drift, tolerance 2 %
    result = drift_test(t, y, tol=0.02, scale=10.0)
    assert not result.stationary
    assert result.drift == pytest.approx(1.0, rel=0.1)


def test_relaxation_is_not_steady_until_it_has_relaxed() -> None:
    t = np.linspace(0.0, 10.0, 1000)
    y = 1.0 - np.exp(-t)  # relaxes over a time 1
    assert not drift_test(t[:200], y[:200], tol=0.02, scale=1.0).stationary
    assert drift_test(t[600:], y[600:], tol=0.02, scale=1.0).stationary


def test_too_few_samples_is_an_error() -> None:
    with pytest.raises(ValueError, match="at least 16 samples"):
        drift_test(np.arange(10.0), np.zeros(10), tol=0.1, scale=1.0)


def test_balance_with_no_tolerance_passes_as_often_as_students_t(rng: np.random.Generator) -> None:
    """With tol = 0 the test passes when |mean - target| <= 2 block errors: for 8 independent
    blocks, P(|t_7| <= 2) = 0.914. 4 000 white-noise series: the pass rate's own error is 0.0044,
    so 3.5 of them bound it."""
    n, p_pass = 4000, 2.0 * stats.t.cdf(2.0, df=7) - 1.0
    passed = [balance_test(1.0 + rng.normal(0.0, 0.3, 160), 1.0, tol=0.0).balanced for _ in range(n)]
    assert abs(np.mean(passed) - p_pass) < 3.5 * np.sqrt(p_pass * (1 - p_pass) / n)


def test_push_above_the_load_beyond_the_tolerance_fails(rng: np.random.Generator) -> None:
    """A wall pushed 1.35 x its load (a fast rheometer state's, still rising under its damping)."""
    push = 1.35 + rng.normal(0.0, 0.2, 400)
    result = balance_test(push, 1.0, tol=0.02)
    assert not result.balanced
    assert result.ratio == pytest.approx(1.35, abs=0.05)
    assert balance_test(push, 1.0, tol=0.5).balanced


def test_balance_needs_blocks_and_a_target() -> None:
    with pytest.raises(ValueError, match="at least 16 samples"):
        balance_test(np.ones(10), 1.0, tol=0.1)
    with pytest.raises(ValueError, match="non-zero"):
        balance_test(np.ones(40), 0.0, tol=0.1)
