"""The solid fraction's error from the packing's frozen structure: patches of the cell as replicas.

A time average cannot see the part of a solid-fraction profile that is frozen into the packing
(layering against a rough wall, denser and looser regions in the creeping bed): it does not
change over the window, so block means agree and the time error is tiny, while another replica,
a different packing, has another structure. Replica scatter then exceeds the time errors by a
factor of hundreds (the default run's replica chi-square of nu was 9e4).

The cell is cut in the plane into patches; each patch's time-averaged profile
``nu_k(z) = sum_{i in k} V_i phi(z - z_i) / A_k`` is a sub-sample of the structure. For
independent grains the variance of a region's mean falls as 1 / area, and the cell's error would
be ``std_k(nu_k) / sqrt(K)``; a dense packing suppresses density fluctuations (they fall faster
with the area), so that overstates it (replica chi-square 0.1-0.2 on the default run). The
variance is therefore measured at two patch sizes, ``PATCH_OVER_D`` d and twice that, its decay
exponent ``alpha`` (variance ~ area^-alpha, bulk-averaged, held in [0.5, 2]: from structure
correlated over more than a patch, through Poisson, to surface-like fluctuations) fitted, and the fine patches' variance extrapolated to the cell's
area: ``err(z)^2 = var_k(nu_k)(z) (A_patch / A_cell)^alpha``. A cell too small for two patch
sizes takes alpha = 1. A patch's own time noise is part of its scatter. Units: dimensionless.
"""
from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp

from pipeline.coarse_graining.kernels import Kernel
from pipeline.dumps.reader import Dump

#: Smallest patch side, in d: density correlations in dense packings decay over one to two grains.
PATCH_OVER_D = 2.0
#: Range of the variance's decay exponent with the patch area (1: independent grains; below 1:
#: structure correlated over more than a patch, e.g. creep moving in blocks).
ALPHA_RANGE = (0.5, 2.0)


def patch_counts(lx: float, ly: float, d: float, side_over_d: float = PATCH_OVER_D) -> tuple[int, int]:
    """Patches along x and y (at least one each) of side at least ``side_over_d`` d."""
    # The small tolerance keeps an 8 d cell at 4 patches of 2 d despite rounding of lx.
    return (max(1, int(lx / (side_over_d * d) + 1e-9)), max(1, int(ly / (side_over_d * d) + 1e-9)))


def _patch_index(x: np.ndarray, y: np.ndarray, box: np.ndarray, counts: tuple[int, int]) -> np.ndarray:
    """Patch number of each grain at (x, y) (m) among ``counts = (nx, ny)`` equal patches of the box."""
    nx, ny = counts
    lx, ly = float(box[0, 1] - box[0, 0]), float(box[1, 1] - box[1, 0])
    kx = np.clip(((x - box[0, 0]) / lx * nx).astype(int), 0, nx - 1)
    ky = np.clip(((y - box[1, 0]) / ly * ny).astype(int), 0, ny - 1)
    return kx * ny + ky


def patch_profiles(particles: Dump, snapshots: np.ndarray, kernel: Kernel, z_grid: np.ndarray,
                   counts: tuple[int, int], body_types: tuple[int, ...] = (1,)) -> np.ndarray:
    """Time-averaged solid-fraction profiles of ``counts = (nx, ny)`` patches, shape (patches, z)."""
    i_t, i_x, i_y, i_z, i_r = (particles.index(c) for c in ("type", "x", "y", "z", "radius"))
    box = particles.boxes[snapshots[0]]
    lx, ly = float(box[0, 1] - box[0, 0]), float(box[1, 1] - box[1, 0])
    nx, ny = counts
    area = lx * ly / (nx * ny)
    total = np.zeros((nx * ny, z_grid.size))
    for s in snapshots:
        rows = particles.rows(int(s))
        rows = rows[np.isin(rows[:, i_t], body_types)]
        volume = 4.0 / 3.0 * math.pi * rows[:, i_r] ** 3
        weight = kernel.pdf(z_grid[None, :] - rows[:, i_z, None]) * volume[:, None]
        patch = _patch_index(rows[:, i_x], rows[:, i_y], box, counts)
        # the sum of each patch's grains' rows: a (patches x grains) 0/1 matrix product; the whole
        # function in half np.add.at's time on the default's shear_gravity r1 (0.37-0.43 s against
        # 0.79-0.81 s, equal to 9e-15)
        total += sp.csr_matrix((np.ones(patch.size), (patch, np.arange(patch.size))), shape=(nx * ny, patch.size)) @ weight
    return total / (len(snapshots) * area)


def _extrapolate(var_fine: np.ndarray, var_coarse: np.ndarray | None, k_fine: int, k_coarse: int,
                 bulk: np.ndarray) -> tuple[np.ndarray, float]:
    """The cell's error from the fine patches' variance, with the area exponent fitted between
    the two patch sizes over ``bulk`` (module docstring)."""
    alpha = ALPHA_RANGE[0]
    if var_coarse is not None and k_coarse >= 2 and bulk.any():
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio = float(np.nanmean(var_fine[bulk])) / float(np.nanmean(var_coarse[bulk]))
        if ratio > 0 and math.isfinite(ratio):
            alpha = float(np.clip(math.log(ratio) / math.log(k_fine / k_coarse), *ALPHA_RANGE))
    return np.sqrt(var_fine * (1.0 / k_fine) ** alpha), alpha


def structural_error(particles: Dump, snapshots: np.ndarray, kernel: Kernel, z_grid: np.ndarray, d: float,
                     bulk: np.ndarray) -> tuple[np.ndarray, float, tuple[int, int]]:
    """The cell profile's structural error on ``z_grid``, the exponent ``alpha`` used and the fine
    patch counts (module docstring); ``bulk`` marks the grid points alpha is fitted on. NaN where
    the cell holds a single patch."""
    box = particles.boxes[snapshots[0]]
    lx, ly = float(box[0, 1] - box[0, 0]), float(box[1, 1] - box[1, 0])
    fine = patch_counts(lx, ly, d)
    k_fine = fine[0] * fine[1]
    if k_fine < 2:
        return np.full(z_grid.size, np.nan), math.nan, fine
    var_fine = patch_profiles(particles, snapshots, kernel, z_grid, fine).var(axis=0, ddof=1)
    coarse = (max(1, fine[0] // 2), max(1, fine[1] // 2))
    k_coarse = coarse[0] * coarse[1]
    var_coarse = patch_profiles(particles, snapshots, kernel, z_grid, coarse).var(axis=0, ddof=1) if k_coarse >= 2 else None
    err, alpha = _extrapolate(var_fine, var_coarse, k_fine, k_coarse, bulk)
    return err, alpha, fine


def mean_field_error(x: np.ndarray, y: np.ndarray, z: np.ndarray, weight: np.ndarray, value: np.ndarray,
                     box: np.ndarray, kernel: Kernel, z_grid: np.ndarray, d: float,
                     bulk: np.ndarray) -> tuple[np.ndarray, float, tuple[int, int]]:
    """The same for a weighted-mean field ``u(z) = sum w v phi / sum w phi`` of per-grain values
    ``value`` (grains at ``x``, ``y``, ``z`` in m, weights ``weight``, e.g. masses): each patch's
    profile is its own weighted mean. NaN where a patch has no weight (its variance skips it)."""
    lx, ly = float(box[0, 1] - box[0, 0]), float(box[1, 1] - box[1, 0])
    phi = kernel.pdf(z_grid[None, :] - z[:, None]) * weight[:, None]

    def variance(counts: tuple[int, int]) -> np.ndarray:
        k = _patch_index(x, y, box, counts)
        num, den = np.zeros((counts[0] * counts[1], z_grid.size)), np.zeros((counts[0] * counts[1], z_grid.size))
        np.add.at(num, k, phi * value[:, None])
        np.add.at(den, k, phi)
        with np.errstate(invalid="ignore", divide="ignore"):
            profiles = np.where(den > 0, num / np.where(den > 0, den, 1.0), np.nan)
        counted = np.isfinite(profiles).sum(axis=0)
        mean = np.nanmean(np.where(counted > 0, profiles, 0.0), axis=0)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(counted > 1, np.nansum((profiles - mean) ** 2, axis=0) / np.maximum(counted - 1, 1), np.nan)

    fine = patch_counts(lx, ly, d)
    k_fine = fine[0] * fine[1]
    if k_fine < 2:
        return np.full(z_grid.size, np.nan), math.nan, fine
    coarse = (max(1, fine[0] // 2), max(1, fine[1] // 2))
    k_coarse = coarse[0] * coarse[1]
    err, alpha = _extrapolate(variance(fine), variance(coarse) if k_coarse >= 2 else None, k_fine, k_coarse, bulk)
    return err, alpha, fine
