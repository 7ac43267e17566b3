"""The draws' normal deviates (pipeline.calibration.samplers): the random source is numpy's own calls;
the Sobol source gives the target distribution, more evenly than random points."""
from __future__ import annotations

import numpy as np
import pytest

from pipeline.calibration.samplers import RandomSource, SobolSource, normal_source

MEAN = np.array([0.37, 0.98, 0.56])
COV = np.array([[7e-6, 2e-5, 1e-5], [2e-5, 8e-4, 1e-3], [1e-5, 1e-3, 2.6e-3]])


def test_the_random_source_is_numpys_calls():
    a, b = RandomSource(np.random.default_rng(5)), np.random.default_rng(5)
    a.start_draw()
    np.testing.assert_array_equal(a.multivariate_normal(MEAN, COV), b.multivariate_normal(MEAN, COV, method="eigh"))
    assert a.normal(1.06, 0.01) == float(b.normal(1.06, 0.01))


def _sobol_draws(n: int, seed: int) -> np.ndarray:
    source = SobolSource(n, seed)
    out = []
    for _ in range(n):
        source.start_draw()
        out.append(source.multivariate_normal(MEAN, COV))
    return np.array(out)


def test_sobol_draws_have_the_covariance_asked_for():
    x = _sobol_draws(1024, 3)
    sd = np.sqrt(np.diag(COV))
    # 1024 points: the sample mean within 0.02 sd (random points: 0.03 sd rms), the covariance within 5 %
    assert np.all(np.abs(x.mean(axis=0) - MEAN) < 0.02 * sd)
    np.testing.assert_allclose(np.cov(x.T), COV, rtol=0.05, atol=0.05 * np.outer(sd, sd).max())


def test_sixteen_sobol_points_estimate_a_spread_better_than_sixteen_random_ones():
    # The spread of a linear function of the parameters over 16 draws, repeated over 40 scrambles
    # or 40 random seeds: the Sobol estimates scatter less about the truth.
    weights = np.array([1.0, -0.5, 0.2])
    truth = float(np.sqrt(weights @ COV @ weights))
    sobol = [np.std(_sobol_draws(16, s) @ weights, ddof=1) / truth for s in range(40)]
    rand = [np.std(np.random.default_rng(s).multivariate_normal(MEAN, COV, 16, method="eigh") @ weights, ddof=1) / truth
            for s in range(40)]
    assert np.sqrt(np.mean(np.square(np.subtract(sobol, 1.0)))) < 0.7 * np.sqrt(np.mean(np.square(np.subtract(rand, 1.0))))


def test_a_used_up_sequence_and_an_unknown_sampler_are_refused():
    source = SobolSource(2, 0)
    for _ in range(2):
        source.start_draw()
    with pytest.raises(ValueError, match="used up"):
        source.start_draw()
    with pytest.raises(ValueError, match="draw_sampler"):
        normal_source("halton", 0, 8)
