"""Coarse-grain DEM particles and contacts into continuum fields (Goldhirsch 2010; Weinhart et al. 2012).

Conventions (docs/physics.md): compressive stress positive; flow x, gradient z (up), vorticity y.
With the product kernel of :mod:`pipeline.coarse_graining.kernels` integrated exactly over the periodic x and y
(profiles, per unit area ``A = Lx Ly``) or over y (x-z fields, per unit length ``Ly``):

- density ``rho = sum_i m_i phi(r - r_i)``; solid fraction ``nu = sum_i V_i phi`` (``V = 4/3 pi R^3``);
- velocity ``u = <sum m v phi> / <rho>`` (momentum over density, both time-averaged: Favre mean);
- kinetic stress ``<sum m v v phi> - <rho> u u``: fluctuations about the time-averaged local mean
  velocity, so that the time-averaged fields obey the time-averaged momentum balance;
- contact stress ``sum_c f_c (x) r_c * integral_0^1 phi(r - r_1 + s r_c) ds`` with ``f_c`` the
  force on particle 1 and ``r_c = r_1 - r_2`` (minimum image across periodic faces), summed over
  every contact in the dump, flowing-wall contacts included; the line integral is exact (an erf
  or polynomial difference, :meth:`Kernel.segment`). ``sigma_ab = sum f_a r_b ...`` so that the
  momentum balance reads ``d sigma_xz / dz = 0``, ``d sigma_zz / dz = -rho g`` in steady planar
  flow. With this sign ``sigma_xz`` is negative where ``du_x/dz > 0``.
- ``p = trace / 3``; ``mu = |sigma_xz| / p``; ``shear_rate = du_x/dz`` differentiated exactly
  (the kernel derivative applied to the time-averaged momentum and density); ``I = |shear_rate|
  d / sqrt(p / rho_s)``.

Errors: the snapshots in the window are split into ``blocks`` contiguous blocks (default 5);
every field is computed from each block's averages and its standard error is the standard
deviation of the block values over sqrt(blocks).

Command line: :mod:`pipeline.coarse_graining.dumps_cli` (``python -m pipeline.coarse_graining``).
"""
from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import scipy.sparse as sp
import xarray as xr

from pipeline.dumps.reader import Dump, check_particle_rows
from pipeline.common import atomic
from pipeline.common.statistics import integrated_autocorrelation_time
from pipeline.coarse_graining.kernels import Kernel, segment_2d
from pipeline.coarse_graining.pairing import contact_index

#: Raw per-snapshot sums (per unit area or length) that all fields derive from.
SUMS = ("mass", "mass_body", "volume", "mom_x", "mom_y", "mom_z", "mvv_xx", "mvv_yy", "mvv_zz", "mvv_xz",
        "dmass", "dmom_x", "c_xx", "c_yy", "c_zz", "c_xz", "c_zx")
#: Particle rows coarse-grained in one vectorised pass (bounds the temporaries to ~100 MB).
BATCH_ROWS = 200_000

#: Output fields: (units, long name). Every field also gets an ``_err`` companion.
FIELDS: dict[str, tuple[str, str]] = {
    "nu": ("1", "solid fraction"),
    "rho": ("kg m-3", "mass density (all grains)"),
    "rho_body": ("kg m-3", "mass density of the grains gravity acts on"),
    "u_x": ("m s-1", "velocity along x (flow)"),
    "u_z": ("m s-1", "velocity along z (gradient, up)"),
    "shear_rate": ("s-1", "shear rate du_x/dz (exact derivative of the coarse-grained u_x)"),
    "sigma_xx": ("Pa", "normal stress xx, contact plus kinetic, compressive positive"),
    "sigma_yy": ("Pa", "normal stress yy, contact plus kinetic, compressive positive"),
    "sigma_zz": ("Pa", "normal stress zz, contact plus kinetic, compressive positive"),
    "sigma_xz": ("Pa", "shear stress xz (x force across z planes), contact plus kinetic, compressive-positive sign"),
    "sigma_xz_contact": ("Pa", "contact part of sigma_xz"),
    "sigma_xz_kinetic": ("Pa", "kinetic part of sigma_xz"),
    "sigma_zx_contact": ("Pa", "contact part of sigma_zx (z force across x planes; equals sigma_xz_contact on average)"),
    "sigma_zz_kinetic": ("Pa", "kinetic part of sigma_zz"),
    "p": ("Pa", "mean normal stress, trace / 3"),
    "mu": ("1", "stress ratio |sigma_xz| / p"),
    "I": ("1", "inertial number |shear_rate| d / sqrt(p / rho_s)"),
    "fluidity": ("s-1", "operational granular fluidity shear_rate / mu (Zhang & Kamrin 2017)"),
    "granular_temperature": ("m2 s-2", "granular temperature: trace of the kinetic stress / (3 rho), velocity "
                             "fluctuations about the local mean (includes the mean-flow variation within the kernel)"),
}


class CoarseGrainError(ValueError):
    """Inputs the coarse-graining cannot use (empty window, bad grid, missing columns)."""


@dataclass(frozen=True)
class Grid:
    """Where fields are evaluated: z centres (m), and for x-z fields x centres (periodic, m)."""

    z: np.ndarray
    x: np.ndarray | None = None

    @property
    def dz(self) -> float:
        return float(self.z[1] - self.z[0]) if self.z.size > 1 else 1.0

    @property
    def dx(self) -> float:
        assert self.x is not None
        return float(self.x[1] - self.x[0]) if self.x.size > 1 else 1.0


def profile_grid(z_lo: float, z_hi: float, bins: int | None = None, dz: float | None = None) -> Grid:
    """Uniform z centres from ``z_lo`` to ``z_hi`` (inclusive): ``bins`` points or spacing ``dz``."""
    if bins is None:
        if dz is None or dz <= 0:
            raise CoarseGrainError("give a positive bin count or spacing")
        bins = max(2, int(round((z_hi - z_lo) / dz)) + 1)
    if bins < 2 or not z_hi > z_lo:
        raise CoarseGrainError(f"need at least 2 bins over a positive range, got {bins} over [{z_lo}, {z_hi}]")
    return Grid(np.linspace(z_lo, z_hi, bins))


def plane_grid(x_lo: float, lx: float, z_lo: float, z_hi: float, dx: float, bins_z: int | None = None) -> Grid:
    """x-z grid: x centres cover the periodic length ``lx`` with a spacing near ``dx``."""
    nx = max(2, int(round(lx / dx)))
    x = x_lo + (np.arange(nx) + 0.5) * (lx / nx)
    return Grid(profile_grid(z_lo, z_hi, bins=bins_z, dz=None if bins_z else dx).z, x)


# ---------------------------------------------------------------------------------------------
# One snapshot


@dataclass
class SnapshotData:
    """Arrays of one snapshot: particle and contact quantities (SI)."""

    pos: np.ndarray  # (N, 3) m
    vel: np.ndarray  # (N, 3) m/s
    mass: np.ndarray  # (N,) kg
    volume: np.ndarray  # (N,) m3
    body: np.ndarray  # (N,) bool: gravity acts on the grain
    r1: np.ndarray  # (M, 3) m, position of particle 1
    branch: np.ndarray  # (M, 3) m, r1 - r2 with the minimum image across periodic faces
    force: np.ndarray  # (M, 3) N, on particle 1
    box: np.ndarray  # (3, 2) m (the first snapshot's, for a batch)
    periodic: tuple[bool, bool, bool]
    # A batch of snapshots: snapshot index of every particle row and contact row, cell areas.
    psid: np.ndarray | None = None
    csid: np.ndarray | None = None
    areas: np.ndarray | None = None
    lengths: np.ndarray | None = None  # (snapshots, 3) m, box lengths of each snapshot of a batch

    @property
    def nsnap(self) -> int:
        return 1 if self.areas is None else int(self.areas.size)


def snapshot(particles: Dump, contacts: Dump | None, s: int, body_types: Sequence[int] | None = (1,)) -> SnapshotData:
    """Arrays of particle snapshot ``s`` and of the contact snapshot at the same timestep."""
    data = batch(particles, contacts, np.array([s]), body_types)
    data.psid = data.csid = data.areas = data.lengths = None
    return data


def _rows(dump: Dump, snaps: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rows of several snapshots and the batch index (0..len(snaps)-1) of each row."""
    counts = dump.counts[snaps]
    if snaps.size == 1:
        return dump.rows(int(snaps[0])), np.zeros(int(counts[0]), dtype=np.int64)
    if np.all(np.diff(snaps) == 1):  # consecutive snapshots (a time window): a view, no copy
        rows = dump.data[dump.offsets[snaps[0]]:dump.offsets[snaps[-1] + 1]]
    else:
        rows = np.concatenate([dump.rows(int(k)) for k in snaps])
    return rows, np.repeat(np.arange(snaps.size), counts)


def _columns(rows: np.ndarray, columns: Sequence[str], names: Sequence[str]) -> np.ndarray:
    """The named columns of ``rows``: a read-only view when they are adjacent and in order (no copy),
    else a copy."""
    idx = [columns.index(n) for n in names]
    if idx == list(range(idx[0], idx[0] + len(idx))):
        view = rows[:, idx[0]:idx[0] + len(idx)]
        view.flags.writeable = False
        return view
    return rows[:, idx]


def batch(particles: Dump, contacts: Dump | None, chosen: np.ndarray,
          body_types: Sequence[int] | None = (1,)) -> SnapshotData:
    """Arrays of several particle snapshots (and their contacts) for one vectorised pass."""
    chosen = np.asarray(chosen, dtype=np.int64)
    rows, psid = _rows(particles, chosen)
    cols = particles.columns
    pos = _columns(rows, cols, ("x", "y", "z"))
    vel = _columns(rows, cols, ("vx", "vy", "vz"))
    mass = rows[:, cols.index("mass")]
    radius = rows[:, cols.index("radius")]
    if body_types is not None and "type" in cols:
        body = np.isin(rows[:, cols.index("type")].astype(np.int64), np.asarray(body_types))
    else:
        body = np.ones(rows.shape[0], dtype=bool)
    boxes = particles.boxes[chosen]
    lengths = boxes[:, :, 1] - boxes[:, :, 0]
    periodic = tuple(flag.startswith("p") for flag in (particles.boundary + ("pp", "pp", "ff"))[:3])
    if contacts is not None:
        crow, csid = _rows(contacts, contact_index(particles, contacts, chosen))
        cc = contacts.columns
        r1 = _columns(crow, cc, ("x1", "y1", "z1"))
        r2 = _columns(crow, cc, ("x2", "y2", "z2"))
        force = _columns(crow, cc, ("fx", "fy", "fz"))
        branch = r1 - r2
        for axis in range(3):
            if periodic[axis]:
                # Minimum image: positions are wrapped into the box, contacts may cross a face.
                length = lengths[csid, axis]
                branch[:, axis] -= length * np.round(branch[:, axis] / length)
    else:
        r1 = branch = force = np.zeros((0, 3))
        csid = np.zeros(0, dtype=np.int64)
    return SnapshotData(pos, vel, mass, 4.0 / 3.0 * math.pi * radius**3, body, r1, branch, force, boxes[0], periodic,
                        psid, csid, lengths[:, 0] * lengths[:, 1], lengths)


def _window(start: np.ndarray, span: float, origin: float, step: float, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Grid indices (N, W) whose centres may lie in [start, start + span], and a validity mask."""
    first = np.ceil((start - origin) / step).astype(np.int64)
    width = int(math.floor(span / step)) + 2
    idx = first[:, None] + np.arange(width)[None, :]
    return idx, (idx >= 0) & (idx < n)


#: Window entries (rows x window points) computed in one vectorised step. Chunks this size keep
#: the temporaries in cache and below malloc's mmap threshold: one pass over fresh large arrays
#: costs as much in page faults as in arithmetic.
CHUNK = 16_384


def _chunks(rows: int | np.ndarray, width: int, chunk: int = CHUNK) -> list:
    """Row selections (slices, or index arrays when ``rows`` is an index array) of about ``chunk`` entries."""
    step = max(1, chunk // max(width, 1))
    if isinstance(rows, np.ndarray):
        return [rows[i:i + step] for i in range(0, rows.size, step)]
    return [slice(i, min(i + step, rows)) for i in range(0, rows, step)]


def _deposit(flat: np.ndarray, values: np.ndarray, size: int, weights: np.ndarray) -> np.ndarray:
    """``out[k, q] = sum_{i, j: flat[i, j] = k} values[i, j] weights[i, q]``, shape (size, q).

    One sparse (bins x rows) matrix built straight from the windows (every row owns a fixed
    number of entries, so the CSC structure needs no sorting), applied to all weight columns at
    once: the particle -> grid weights are computed once and reused for every field."""
    n = values.shape[0]
    if n == 0:
        return np.zeros((size, weights.shape[1]))
    width = values.size // n
    itype = np.int32 if max(size, values.size) < 2**31 - 1 else np.int64
    matrix = sp.csc_matrix((values.reshape(-1), flat.reshape(-1).astype(itype, copy=False),
                            np.arange(0, n * width + 1, width, dtype=itype)), shape=(size, n))
    return np.asarray(matrix @ weights)


def _index_type(size: int, entries: int) -> type:
    return np.int32 if max(size, entries) < 2**31 - 1 else np.int64


def _particle_weights(data: SnapshotData) -> tuple[np.ndarray, np.ndarray]:
    """Per-particle weights of the kernel sums (the first ten :data:`SUMS`) and of its derivative
    (``dmass``, ``dmom_x``)."""
    m, v = data.mass, data.vel
    mvx = m * v[:, 0]
    phi_w = np.column_stack([m, m * data.body, data.volume, mvx, m * v[:, 1], m * v[:, 2],
                             mvx * v[:, 0], m * v[:, 1] ** 2, m * v[:, 2] ** 2, mvx * v[:, 2]])
    return phi_w, np.column_stack([m, mvx])


#: Index pairs (a, b) of the contact sums c_xx, c_yy, c_zz, c_xz, c_zx (f_a r_b).
_CONTACT_AB = ((0, 0), (1, 1), (2, 2), (0, 2), (2, 0))
_PHI_SUMS = [SUMS.index(n) for n in ("mass", "mass_body", "volume", "mom_x", "mom_y", "mom_z",
                                     "mvv_xx", "mvv_yy", "mvv_zz", "mvv_xz")]
_DPHI_SUMS = [SUMS.index("dmass"), SUMS.index("dmom_x")]
_CONTACT_SUMS = [SUMS.index(n) for n in ("c_xx", "c_yy", "c_zz", "c_xz", "c_zx")]


def _contact_weights(data: SnapshotData, sl: slice | np.ndarray = slice(None)) -> np.ndarray:
    f, r = data.force[sl], data.branch[sl]
    return np.column_stack([f[:, a] * r[:, b] for a, b in _CONTACT_AB])


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
        for sl in _chunks(heights.size, self.width):
            hidx, _ = _window(heights[sl] - c, 2 * c, z0, dz, nz)
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
    flat = np.full((n, width), dummy, dtype=_index_type(dummy + 1, n * width))
    weight = np.zeros((n, width))
    if rows.size == 0:
        return flat, weight
    cdf = _CdfTable(kernel, np.concatenate([z1[rows], z2[rows]]), z0, dz, nz)
    m = rows.size
    for part in _chunks(np.arange(m), width):
        sel = rows[part]
        idx, ok = _window(lo[sel], span, z0, dz, nz)
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
    out = np.zeros((size + 1, len(_CONTACT_AB)))
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
        out += _deposit(flat, weight, size + 1, _contact_weights(sub))
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
    coeff = np.empty((heights.size, len(_CONTACT_AB)))
    for q, (a, b) in enumerate(_CONTACT_AB):
        g = f[:, a] * r[:, b] / r[:, 2]
        coeff[:, q] = np.bincount(group, np.concatenate([g, -g]), heights.size)
    low, high = (float(v) for v in np.asarray(kernel.cdf(np.array([-c, c])), dtype=np.float64).reshape(2))
    width = int(math.floor(2 * c / dz)) + 2
    table = np.empty((heights.size, width))
    flat = np.empty((heights.size, width), dtype=_index_type(size + 1, heights.size * width))
    above = np.empty(heights.size, np.int64)
    for sl in _chunks(heights.size, width):
        hidx, ok = _window(heights[sl] - c, 2 * c, z0, dz, nz)
        table[sl] = kernel.cdf(z0 + hidx * dz - heights[sl, None])
        table[sl] -= low
        flat[sl] = np.where(ok, hidx + (hsid[sl] * nz)[:, None], size)
        above[sl] = hidx[:, -1] + 1
    # C(z - h) = low + (table - low) on the window + (high - low) from the window's end upwards.
    out += _deposit(flat, table, size + 1, coeff)
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
        flat = np.empty((n, width), dtype=_index_type(size, n * width))
        for sl in _chunks(n, width):
            idx, ok = _window(z[sl] - c, 2 * c, z0, dz, nz)
            p, dp = kernel.pdf_dpdf(z0 + idx * dz - z[sl, None])
            p[~ok] = 0.0
            dp[~ok] = 0.0
            phi[sl], dphi[sl] = p, dp
            flat[sl] = np.where(ok, idx + (psid[sl] * nz)[:, None], dummy)
        phi_w, dphi_w = _particle_weights(data)
        out[:, _PHI_SUMS] = _deposit(flat, phi, size, phi_w)
        out[:, _DPHI_SUMS] = _deposit(flat, dphi, size, dphi_w)
    if data.force.shape[0]:
        out[:-1, _CONTACT_SUMS] = _contact_profile_sums(data, kernel, z0, dz, nz, csid, nsnap)
    out = out[:-1].reshape(nsnap, nz, len(SUMS)).transpose(0, 2, 1)
    if data.areas is None:
        return out[0] / float(np.prod(data.box[:2, 1] - data.box[:2, 0]))
    return out / data.areas[:, None, None]


def plane_sums(data: SnapshotData, kernel: Kernel, grid: Grid) -> np.ndarray:
    """The :data:`SUMS` on an x-z grid, per unit length in y: (len(SUMS), nx, nz) for one snapshot,
    or (snapshots, len(SUMS), nx, nz) for a batch (:func:`batch`), all snapshots in one pass.

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
    psid = np.zeros(data.mass.size, np.int64) if data.psid is None else data.psid
    csid = np.zeros(data.force.shape[0], np.int64) if data.csid is None else data.csid

    if data.mass.size:
        ix, _ = _window(data.pos[:, 0] - c, 2 * c, x0, dx, 10**18)
        if 2 * c >= lx.min():
            raise CoarseGrainError(f"kernel support 2 x {c:.3g} m exceeds the periodic length {lx.min():.3g} m")
        px = kernel.pdf(x0 + ix * dx - data.pos[:, 0:1])
        iz, okz = _window(data.pos[:, 2] - c, 2 * c, z0, dz, nz)
        pz, dpz = kernel.pdf_dpdf(z0 + iz * dz - data.pos[:, 2:3])
        pz[~okz] = 0.0
        dpz[~okz] = 0.0
        n = ix.shape[0]
        flat = np.where(okz[:, None, :], (ix % nx)[:, :, None] * nz + iz[:, None, :] + (psid * cells)[:, None, None],
                        nsnap * cells).reshape(n, -1)
        phi = (px[:, :, None] * pz[:, None, :]).reshape(n, -1)
        dphi = (px[:, :, None] * dpz[:, None, :]).reshape(n, -1)
        phi_w, dphi_w = _particle_weights(data)
        out[:, _PHI_SUMS] = _deposit(flat, phi, size, phi_w)
        out[:, _DPHI_SUMS] = _deposit(flat, dphi, size, dphi_w)

    def contact_part(sl: slice) -> None:
        r1, branch = data.r1[sl], data.branch[sl]
        x1, z1 = r1[:, 0], r1[:, 2]
        x2, z2 = x1 - branch[:, 0], z1 - branch[:, 2]  # x2 unwrapped next to x1
        spanx = float(np.max(np.abs(branch[:, 0]))) + 2 * c
        spanz = float(np.max(np.abs(branch[:, 2]))) + 2 * c
        ix, _ = _window(np.minimum(x1, x2) - c, spanx, x0, dx, 10**18)
        if spanx >= lx.min():
            raise CoarseGrainError(f"kernel support plus branch ({spanx:.3g} m) exceeds the periodic length "
                                   f"{lx.min():.3g} m")
        iz, okz = _window(np.minimum(z1, z2) - c, spanz, z0, dz, nz)
        xk = (x0 + ix * dx)[:, :, None]
        zk = (z0 + iz * dz)[:, None, :]
        shape = (len(ix), ix.shape[1], iz.shape[1])
        # Only on-grid points within c (in x and in z) of the branch's extent are evaluated: at
        # the others the path misses the support and the weight is exactly 0 (the windows are
        # sized for the chunk's longest branch). The slack of 1e-9 c only guards rounding.
        reach = c * (1.0 + 1e-9)
        xs, zs = xk[:, :, 0], zk[:, 0, :]
        near_x = (xs > np.minimum(x1, x2)[:, None] - reach) & (xs < np.maximum(x1, x2)[:, None] + reach)
        near_z = okz & (zs > np.minimum(z1, z2)[:, None] - reach) & (zs < np.maximum(z1, z2)[:, None] + reach)
        okb = near_x[:, :, None] & near_z[:, None, :]
        weight = np.zeros(shape)
        weight[okb] = segment_2d(kernel, np.broadcast_to(xk - x1[:, None, None], shape)[okb],
                                 np.broadcast_to(zk - z1[:, None, None], shape)[okb],
                                 np.broadcast_to(xk - x2[:, None, None], shape)[okb],
                                 np.broadcast_to(zk - z2[:, None, None], shape)[okb])
        weight = weight.reshape(len(ix), -1)
        flat = np.where(okb, (ix % nx)[:, :, None] * nz + iz[:, None, :] + (csid[sl] * cells)[:, None, None],
                        nsnap * cells).reshape(len(ix), -1)
        out[:, _CONTACT_SUMS] += _deposit(flat, weight, size, _contact_weights(data, sl))

    if data.force.shape[0]:
        # Chunks of about 4 CHUNK window entries keep the many temporaries of segment_2d in cache.
        wx = int(math.floor((float(np.max(np.abs(data.branch[:, 0]))) + 2 * c) / dx)) + 2
        wz = int(math.floor((float(np.max(np.abs(data.branch[:, 2]))) + 2 * c) / dz)) + 2
        for sl in _chunks(data.force.shape[0], wx * wz, 4 * CHUNK):
            contact_part(sl)
    out = out[:-1].reshape(nsnap, cells, len(SUMS)).transpose(0, 2, 1).reshape(nsnap, len(SUMS), nx, nz)
    if data.areas is None:
        return out[0] / ly[0]
    return out / ly[:, None, None, None]


# ---------------------------------------------------------------------------------------------
# Fields from sums


def derive(sums: np.ndarray, d: float, rho_s: float) -> dict[str, np.ndarray]:
    """Fields (see :data:`FIELDS`) from time-averaged :data:`SUMS` (first axis)."""
    s = {name: sums[k] for k, name in enumerate(SUMS)}
    rho = s["mass"]
    positive = rho > 0

    def ratio(num: np.ndarray, den: np.ndarray, ok: np.ndarray) -> np.ndarray:
        return np.divide(num, den, out=np.full(num.shape, np.nan), where=ok)

    u = {a: ratio(s[f"mom_{a}"], rho, positive) for a in "xyz"}
    kinetic = {ab: s[f"mvv_{ab}"] - np.where(positive, rho * u[ab[0]] * u[ab[1]], 0.0) for ab in ("xx", "yy", "zz", "xz")}
    sigma = {ab: s[f"c_{ab}"] + kinetic[ab] for ab in ("xx", "yy", "zz", "xz")}
    p = (sigma["xx"] + sigma["yy"] + sigma["zz"]) / 3.0
    shear_rate = ratio(s["dmom_x"] * rho - s["mom_x"] * s["dmass"], rho * rho, positive)
    loaded = p > 0
    mu = ratio(np.abs(sigma["xz"]), p, loaded)
    root = np.sqrt(np.where(loaded, p, 1.0) / rho_s)
    inertial = np.where(loaded, np.abs(np.nan_to_num(shear_rate)) * d / root, np.nan)
    inertial = np.where(np.isnan(shear_rate), np.nan, inertial)
    return {
        "nu": s["volume"], "rho": rho, "rho_body": s["mass_body"], "u_x": u["x"], "u_z": u["z"],
        "shear_rate": shear_rate,
        "sigma_xx": sigma["xx"], "sigma_yy": sigma["yy"], "sigma_zz": sigma["zz"], "sigma_xz": sigma["xz"],
        "sigma_xz_contact": s["c_xz"], "sigma_xz_kinetic": kinetic["xz"], "sigma_zx_contact": s["c_zx"],
        "sigma_zz_kinetic": kinetic["zz"], "p": p, "mu": mu, "I": inertial,
        "fluidity": ratio(shear_rate, mu, np.isfinite(mu) & (np.nan_to_num(mu) > 0)),
        "granular_temperature": ratio(kinetic["xx"] + kinetic["yy"] + kinetic["zz"], 3.0 * rho, positive),
    }


def block_average(stack: np.ndarray, blocks: int, d: float, rho_s: float) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray], int]:
    """Fields of the mean over snapshots (axis 0) and their standard errors.

    The error of each field is the larger of two estimates: the scatter of ``blocks`` consecutive
    block means over sqrt(blocks), and the standard deviation of the per-snapshot field times
    sqrt(2 tau / n), tau the integrated autocorrelation time (:func:`integrated_autocorrelation_time`).
    Block means alone understate the error when the correlation time is not short against a block
    (a load-controlled wall oscillates slowly); the autocorrelation estimate alone is noisy with
    few snapshots. Returns (fields, errors, blocks used). With fewer than 2 snapshots the errors are NaN."""
    n = stack.shape[0]
    used = min(blocks, n)
    if used < 2:
        fields = derive(stack.mean(axis=0), d, rho_s)
        return fields, {k: np.full_like(v, np.nan) for k, v in fields.items()}, used
    # The overall mean and the block means in one (elementwise) derive: SUMS on the first axis,
    # then [overall, block 1, ..., block B].
    parts = np.array_split(np.arange(n), used)
    means = np.stack([stack.mean(axis=0)] + [stack[idx].mean(axis=0) for idx in parts], axis=1)
    everything = derive(means, d, rho_s)
    with np.errstate(invalid="ignore", divide="ignore"):
        per_snapshot = derive(np.moveaxis(stack, 0, 1), d, rho_s)
    fields = {k: v[0] for k, v in everything.items()}
    errors = {}
    for name in fields:
        values = everything[name][1:]
        finite = np.all(np.isfinite(values), axis=0)
        safe = np.where(finite, values, 0.0)
        block_err = np.where(finite, safe.std(axis=0, ddof=1) / math.sqrt(used), np.nan)
        series = per_snapshot[name]
        good = np.all(np.isfinite(series), axis=0)
        clean = np.where(good, series, 0.0)
        tau = integrated_autocorrelation_time(clean)
        ac_err = np.where(good, clean.std(axis=0, ddof=1) * np.sqrt(2.0 * np.nan_to_num(tau, nan=0.5) / n), 0.0)
        errors[name] = np.where(finite, np.maximum(block_err, ac_err), np.nan)
    return fields, errors, used


@dataclass
class Result:
    """Coarse-grained fields with errors, the raw per-snapshot sums and timing."""

    dataset: xr.Dataset
    sums: np.ndarray  # (snapshots, len(SUMS), *grid shape)
    seconds: float


def coarse_grain(particles: Dump, contacts: Dump | None, kernel: Kernel, grid: Grid, *,
                 snapshots: np.ndarray | None = None, d: float | None = None, rho_s: float | None = None,
                 blocks: int = 5, time_step: float | None = None,
                 body_types: Sequence[int] | None = (1,)) -> Result:
    """Time-averaged fields over the chosen particle snapshots (default all), on ``grid``.

    ``d`` (m) defaults to the mean particle diameter and ``rho_s`` (kg m-3) to the mean particle
    density, both from the dump; ``time_step`` (s) converts timesteps to times in the attributes.
    """
    t0 = time.perf_counter()
    chosen = np.arange(len(particles)) if snapshots is None else np.asarray(snapshots, dtype=np.int64)
    if chosen.size == 0:
        raise CoarseGrainError("no snapshot in the averaging window")
    check_particle_rows(particles, chosen)
    radius = particles.column("radius")
    if d is None:
        d = float(2.0 * radius.mean())
    if rho_s is None:
        rho_s = float(np.mean(particles.column("mass") / (4.0 / 3.0 * math.pi * radius**3)))
    plane = grid.x is not None
    # Snapshots in batches of about BATCH_ROWS particle rows (x-z: 16 times fewer, each row has a
    # 2D window): one vectorised pass each.
    limit = BATCH_ROWS // 16 if plane else BATCH_ROWS
    sums_of = plane_sums if plane else profile_sums
    parts, rows = [], np.cumsum(particles.counts[chosen])
    groups = np.split(chosen, np.searchsorted(rows, np.arange(limit, rows[-1], limit)))
    for group in groups:
        if group.size:
            parts.append(sums_of(batch(particles, contacts, group, body_types), kernel, grid))
    sums = np.concatenate(parts)
    fields, errors, used = block_average(sums, blocks, d, rho_s)
    dims = ("x", "z") if plane else ("z",)
    coords = {"z": ("z", grid.z, {"units": "m", "long_name": "height (gradient direction, up)"})}
    if plane:
        coords["x"] = ("x", grid.x, {"units": "m", "long_name": "position along the flow (periodic)"})
    variables = {}
    for name, (units, long_name) in FIELDS.items():
        variables[name] = (dims, fields[name], {"units": units, "long_name": long_name})
        variables[f"{name}_err"] = (dims, errors[name], {"units": units, "long_name": f"standard error of {long_name}: "
                                                          f"the larger of {used} block means and the autocorrelation-time estimate"})
    steps = particles.timesteps[chosen]
    attrs: dict[str, Any] = {
        "kernel": kernel.name, "width": kernel.width, "kernel_cutoff": kernel.cutoff,
        "number_of_snapshots": int(chosen.size), "error_blocks": int(used), "d": d, "rho_s": rho_s,
        "timestep_first": int(steps[0]), "timestep_last": int(steps[-1]),
        "geometry": "plane_xz" if plane else "profile_z",
        "conventions": "compressive stress positive; x flow, z gradient (up), y vorticity; sigma_ab = sum f_a r_b "
                       "(x force across z planes for sigma_xz); mu = |sigma_xz| / p",
        "averaging": "profiles integrate x and y exactly over the periodic cell (per unit area); x-z fields integrate y"
                     if not plane else "fields integrate y exactly (per unit length of the periodic y)",
        "contacts_included": int(contacts is not None),
    }
    if time_step is not None:
        attrs["time_window"] = np.array([steps[0] * time_step, steps[-1] * time_step])
        attrs["time_step"] = time_step
    dataset = xr.Dataset(variables, coords=coords, attrs=attrs)
    return Result(dataset, sums, time.perf_counter() - t0)


def write_netcdf(ds: xr.Dataset, path: Path) -> None:
    """Write a fields dataset atomically with its CF metadata (:func:`pipeline.common.atomic.write_netcdf`)."""
    atomic.write_netcdf(ds, Path(path), title="granular-validate coarse-grained fields")
