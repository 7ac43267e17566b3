"""The :data:`~pipeline.coarse_graining.deposit.SUMS` on an x-z grid (fields averaged over the
periodic y, per unit length in y), all snapshots of a batch in one pass.

Particles deposit their kernel windows, ``phi(x - x_i) phi(z - z_i)``. A contact deposits the line
integral of the kernel along its branch, ``integral_0^1 phi(x - x_1 + s b_x) phi(z - z_1 + s b_z) ds``:
- a branch up to ``LONG_BRANCH`` kernel widths long (every grain-grain contact) by a
  ``CONTACT_POINTS``-point Gauss-Legendre rule along it: on the contact's window the weight is
  ``sum_q w_q phi(x - x_q) phi(z - z_q)``, one small matrix product;
- a longer one (the rod's contacts), or every one with ``exact``, by the exact integral
  (:func:`~pipeline.coarse_graining.kernels.segment_2d`, erf differences on every window entry):
  that cost three quarters of a rod-frame field's CPU (docs/dem_cost.md 33).
The rule's error comes from the truncated Gaussian's kinks at its cut-off: at most 4e-4 of a
contact's peak weight on branches up to 2.5 w, and on the default's pushed rods' fields (w = d / 2,
spacing w / 2) at most 1.4e-4 of each stress field's largest magnitude, 0.027 of its standard error
(``benchmarks/plane_rule.py``). In a bed at rest the standard errors of a time average can be
smaller still: :func:`~pipeline.coarse_graining.coarse_grain.coarse_grain` checks the rule against the
exact integral on a sample of the snapshots and falls back on the exact one where it matters.
"""
from __future__ import annotations

import numpy as np

from pipeline.coarse_graining.deposit import (CHUNK, CONTACT_SUMS, DPHI_SUMS, PHI_SUMS, SUMS, CoarseGrainError, Grid,
                                              SnapshotData, chunks, contact_weights, deposit, particle_weights,
                                              window)
from pipeline.coarse_graining.kernels import Kernel, segment_2d

#: Gauss-Legendre points along a contact's branch.
CONTACT_POINTS = 8
#: Branches longer than this many kernel widths (in the x-z plane) are integrated exactly: the rule's
#: points would lie about a width apart or more (a rod's contacts are 1.5-2 d long, a grain's about d).
LONG_BRANCH = 2.5
_T, _W = np.polynomial.legendre.leggauss(CONTACT_POINTS)
_T, _W = 0.5 * (_T + 1.0), 0.5 * _W


def _bins(ix: np.ndarray, iz: np.ndarray, ok: np.ndarray, sid: np.ndarray, grid: Grid, size: int) -> np.ndarray:
    """Flat bin of every window entry, (rows, wx * wz); the last bin (``size - 1``) where ``ok`` is False."""
    assert grid.x is not None
    nx, nz = grid.x.size, grid.z.size
    flat = np.where(ok, (ix % nx)[:, :, None] * nz + iz[:, None, :] + (sid * nx * nz)[:, None, None], size - 1)
    return flat.reshape(ix.shape[0], -1)


def _branch_windows(data: SnapshotData, rows: np.ndarray, grid: Grid, c: float
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, tuple[np.ndarray, ...]]:
    """The grid window of each contact of ``rows``, covering its branch and the cut-off around it (sized
    for the longest branch among them): x indices (periodic, not yet wrapped) and grid x, z indices,
    their validity and grid z; and the branch's ends (x1, z1, x2, z2)."""
    assert grid.x is not None
    r1, branch = data.r1[rows], data.branch[rows]
    x1, z1 = r1[:, 0], r1[:, 2]
    x2, z2 = x1 - branch[:, 0], z1 - branch[:, 2]  # x2 unwrapped next to x1
    ix, _ = window(np.minimum(x1, x2) - c, float(np.max(np.abs(branch[:, 0]))) + 2 * c, float(grid.x[0]), grid.dx,
                   10**18)
    iz, okz = window(np.minimum(z1, z2) - c, float(np.max(np.abs(branch[:, 2]))) + 2 * c, float(grid.z[0]), grid.dz,
                     grid.z.size)
    return ix, float(grid.x[0]) + ix * grid.dx, iz, okz, float(grid.z[0]) + iz * grid.dz, (x1, z1, x2, z2)


def _ruled_contacts(data: SnapshotData, rows: np.ndarray, kernel: Kernel, grid: Grid, csid: np.ndarray,
                    size: int) -> np.ndarray:
    """The contact sums (columns of ``CONTACT_SUMS``) of the contacts ``rows`` by the Gauss-Legendre rule."""
    ix, xk, iz, okz, zk, _ = _branch_windows(data, rows, grid, kernel.cutoff)
    r1, branch = data.r1[rows], data.branch[rows]
    # the rule's points from particle 1 (s = 0) to particle 2 (s = 1): (rows, points)
    xq = r1[:, 0, None] - _T[None, :] * branch[:, 0, None]
    zq = r1[:, 2, None] - _T[None, :] * branch[:, 2, None]
    px = kernel.pdf(xk[:, None, :] - xq[:, :, None]) * _W[None, :, None]  # (rows, points, wx)
    pz = kernel.pdf(zk[:, None, :] - zq[:, :, None])  # (rows, points, wz)
    weight = np.matmul(px.transpose(0, 2, 1), pz)  # (rows, wx, wz)
    flat = _bins(ix, iz, np.broadcast_to(okz[:, None, :], weight.shape), csid[rows], grid, size)
    return deposit(flat, weight.reshape(rows.size, -1), size, contact_weights(data, rows))


def _exact_contacts(data: SnapshotData, rows: np.ndarray, kernel: Kernel, grid: Grid, csid: np.ndarray,
                    size: int) -> np.ndarray:
    """The contact sums of the contacts ``rows`` by the exact line integral (:func:`segment_2d`) at
    every grid point within the cut-off of the branch's extent (at the others the path misses the
    support and the weight is exactly 0; the slack of 1e-9 c only guards rounding)."""
    c = kernel.cutoff
    ix, xk, iz, okz, zk, (x1, z1, x2, z2) = _branch_windows(data, rows, grid, c)
    reach = c * (1.0 + 1e-9)
    near_x = (xk > np.minimum(x1, x2)[:, None] - reach) & (xk < np.maximum(x1, x2)[:, None] + reach)
    near_z = okz & (zk > np.minimum(z1, z2)[:, None] - reach) & (zk < np.maximum(z1, z2)[:, None] + reach)
    ok = near_x[:, :, None] & near_z[:, None, :]
    shape = ok.shape
    xg, zg = xk[:, :, None], zk[:, None, :]
    weight = np.zeros(shape)
    weight[ok] = segment_2d(kernel, np.broadcast_to(xg - x1[:, None, None], shape)[ok],
                            np.broadcast_to(zg - z1[:, None, None], shape)[ok],
                            np.broadcast_to(xg - x2[:, None, None], shape)[ok],
                            np.broadcast_to(zg - z2[:, None, None], shape)[ok])
    flat = _bins(ix, iz, ok, csid[rows], grid, size)
    return deposit(flat, weight.reshape(rows.size, -1), size, contact_weights(data, rows))


def _contact_sums(data: SnapshotData, kernel: Kernel, grid: Grid, csid: np.ndarray, size: int,
                  exact: bool) -> np.ndarray:
    """Every contact's sums, (size, len(CONTACT_SUMS)): short branches by the rule, long ones (all
    with ``exact``) exactly, in chunks of about 4 ``CHUNK`` window entries (the temporaries stay in
    cache)."""
    c = kernel.cutoff
    out = np.zeros((size, len(CONTACT_SUMS)))
    long = np.hypot(data.branch[:, 0], data.branch[:, 2]) > (0.0 if exact else LONG_BRANCH * kernel.width)
    for rows, part in ((np.nonzero(~long)[0], _ruled_contacts), (np.nonzero(long)[0], _exact_contacts)):
        if rows.size:
            wx = int(np.floor((float(np.max(np.abs(data.branch[rows, 0]))) + 2 * c) / grid.dx)) + 2
            wz = int(np.floor((float(np.max(np.abs(data.branch[rows, 2]))) + 2 * c) / grid.dz)) + 2
            for chunk in chunks(rows, wx * wz, 4 * CHUNK):
                out += part(data, chunk, kernel, grid, csid, size)
    return out


def plane_sums(data: SnapshotData, kernel: Kernel, grid: Grid, exact: bool = False) -> np.ndarray:
    """The :data:`SUMS` on an x-z grid, per unit length in y: (len(SUMS), nx, nz) for one snapshot,
    or (snapshots, len(SUMS), nx, nz) for a batch (:func:`~pipeline.coarse_graining.coarse_grain.batch`).
    ``exact``: every contact by the exact line integral (module docstring).

    x is periodic (the grid spans the box); the kernel's support must fit in the box."""
    assert grid.x is not None
    nx, nz = grid.x.size, grid.z.size
    x0, dx, z0, dz = float(grid.x[0]), grid.dx, float(grid.z[0]), grid.dz
    nsnap = data.nsnap
    lengths = (data.box[:, 1] - data.box[:, 0])[None, :] if data.lengths is None else data.lengths
    lx, ly = lengths[:, 0], lengths[:, 1]
    c = kernel.cutoff
    cells = nx * nz
    size = nsnap * cells + 1  # the last bin collects the off-grid entries
    out = np.zeros((size, len(SUMS)))
    if not data.periodic[0]:
        raise CoarseGrainError("x-z fields need a periodic x direction")
    if 2 * c >= lx.min():
        raise CoarseGrainError(f"kernel support 2 x {c:.3g} m exceeds the periodic length {lx.min():.3g} m")
    psid = np.zeros(data.mass.size, np.int64) if data.psid is None else data.psid
    csid = np.zeros(data.force.shape[0], np.int64) if data.csid is None else data.csid

    if data.mass.size:
        ix, _ = window(data.pos[:, 0] - c, 2 * c, x0, dx, 10**18)
        px = kernel.pdf(x0 + ix * dx - data.pos[:, 0:1])
        iz, okz = window(data.pos[:, 2] - c, 2 * c, z0, dz, nz)
        pz, dpz = kernel.pdf_dpdf(z0 + iz * dz - data.pos[:, 2:3])
        pz[~okz] = 0.0
        dpz[~okz] = 0.0
        n = ix.shape[0]
        flat = _bins(ix, iz, np.broadcast_to(okz[:, None, :], (n, ix.shape[1], iz.shape[1])), psid, grid, size)
        phi = (px[:, :, None] * pz[:, None, :]).reshape(n, -1)
        dphi = (px[:, :, None] * dpz[:, None, :]).reshape(n, -1)
        phi_w, dphi_w = particle_weights(data)
        out[:, PHI_SUMS] = deposit(flat, phi, size, phi_w)
        out[:, DPHI_SUMS] = deposit(flat, dphi, size, dphi_w)

    if data.force.shape[0]:
        spanx = float(np.max(np.abs(data.branch[:, 0]))) + 2 * c
        if spanx >= lx.min():
            raise CoarseGrainError(f"kernel support plus branch ({spanx:.3g} m) exceeds the periodic length "
                                   f"{lx.min():.3g} m")
        out[:, CONTACT_SUMS] += _contact_sums(data, kernel, grid, csid, size, exact)
    out = out[:-1].reshape(nsnap, cells, len(SUMS)).transpose(0, 2, 1).reshape(nsnap, len(SUMS), nx, nz)
    if data.areas is None:
        return out[0] / ly[0]
    return out / ly[:, None, None, None]
