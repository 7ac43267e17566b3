"""The :data:`~pipeline.coarse_graining.deposit.SUMS` on a z profile (fields averaged over the
periodic x and y, per unit area): particles by their kernel windows, contacts by the exact
line integral of the kernel along each branch (a cdf difference, :meth:`Kernel.segment`).
"""
from __future__ import annotations

import math

import numpy as np

from pipeline.coarse_graining.deposit import (CONTACT_AB, CONTACT_SUMS, DPHI_SUMS, PHI_SUMS, SUMS, Grid, SnapshotData, chunks,
                                              contact_weights, deposit, index_type, particle_weights, window)
from pipeline.coarse_graining.kernels import Kernel


class _CdfTable:
    """``kernel.cdf(z0 + k dz - h)`` for each distinct contact-end height ``h`` on the grid points
    ``k`` of that height's own window, evaluated once per height (a grain's height repeats in
    each of its contacts) and looked up for every contact.

    Outside a height's window the argument is beyond the cut-off, where ``cdf`` is the constant
    ``cdf(-c)`` (below) or ``cdf(c)`` (above): its value for any argument past the cut-off."""

    def __init__(self, kernel: Kernel, z: np.ndarray, z0: float, dz: float, nz: int) -> None:
        c = kernel.cutoff
        heights, self.inverse = np.unique(z, return_inverse=True)
        self.width = int(math.floor(2 * c / dz)) + 2
        self.table = np.empty((heights.size, self.width + 2))
        self.first = np.empty(heights.size, np.int64)
        for sl in chunks(heights.size, self.width):
            hidx, _ = window(heights[sl] - c, 2 * c, z0, dz, nz)
            self.first[sl] = hidx[:, 0]
            self.table[sl, 1:-1] = kernel.cdf(z0 + hidx * dz - heights[sl, None])
        self.table[:, 0], self.table[:, -1] = np.asarray(kernel.cdf(np.array([-c, c])), dtype=np.float64).reshape(2)
        self.flat = self.table.reshape(-1)

    def __call__(self, ends: np.ndarray, idx: np.ndarray) -> np.ndarray:
        """The cdf for the contact ends ``ends`` (positions in the ``z`` given) at grid indices ``idx``."""
        which = self.inverse[ends]
        col = idx - (self.first[which] - 1)[:, None]
        np.clip(col, 0, self.width + 1, out=col)
        col += (which * (self.width + 2))[:, None]
        return self.flat[col]


def _contact_profile(data: SnapshotData, kernel: Kernel, z0: float, dz: float, nz: int,
                     csid: np.ndarray, dummy: int) -> tuple[np.ndarray, np.ndarray]:
    """Windows (flat bin indices, off-grid entries at bin ``dummy``) and exact branch weights (zero
    off the grid) of the contacts on a z profile."""
    c = kernel.cutoff
    z1 = np.ascontiguousarray(data.r1[:, 2])
    z2 = z1 - data.branch[:, 2]
    n = z1.size
    lo = np.minimum(z1, z2) - c
    span = float(np.max(np.abs(data.branch[:, 2]))) + 2 * c
    width = int(math.floor(span / dz)) + 2
    # Contacts with no grid point inside their support [min z - c, max z + c] contribute nothing
    # (beyond the cut-off both cdf values are the same constant, so the weight is exactly 0): skip
    # them. The slack of 1e-9 c only guards the rounding of the bounds.
    slack = 1e-9 * c
    kmin = np.maximum(np.ceil((lo - slack - z0) / dz), 0.0)
    kmax = np.minimum(np.floor((np.maximum(z1, z2) + c + slack - z0) / dz), nz - 1.0)
    rows = np.nonzero(kmin <= kmax)[0]
    flat = np.full((n, width), dummy, dtype=index_type(dummy + 1, n * width))
    weight = np.zeros((n, width))
    if rows.size == 0:
        return flat, weight
    cdf = _CdfTable(kernel, np.concatenate([z1[rows], z2[rows]]), z0, dz, nz)
    m = rows.size
    for part in chunks(np.arange(m), width):
        sel = rows[part]
        idx, ok = window(lo[sel], span, z0, dz, nz)
        zk = z0 + idx * dz
        values = kernel.segment(zk - z1[sel, None], zk - z2[sel, None], cdf1=cdf(part, idx), cdf2=cdf(part + m, idx))
        values[~ok] = 0.0
        weight[sel] = values
        flat[sel] = np.where(ok, idx + (csid[sel] * nz)[:, None], dummy)
    return flat, weight


#: Contacts with |branch z| below this many kernel widths take the per-contact path of the profile
#: contact sums; the others the telescoped one (:func:`_contact_profile_sums`), whose per-end
#: coefficients f r / |branch z| then stay below 100 f r / w (rounding amplified at most 100 times).
FLAT_BRANCH = 0.01


def _contact_profile_sums(data: SnapshotData, kernel: Kernel, z0: float, dz: float, nz: int, csid: np.ndarray,
                          nsnap: int) -> np.ndarray:
    """Contact sums ``sum_c f_a r_b w_c(z_k)`` (columns c_xx, c_yy, c_zz, c_xz, c_zx) on a profile,
    shape (nsnap nz, 5), before division by the area.

    The exact weight ``w_c(z) = (C(z - z2) - C(z - z1)) / (z1 - z2)`` (``C`` the kernel cdf) is a
    difference of two cdf terms, so the sum over contacts telescopes into a sum over the distinct
    contact-end heights ``h`` of each snapshot: ``sum_h G_h C(z - h)``, ``G_h`` the sum of
    ``+-f_a r_b / (z1 - z2)`` over the contact ends at ``h``. ``C(z - h)`` is tabulated on the
    window of ``h`` once, and above the window (where ``C`` is the constant ``C(c)``) its part is a
    cumulative sum over the grid. No work per (contact, grid point) pair remains. Contacts with
    ``|z1 - z2| < FLAT_BRANCH w`` would make ``G`` large and cancel; they use the per-contact path
    (:func:`_contact_profile`)."""
    c = kernel.cutoff
    size = nsnap * nz
    out = np.zeros((size + 1, len(CONTACT_AB)))
    z1, bz = data.r1[:, 2], data.branch[:, 2]
    z2 = z1 - bz
    # Contacts with no grid point inside their support [min z - c, max z + c] contribute exactly
    # nothing (their weight is 0 at every grid point): skip them, as _contact_profile does.
    slack = 1e-9 * c
    kmin = np.maximum(np.ceil((np.minimum(z1, z2) - c - slack - z0) / dz), 0.0)
    kmax = np.minimum(np.floor((np.maximum(z1, z2) + c + slack - z0) / dz), nz - 1.0)
    hits = kmin <= kmax
    flat_branch = np.abs(bz) < FLAT_BRANCH * kernel.width
    few = np.nonzero(flat_branch & hits)[0]
    if few.size:
        sub = SnapshotData(data.pos[:0], data.vel[:0], data.mass[:0], data.volume[:0], data.body[:0], data.r1[few],
                           data.branch[few], data.force[few], data.box, data.periodic)
        flat, weight = _contact_profile(sub, kernel, z0, dz, nz, csid[few], size)
        out += deposit(flat, weight, size + 1, contact_weights(sub))
    steep = np.nonzero(~flat_branch & hits)[0]
    if steep.size == 0:
        return out[:-1]
    every = steep.size == bz.size
    f, r = (data.force, data.branch) if every else (data.force[steep], data.branch[steep])
    # Contact ends (z2 with +f_a r_b / bz, z1 with -f_a r_b / bz) grouped by (snapshot, height).
    ends = np.concatenate([z2, z1] if every else [z2[steep], z1[steep]])
    sid = np.concatenate([csid, csid] if every else [csid[steep], csid[steep]])
    # Sorted by snapshot, then height. Only equal (snapshot, height) pairs must end up adjacent:
    # a rounded key that merely orders neighbours loosely at worst splits a group in two.
    order = np.argsort(ends + sid * (2.0 * float(np.ptp(ends)) + 1.0))
    ends, sid = ends[order], sid[order]
    new = np.empty(ends.size, bool)
    new[0] = True
    new[1:] = (ends[1:] != ends[:-1]) | (sid[1:] != sid[:-1])
    group = np.empty(ends.size, np.int64)
    group[order] = np.cumsum(new) - 1
    heights, hsid = ends[new], sid[new]
    coeff = np.empty((heights.size, len(CONTACT_AB)))
    for q, (a, b) in enumerate(CONTACT_AB):
        g = f[:, a] * r[:, b] / r[:, 2]
        coeff[:, q] = np.bincount(group, np.concatenate([g, -g]), heights.size)
    low, high = (float(v) for v in np.asarray(kernel.cdf(np.array([-c, c])), dtype=np.float64).reshape(2))
    width = int(math.floor(2 * c / dz)) + 2
    table = np.empty((heights.size, width))
    flat = np.empty((heights.size, width), dtype=index_type(size + 1, heights.size * width))
    above = np.empty(heights.size, np.int64)
    for sl in chunks(heights.size, width):
        hidx, ok = window(heights[sl] - c, 2 * c, z0, dz, nz)
        table[sl] = kernel.cdf(z0 + hidx * dz - heights[sl, None])
        table[sl] -= low
        flat[sl] = np.where(ok, hidx + (hsid[sl] * nz)[:, None], size)
        above[sl] = hidx[:, -1] + 1
    # C(z - h) = low + (table - low) on the window + (high - low) from the window's end upwards.
    out += deposit(flat, table, size + 1, coeff)
    start = np.where(above < nz, np.maximum(above, 0) + hsid * nz, size)
    steps = np.stack([np.bincount(start, (high - low) * coeff[:, q], size + 1) for q in range(coeff.shape[1])], axis=1)
    out[:-1] += np.cumsum(steps[:-1].reshape(nsnap, nz, -1), axis=1).reshape(size, -1)
    per_snapshot = np.stack([np.bincount(hsid, coeff[:, q], nsnap) for q in range(coeff.shape[1])], axis=1)
    out[:-1] += low * np.repeat(per_snapshot, nz, axis=0)
    return out[:-1]


def profile_sums(data: SnapshotData, kernel: Kernel, grid: Grid, particles: bool = True) -> np.ndarray:
    """The :data:`SUMS` on a z profile, per unit area: (len(SUMS), nz) for one snapshot, or
    (snapshots, len(SUMS), nz) for a batch (:func:`batch`).

    ``particles=False`` computes the contact sums only (the particle sums are left zero)."""
    nz, z0, dz = grid.z.size, float(grid.z[0]), grid.dz
    nsnap = data.nsnap
    c = kernel.cutoff
    # Rows of snapshot s go to bins s nz + k; bin nsnap nz collects the window entries that fall
    # off the grid and is discarded.
    dummy = nsnap * nz
    size = dummy + 1
    out = np.zeros((size, len(SUMS)))
    psid = np.zeros(data.mass.size, np.int64) if data.psid is None else data.psid
    csid = np.zeros(data.force.shape[0], np.int64) if data.csid is None else data.csid
    n = data.mass.size
    if particles and n:
        z = np.ascontiguousarray(data.pos[:, 2])
        width = int(math.floor(2 * c / dz)) + 2
        phi, dphi = np.empty((n, width)), np.empty((n, width))
        flat = np.empty((n, width), dtype=index_type(size, n * width))
        for sl in chunks(n, width):
            idx, ok = window(z[sl] - c, 2 * c, z0, dz, nz)
            p, dp = kernel.pdf_dpdf(z0 + idx * dz - z[sl, None])
            p[~ok] = 0.0
            dp[~ok] = 0.0
            phi[sl], dphi[sl] = p, dp
            flat[sl] = np.where(ok, idx + (psid[sl] * nz)[:, None], dummy)
        phi_w, dphi_w = particle_weights(data)
        out[:, PHI_SUMS] = deposit(flat, phi, size, phi_w)
        out[:, DPHI_SUMS] = deposit(flat, dphi, size, dphi_w)
    if data.force.shape[0]:
        out[:-1, CONTACT_SUMS] = _contact_profile_sums(data, kernel, z0, dz, nz, csid, nsnap)
    out = out[:-1].reshape(nsnap, nz, len(SUMS)).transpose(0, 2, 1)
    if data.areas is None:
        return out[0] / float(np.prod(data.box[:2, 1] - data.box[:2, 0]))
    return out / data.areas[:, None, None]
