"""Drift test: stationary noise passes, a trend larger than the tolerance fails."""
from __future__ import annotations

import numpy as np
import pytest

from pipeline.dem.steady_state import drift_test


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
