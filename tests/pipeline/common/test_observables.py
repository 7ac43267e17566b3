"""Creep observables: decades of a profile resolved above its noise."""
from __future__ import annotations

import math

import numpy as np

from pipeline.common.observables import decades_resolved


def test_exponential_creep_is_resolved_down_to_twice_its_error(rng: np.random.Generator) -> None:
    # u/V = exp(-depth / 2 d) from the top (last index) down, error 1e-4 V everywhere: resolved
    # while exp(-depth/2) > 2e-4, i.e. to depth 2 ln(5000) = 17.0 d: log10(1 / 2e-4) = 3.7 decades
    # (up to the grid's 0.25 d steps).
    depth = np.arange(0.0, 25.0, 0.25)[::-1]
    u = np.exp(-depth / 2.0)
    decades, slowest = decades_resolved(u, np.full(u.size, 1e-4), 1.0)
    assert abs(decades - math.log10(1.0 / 2e-4)) < 0.06
    assert 2e-4 < slowest < 2.3e-4


def test_a_noise_spike_below_the_unresolved_point_does_not_count() -> None:
    u = np.array([5e-3, 1e-5, 1e-3, 1e-2, 1e-1, 1.0])  # bottom ... top
    err = np.full(u.size, 1e-4)
    decades, slowest = decades_resolved(u, err, 1.0)
    assert slowest == 1e-3 and decades == 3.0


def test_nothing_resolved() -> None:
    assert decades_resolved(np.array([1e-5, 2e-5]), np.array([1e-4, 1e-4]), 1.0)[0] == 0.0
