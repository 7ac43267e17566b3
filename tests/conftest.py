"""Shared test fixtures.

Floating-point errors raise (as in py-pde's test suite) so that a NaN or an overflow inside a
solver or a coarse-graining kernel fails the test where it happens instead of propagating.
"""
from __future__ import annotations

import numpy as np
import pytest

np.seterr(all="raise")


@pytest.fixture
def rng() -> np.random.Generator:
    """A seeded generator: every random test input is reproducible."""
    return np.random.default_rng(20261123)
