"""The solid fraction's structural error (pipeline.coarse_graining.structure) on packings of known statistics."""
from __future__ import annotations

import numpy as np

from pipeline.coarse_graining import structure
from pipeline.coarse_graining.kernels import Kernel
from pipeline.dumps.reader import Dump

COLUMNS = ("id", "type", "x", "y", "z", "vx", "vy", "vz", "radius", "mass")
D = 0.002
L = 8 * D


def frozen_packing(rng: np.random.Generator, n: int = 1500, snaps: int = 4) -> Dump:
    """Grains at random positions (independent: Poisson statistics), frozen over the snapshots."""
    pos = np.column_stack([rng.uniform(0, L, n), rng.uniform(0, L, n), rng.uniform(0, 20 * D, n)])
    block = np.column_stack([np.arange(1, n + 1), np.ones(n), pos, np.zeros((n, 3)), np.full(n, D / 2), np.full(n, 1e-5)])
    boxes = np.tile(np.array([[0.0, L], [0.0, L], [-D, 21 * D]]), (snaps, 1, 1))
    return Dump("atoms", COLUMNS, np.arange(snaps) * 100, boxes, ("pp", "pp", "ff"),
                np.arange(snaps + 1) * n, np.tile(block, (snaps, 1)), ("synthetic",))


def test_patches_partition_the_cell_and_predict_the_replica_scatter(rng: np.random.Generator) -> None:
    kernel = Kernel("gaussian", 0.5 * D)
    z = np.linspace(4 * D, 16 * D, 25)
    bulk = np.ones(z.size, dtype=bool)
    cells, errors, alphas = [], [], []
    for _ in range(40):
        dump = frozen_packing(rng)
        snaps = np.arange(len(dump))
        # The four 2 d x 2 d patches of an 8 d cell, 16 in all: their mean is the cell profile.
        patches = structure.patch_profiles(dump, snaps, kernel, z, structure.patch_counts(L, L, D))
        cell = structure.patch_profiles(dump, snaps, kernel, z, (1, 1))[0]
        np.testing.assert_allclose(patches.mean(axis=0), cell, rtol=1e-12)
        err, alpha, counts = structure.structural_error(dump, snaps, kernel, z, D, bulk)
        assert counts == (4, 4)
        cells.append(cell)
        errors.append(err)
        alphas.append(alpha)
    # Independent grains: the variance falls as 1 / area (alpha at its lower bound 1 within the
    # noise of 40 estimates), and the stated error matches the scatter of the 40 replicas' profiles
    # to the precision 40 replicas give (chi-square of 40 samples: +-22 % in variance at 1 sigma).
    assert np.median(alphas) < 1.15
    scatter = np.array(cells).std(axis=0, ddof=1)
    stated = np.sqrt(np.mean(np.array(errors) ** 2, axis=0))
    assert 0.75 < np.mean(scatter**2) / np.mean(stated**2) < 1.35


def test_one_patch_gives_no_structural_error(rng: np.random.Generator) -> None:
    # With grains of 5 d the 8 d cell holds one patch of 2 grain sizes: no scatter to read.
    dump = frozen_packing(rng, n=200)
    err, _, counts = structure.structural_error(dump, np.arange(len(dump)), Kernel("gaussian", D), np.array([0.01]),
                                                5 * D, np.ones(1, dtype=bool))
    assert counts == (1, 1) and np.isnan(err).all()


def test_mean_field_error_predicts_the_replica_scatter_of_a_weighted_mean(rng: np.random.Generator) -> None:
    # Per-grain creep speeds with independent scatter (0.01 m/s about a mean): the error of the
    # cell's kernel-weighted mean profile, from its patches, matches the scatter over replicas.
    kernel = Kernel("gaussian", 0.5 * D)
    z_grid = np.linspace(4 * D, 16 * D, 25)
    box = np.array([[0.0, L], [0.0, L], [-D, 21 * D]])
    cells, errors = [], []
    for _ in range(40):
        n = 1500
        x, y, z = rng.uniform(0, L, n), rng.uniform(0, L, n), rng.uniform(0, 20 * D, n)
        m = rng.uniform(0.5, 1.5, n)
        v = 0.001 + 0.01 * rng.normal(size=n)
        phi = kernel.pdf(z_grid[None, :] - z[:, None]) * m[:, None]
        cells.append((phi * v[:, None]).sum(axis=0) / phi.sum(axis=0))
        err, _, counts = structure.mean_field_error(x, y, z, m, v, box, kernel, z_grid, D, np.ones(z_grid.size, bool))
        assert counts == (4, 4)
        errors.append(err)
    ratio = np.mean(np.array(cells).var(axis=0, ddof=1)) / np.mean(np.array(errors) ** 2)
    assert 0.7 < ratio < 1.4
