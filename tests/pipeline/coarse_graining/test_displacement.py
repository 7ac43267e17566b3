"""Displacement-based creep speed (pipeline.coarse_graining.displacement) on dumps with known motion."""
from __future__ import annotations

import numpy as np
import pytest

from pipeline.coarse_graining.displacement import DisplacementError, displacement_velocity
from pipeline.coarse_graining.kernels import Kernel
from pipeline.dumps.reader import Dump

COLUMNS = ("id", "type", "x", "y", "z", "vx", "vy", "vz", "radius", "mass")


def moving_dump(rng: np.random.Generator, speed_of_z, lx: float = 0.01, n: int = 400, snaps: int = 21,
                dt: float = 0.01, jitter: float = 0.0) -> tuple[Dump, np.ndarray]:
    """Grains at fixed heights drifting along x at speed_of_z(z), wrapped into [0, lx), shuffled rows."""
    z = rng.uniform(0.0, 0.02, n)
    x0 = rng.uniform(0.0, lx, n)
    times = np.arange(snaps) * dt
    rows, offsets = [], [0]
    for t in times:
        x = np.mod(x0 + speed_of_z(z) * t + jitter * rng.standard_normal(n), lx)
        block = np.column_stack([np.arange(1, n + 1), np.ones(n), x, np.zeros(n), z, np.zeros((n, 3)),
                                 np.full(n, 0.001), np.full(n, 1e-5)])
        rows.append(block[rng.permutation(n)])  # dumps need not be sorted
        offsets.append(offsets[-1] + n)
    boxes = np.tile(np.array([[0.0, lx], [0.0, lx], [-0.01, 0.03]]), (snaps, 1, 1))
    dump = Dump("atoms", COLUMNS, np.arange(snaps) * 100, boxes, ("pp", "pp", "ff"), np.array(offsets),
                np.concatenate(rows), ("synthetic",))
    return dump, times


def test_linear_creep_profile_is_recovered_through_periodic_wraps(rng) -> None:
    # 0.2 m/s at the top: 2 mm (a fifth of the cell) per snapshot, 4 crossings of the cell in the window.
    dump, times = moving_dump(rng, lambda z: 10.0 * z)
    grid = np.linspace(0.004, 0.016, 13)
    u, err = displacement_velocity(dump, np.arange(len(times)), times, Kernel("gaussian", 0.001), grid, blocks=5)
    # The kernel average of a linear field is exact up to the grains' discreteness.
    assert np.allclose(u, 10.0 * grid, rtol=0.03)
    assert np.all(err < 1e-9)  # steady motion: every block gives the same value


def test_error_falls_with_the_window_for_caged_jitter(rng) -> None:
    slow = lambda z: np.full_like(z, 1e-4)  # noqa: E731
    grid = np.linspace(0.005, 0.015, 5)
    kernel = Kernel("gaussian", 0.001)
    dump, times = moving_dump(rng, slow, jitter=2e-5, snaps=41)
    u_long, e_long = displacement_velocity(dump, np.arange(41), times, kernel, grid, blocks=5)
    u_short, e_short = displacement_velocity(dump, np.arange(11), times[:11], kernel, grid, blocks=5)
    assert np.all(np.abs(u_long - 1e-4) < 4 * e_long)
    # Bounded excursions: the error of the mean speed falls at least as fast as 1/sqrt(T).
    assert np.median(e_long) < np.median(e_short) / np.sqrt(4.0)


def test_grains_too_fast_to_unwrap_leave_the_field_undefined_only_where_they_are(rng) -> None:
    # 0.4 m/s above z = 1 cm: 4 mm of the 1 cm cell per snapshot; 1e-4 m/s below.
    dump, times = moving_dump(rng, lambda z: np.where(z > 0.01, 0.4, 1e-4), dt=0.01)
    grid = np.array([0.003, 0.017])
    u, err = displacement_velocity(dump, np.arange(len(times)), times, Kernel("gaussian", 0.001), grid, 5)
    assert u[0] == pytest.approx(1e-4, rel=1e-6) and np.isnan(u[1]) and np.isnan(err[1])


def test_too_few_snapshots_are_refused(rng) -> None:
    dump, times = moving_dump(rng, lambda z: np.full_like(z, 1e-4), snaps=2)
    with pytest.raises(DisplacementError, match="at least two"):
        displacement_velocity(dump, np.arange(1), times[:1], Kernel("gaussian", 0.001), np.array([0.01]), 5)
